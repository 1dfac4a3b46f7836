"""An eager PyTorch twin of the stitchjax model and train step, written the way a PyTorch user would.

Same networks and layer sizes as ``stitchjax.networks`` (S-CVAE encoders, LSTM cell, latent heads,
latent interpolation, mixture-of-experts decoder with a gating MLP on the phase features — or a plain MLP
decoder — the phase network, the two LSGAN discriminators), the same bidirectional aligned rollout with
stitching as ``stitchjax.rollout`` (a Python loop over frames, batched over windows), the same losses as
``stitchjax.losses``, and ``torch.optim.AdamW`` with the config's settings for the generators and the
discriminators. It exists to measure stitchjax against (benchmarks/run_all.py); it is not part of the
package, and PyTorch is only an optional extra (``pip install -e '.[bench]'``).

Differences that are natural in eager code and change no result: the loop runs only the steps the given
transition length needs (stitchjax scans a static maximum and masks), and losses/discriminators look at
the L + 2 frames of the transition only (stitchjax masks the frames past them).

    twin = Twin(config)                       # a stitchjax Config
    twin.load_flax(params, phase_params)      # copy stitchjax parameters in
    loss, terms = twin.generator_loss(batch, length, eps)   # eps: (B, n, 2, latent) pre-drawn noise
    twin.train_step(batch, length)            # one full update (generators + discriminators)

``jax_noise(key, batch_size, config, max_length)`` draws the noise stitchjax's rollout uses for a key, so both
implementations can be fed the same samples (``check_equal_loss`` does exactly that).
"""
from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
import torch
from torch import nn
import torch.nn.functional as Fn

__all__ = ["Twin", "Generator", "Discriminator", "PhaseNet", "batch_to_torch", "jax_noise", "check_equal_loss",
           "matmul_flops", "num_steps"]

_ACTIVATIONS = {"elu": nn.ELU, "relu": nn.ReLU, "gelu": nn.GELU, "silu": nn.SiLU, "tanh": nn.Tanh,
                "leaky_relu": lambda: nn.LeakyReLU(0.2)}


def _gelu_exact_check(name: str):
    if name == "gelu":  # flax nn.gelu is the tanh approximation by default
        return lambda: nn.GELU(approximate="tanh")
    return _ACTIVATIONS[name]


def mlp(sizes, activation: str, activate_last: bool = True) -> nn.Sequential:
    """Linear layers in_dim -> sizes[1] -> ... with the activation after each (or all but the last)."""
    make = _gelu_exact_check(activation)
    layers = []
    for i in range(len(sizes) - 1):
        layers.append(nn.Linear(sizes[i], sizes[i + 1]))
        if activate_last or i < len(sizes) - 2:
            layers.append(make())
    return nn.Sequential(*layers)


class MoELayer(nn.Module):
    """E expert linear layers; output = sum_e c_e (x W_e + b_e) (blend of the expert outputs)."""

    def __init__(self, in_features: int, out_features: int, num_experts: int):
        super().__init__()
        self.weight = nn.Parameter(torch.randn(num_experts, in_features, out_features) / math.sqrt(in_features))
        self.bias = nn.Parameter(torch.zeros(num_experts, out_features))

    def forward(self, x, coefficients):
        outputs = torch.einsum("bi,eio->beo", x, self.weight) + self.bias
        return torch.einsum("be,beo->bo", coefficients, outputs)


class Generator(nn.Module):
    """One S-CVAE generator (one direction). ``forward`` is one autoregressive step for a batch."""

    def __init__(self, config):
        super().__init__()
        m, d = config.model, config.data
        self.config = config
        joints = d.num_joints
        state = joints * 4 + 3 + d.num_contacts
        offset = joints * 4 + 3 + (1 if m.time_to_target_input else 0)
        widths = list(m.encoder_widths)
        self.state_encoder = mlp([state] + widths, m.activation)
        self.offset_encoder = mlp([offset] + widths, m.activation)
        self.target_encoder = mlp([state] + widths, m.activation)
        self.lstm = nn.LSTMCell(3 * widths[-1], m.lstm_size)
        self.current_head = nn.Linear(m.lstm_size, 2 * m.latent_dim)
        self.target_head = nn.Linear(m.lstm_size, 2 * m.latent_dim)
        dec_in = m.latent_dim + 2 * state + (m.lstm_size if m.decoder_uses_lstm else 0)
        num_out = 3 + joints * 4 + d.num_contacts
        sizes = [dec_in] + list(m.decoder_widths) + [num_out]
        if m.phase_modulation:
            self.gating = mlp([2 * d.num_contacts] + list(m.gating_widths) + [m.num_experts], m.activation,
                              activate_last=False)
            self.experts = nn.ModuleList(MoELayer(sizes[i], sizes[i + 1], m.num_experts)
                                         for i in range(len(sizes) - 1))
            self.act = _gelu_exact_check(m.activation)()
        else:
            self.decoder = mlp(sizes, m.activation, activate_last=False)

    def forward(self, carry, state, target, offset, gamma, phase, eps):
        m = self.config.model
        latent = m.latent_dim
        x = torch.cat([self.state_encoder(state), self.offset_encoder(offset), self.target_encoder(target)], -1)
        c, h = carry
        h, c = self.lstm(x, (h, c))
        cur = self.current_head(h)
        tgt = self.target_head(h)
        mu, logvar = cur[:, :latent], cur[:, latent:]
        mu_t, logvar_t = tgt[:, :latent], tgt[:, latent:]
        if m.latent_interpolation:
            mean = (1 - gamma) * mu + gamma * mu_t
            if m.variance_blend == "std":
                std = (1 - gamma) * torch.exp(0.5 * logvar) + gamma * torch.exp(0.5 * logvar_t)
                mu_b, logvar_b = mean, 2.0 * torch.log(std)
            else:
                var = (1 - gamma) ** 2 * torch.exp(logvar) + gamma ** 2 * torch.exp(logvar_t)
                mu_b, logvar_b = mean, torch.log(var)
        else:
            mu_b, logvar_b = mu, logvar
        z = mu_b + torch.exp(0.5 * logvar_b) * eps
        y = torch.cat([z, state, target] + ([h] if m.decoder_uses_lstm else []), -1)
        if m.phase_modulation:
            coefficients = torch.softmax(self.gating(phase), -1)
            for i, layer in enumerate(self.experts):
                y = layer(y, coefficients)
                if i < len(self.experts) - 1:
                    y = self.act(y)
        else:
            y = self.decoder(y)
        return (c, h), y, (mu_b, logvar_b)


class Discriminator(nn.Module):
    """Temporal conv (kernel = window frames) + dense layers, leaky ReLU 0.2, one score per position."""

    def __init__(self, in_features: int, window: int, widths):
        super().__init__()
        self.window = window
        self.conv = nn.Conv1d(in_features, widths[0], window)
        sizes = list(widths) + [1]
        self.dense = nn.ModuleList(nn.Linear(sizes[i], sizes[i + 1]) for i in range(len(sizes) - 1))

    def forward(self, features):  # (B, T, F) -> (B, T - window + 1)
        x = Fn.leaky_relu(self.conv(features.transpose(1, 2)).transpose(1, 2), 0.2)
        for i, layer in enumerate(self.dense):
            x = layer(x)
            if i < len(self.dense) - 1:
                x = Fn.leaky_relu(x, 0.2)
        return x[..., 0]


class PhaseNet(nn.Module):
    """Phase network: state (S) -> ELU MLP -> P phase features."""

    def __init__(self, state_dim: int, hidden, outputs: int):
        super().__init__()
        self.net = mlp([state_dim] + list(hidden) + [outputs], "elu", activate_last=False)

    def forward(self, state):
        return self.net(state)


# ------------------------------------------------------------------------------------------ geometry


def quat_normalize(q, eps: float = 1e-8):
    return q / torch.sqrt((q * q).sum(-1, keepdim=True) + eps * eps)


def quat_mul(a, b):
    aw, ax, ay, az = a.unbind(-1)
    bw, bx, by, bz = b.unbind(-1)
    return torch.stack([aw * bw - ax * bx - ay * by - az * bz,
                        aw * bx + ax * bw + ay * bz - az * by,
                        aw * by - ax * bz + ay * bw + az * bx,
                        aw * bz + ax * by - ay * bx + az * bw], -1)


def quat_rotate(q, v):
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * torch.cross(u, v, dim=-1)
    return v + w * t + torch.cross(u, t, dim=-1)


def forward_kinematics(rotations, local_positions, parents):
    """(..., J, 4) local quats, (..., J, 3) local positions -> global positions (..., J, 3); joint by joint."""
    grot = [rotations[..., 0, :]]
    gpos = [local_positions[..., 0, :]]
    for j in range(1, len(parents)):
        p = parents[j]
        gpos.append(quat_rotate(grot[p], local_positions[..., j, :]) + gpos[p])
        grot.append(quat_mul(grot[p], rotations[..., j, :]))
    return torch.stack(gpos, -2)


# ------------------------------------------------------------------------------------------ the model


def num_steps(config, max_length: int) -> int:
    """stitchjax's static scan length (its noise array has this many steps)."""
    if config.model.bidirectional:
        return (max_length + 1) // 2 + config.model.stitch_buffer
    return max_length


def schedule(config, length: int):
    if not config.model.bidirectional:
        return length, 0, length, 0
    h = length // 2
    k = min(config.model.stitch_buffer, h)
    return h, k, h + k, length - h + k


class Twin:
    """Generators, discriminators, phase network and AdamW optimisers; train step and inference."""

    def __init__(self, config, threads: int | None = None):
        if threads:
            torch.set_num_threads(threads)
        self.config = config
        m, d = config.model, config.data
        state = d.num_joints * 4 + 3 + d.num_contacts
        # plain dicts (nn.ModuleDict cannot hold a key named "forward"); parameters via ModuleLists
        self.generators = {"forward": Generator(config), "backward": Generator(config)}
        disc_in = (d.num_joints - 1) * 3 + 3
        self.discriminators = {"disc_short": Discriminator(disc_in, m.disc_short_window, m.disc_widths),
                               "disc_long": Discriminator(disc_in, m.disc_long_window, m.disc_widths)}
        self.generator_modules = nn.ModuleList(self.generators.values())
        self.discriminator_modules = nn.ModuleList(self.discriminators.values())
        self.phase_net = PhaseNet(state, (config.phase.hidden_dim,) * config.phase.num_layers,
                                  2 * d.num_contacts)
        self.phase_net.requires_grad_(False)  # frozen after pretraining
        tc = config.train
        kwargs = dict(lr=tc.learning_rate, betas=(tc.adam_b1, tc.adam_b2), eps=1e-8, weight_decay=tc.weight_decay)
        self.gen_opt = torch.optim.AdamW(self.generator_modules.parameters(), **kwargs)
        self.disc_opt = torch.optim.AdamW(self.discriminator_modules.parameters(), **kwargs)

    # -------------------------------------------------------------------------------- parameters

    @torch.no_grad()
    def load_flax(self, params: dict, phase_params: Any = None) -> None:
        """Copy stitchjax parameters ({"forward", "backward", "disc_short", "disc_long"}) into the twin."""
        def t(x):
            return torch.from_numpy(np.array(x, dtype=np.float32))

        def load_linear(layer: nn.Linear, p):
            layer.weight.copy_(t(p["kernel"]).T)
            layer.bias.copy_(t(p["bias"]))

        def load_mlp(seq: nn.Sequential, p, prefix="dense_"):
            linears = [layer for layer in seq if isinstance(layer, nn.Linear)]
            for i, layer in enumerate(linears):
                load_linear(layer, p[f"{prefix}{i}"])

        m = self.config.model
        for name in ("forward", "backward"):
            p = params[name]["params"]
            g = self.generators[name]
            for enc in ("state_encoder", "offset_encoder", "target_encoder"):
                load_mlp(getattr(g, enc), p[enc])
            lstm = p["lstm"]
            g.lstm.weight_ih.copy_(t(lstm["input_kernel"]).T)  # fused gates, order i, f, g, o in both
            g.lstm.weight_hh.copy_(t(lstm["hidden_kernel"]).T)
            g.lstm.bias_hh.copy_(t(lstm["bias"]))
            g.lstm.bias_ih.zero_()
            load_linear(g.current_head, p["current_head"])
            load_linear(g.target_head, p["target_head"])
            if m.phase_modulation:
                load_mlp(g.gating, p["gating"])
                for i, layer in enumerate(g.experts):
                    layer.weight.copy_(t(p[f"expert_{i}"]["kernel"]).permute(1, 0, 2))  # (in, E, out) -> (E, in, out)
                    layer.bias.copy_(t(p[f"expert_{i}"]["bias"]))
            else:
                load_mlp(g.decoder, p["decoder"])
        for name in ("disc_short", "disc_long"):
            if name not in params:  # an inference model holds the generators only
                continue
            p = params[name]["params"]
            d = self.discriminators[name]
            d.conv.weight.copy_(t(p["temporal_conv"]["kernel"]).permute(2, 1, 0))
            d.conv.bias.copy_(t(p["temporal_conv"]["bias"]))
            for i, layer in enumerate(d.dense):
                load_linear(layer, p[f"dense_{i}"] if i < len(d.dense) - 1 else p["score"])
        if phase_params:
            pp = phase_params.get("params", phase_params)
            load_mlp(self.phase_net.net, {**{f"hidden_{i}": pp[f"hidden_{i}"] for i in range(len(pp) - 1)},
                                          f"hidden_{len(pp) - 1}": pp["output"]}, prefix="hidden_")
            self.has_phase = True
        else:
            self.has_phase = False

    # -------------------------------------------------------------------------------- rollout

    def _step(self, gen: Generator, carry, current, target, distance: float, gamma: float, eps):
        d = self.config.data
        batch = current["rotations"].shape[0]
        state = torch.cat([current["rotations"].flatten(1), current["velocity"], current["contacts"]], -1)
        target_state = torch.cat([target["rotations"].flatten(1), target["velocity"], target["contacts"]], -1)
        offset = torch.cat([(target["rotations"] - current["rotations"]).flatten(1),
                            (target["root"] - current["root"]) / d.position_scale], -1)
        if self.config.model.time_to_target_input:
            offset = torch.cat([offset, torch.full((batch, 1), distance / d.fps)], -1)
        if self.config.model.phase_modulation and getattr(self, "has_phase", True):
            phase = self.phase_net(state.detach())
        else:
            phase = torch.zeros(batch, 2 * d.num_contacts)
        carry, y, gaussian = gen(carry, state, target_state, offset, gamma, phase, eps)
        n = d.num_joints * 4
        velocity = y[:, :3]
        frame = {"rotations": quat_normalize(current["rotations"] + y[:, 3:3 + n].reshape(batch, d.num_joints, 4)),
                 "root": current["root"] + velocity * d.velocity_scale,
                 "velocity": velocity,
                 "contacts": torch.sigmoid(y[:, 3 + n:])}
        return carry, frame, gaussian

    def rollout(self, start: dict, target: dict, offsets, length: int, eps):
        """Bidirectional aligned rollout + stitching for a batch.

        start/target: dicts "rotations" (B, J, 4), "root_position" (B, 3), "contacts" (B, C);
        offsets (B, J, 3); eps (B, n >= steps, 2, latent). Returns the stitched motion of L + 2 frames
        ("rotations", "root_positions", "contacts", "global_positions"), per-direction sequences and the
        overlap positions.
        """
        m, d = self.config.model, self.config.data
        parents = tuple(d.parents)
        batch = start["rotations"].shape[0]
        h, k, n_fwd, n_bwd = schedule(self.config, length)
        steps = max(n_fwd, n_bwd)
        zeros = torch.zeros(batch, 3)
        start_frame = {"rotations": start["rotations"], "root": start["root_position"], "velocity": zeros,
                       "contacts": start["contacts"]}
        target_frame = {"rotations": target["rotations"], "root": target["root_position"], "velocity": zeros,
                        "contacts": target["contacts"]}
        carry0 = (torch.zeros(batch, m.lstm_size), torch.zeros(batch, m.lstm_size))
        fwd, bwd = start_frame, target_frame
        fwd_carry, bwd_carry = carry0, carry0
        seqs = {"forward": [], "backward": []}
        gauss = {"forward": [], "backward": []}
        bidir, aligned = m.bidirectional, m.bidirectional_aligning

        def reverse(frame):
            return {**frame, "velocity": -frame["velocity"]}

        for i in range(steps):
            gamma = min(max((i + 1) / (length + 1), 0.0), 1.0)
            if i < n_fwd:
                if bidir and aligned:
                    f_target, f_dist = reverse(bwd), length + 1 - 2 * i
                else:
                    f_target, f_dist = target_frame, length + 1 - i
                fwd_carry, fwd, g = self._step(self.generators["forward"], fwd_carry, fwd, f_target, f_dist,
                                               gamma, eps[:, i, 0])
                seqs["forward"].append(fwd)
                gauss["forward"].append(g)
            if bidir and i < n_bwd:
                if aligned:
                    b_target, b_dist = reverse(fwd), length - 2 * i
                else:
                    b_target, b_dist = start_frame, length + 1 - i
                bwd_carry, bwd, g = self._step(self.generators["backward"], bwd_carry, bwd, b_target, b_dist,
                                               gamma, eps[:, i, 1])
                seqs["backward"].append(bwd)
                gauss["backward"].append(g)

        def stack(first, frames):
            return {key: torch.stack([first[key]] + [f[key] for f in frames], 1) for key in first}

        fwd_all = stack(start_frame, seqs["forward"])  # entry t = frame t
        bwd_all = stack(target_frame, seqs["backward"]) if bidir else fwd_all  # entry r = frame L + 1 - r
        t = np.arange(length + 2)
        fi = np.clip(t, 0, fwd_all["rotations"].shape[1] - 1)
        bi = np.clip(length + 1 - t, 0, bwd_all["rotations"].shape[1] - 1)
        if bidir:
            w = torch.from_numpy(np.clip((t - (h - k)) / (2 * k + 1), 0, 1).astype(np.float32))
        else:
            w = torch.zeros(length + 2)
        q_f, q_b = fwd_all["rotations"][:, fi], bwd_all["rotations"][:, bi]
        sign = torch.where((q_f * q_b).sum(-1, keepdim=True) < 0, -1.0, 1.0)
        rot = quat_normalize((1 - w)[:, None, None] * q_f + w[:, None, None] * sign * q_b)
        root = (1 - w)[:, None] * fwd_all["root"][:, fi] + w[:, None] * bwd_all["root"][:, bi]
        contacts = (1 - w)[:, None] * fwd_all["contacts"][:, fi] + w[:, None] * bwd_all["contacts"][:, bi]
        rot = torch.cat([start["rotations"][:, None], rot[:, 1:-1], target["rotations"][:, None]], 1)
        root = torch.cat([start["root_position"][:, None], root[:, 1:-1], target["root_position"][:, None]], 1)
        contacts = torch.cat([start["contacts"][:, None], contacts[:, 1:-1], target["contacts"][:, None]], 1)

        def fk(rotations, roots):
            local = offsets[:, None].expand(-1, rotations.shape[1], -1, -1).clone()
            local[:, :, 0] = roots
            return forward_kinematics(rotations, local, parents)

        out = {"rotations": rot, "root_positions": root, "contacts": contacts, "global_positions": fk(rot, root)}
        pos = {"forward": fk(fwd_all["rotations"], fwd_all["root"])}
        if bidir:
            pos["backward"] = fk(bwd_all["rotations"], bwd_all["root"])
        for name in pos:
            frames = seqs[name]
            count = n_fwd if name == "forward" else n_bwd
            if count == 0:  # L = 1: the forward generator makes no frame
                out[name] = None
                continue
            out[name] = {"rotations": torch.stack([f["rotations"] for f in frames], 1)[:, :count],
                         "velocities": torch.stack([f["velocity"] for f in frames], 1)[:, :count],
                         "contacts": torch.stack([f["contacts"] for f in frames], 1)[:, :count],
                         "global_positions": pos[name][:, 1:count + 1],
                         "mu_blend": torch.stack([g[0] for g in gauss[name]], 1)[:, :count],
                         "logvar_blend": torch.stack([g[1] for g in gauss[name]], 1)[:, :count]}
        if bidir and k > 0:
            frames = h - k + 1 + np.arange(2 * k)
            out["overlap"] = (pos["forward"][:, np.clip(frames, 0, pos["forward"].shape[1] - 1)],
                              pos["backward"][:, np.clip(length + 1 - frames, 0, pos["backward"].shape[1] - 1)])
        else:
            out["overlap"] = None
        return out

    # -------------------------------------------------------------------------------- losses

    def disc_features(self, global_positions, root_positions):
        d = self.config.data
        rel = (global_positions[:, :, 1:] - global_positions[:, :, :1]) / d.position_scale
        vel = torch.cat([torch.zeros_like(root_positions[:, :1]), root_positions[:, 1:] - root_positions[:, :-1]],
                        1) / d.velocity_scale
        return torch.cat([rel.flatten(2), vel], -1)

    def _norm1(self, x, dims):
        return x.abs().sum(dims) if self.config.loss.reduction == "sum" else x.abs().mean(dims)

    def _targets(self, batch, length: int, count: int, backward: bool):
        i = np.arange(count + 1)
        frames = np.clip((length + 1 - i) if backward else i, 0, batch["rotations"].shape[1] - 1)
        root = batch["root_positions"][:, frames]
        return {"rotations": batch["rotations"][:, frames][:, 1:],
                "velocities": (root[:, 1:] - root[:, :-1]) / self.config.data.velocity_scale,
                "contacts": batch["contacts"][:, frames][:, 1:],
                "global_positions": batch["global_positions"][:, frames][:, 1:]}

    def generator_loss(self, batch: dict, length: int, eps):
        """(total, terms, fake discriminator features) for a batch dict of tensors (B, T, ...)."""
        lc, d, m = self.config.loss, self.config.data, self.config.model
        start = {"rotations": batch["rotations"][:, 0], "root_position": batch["root_positions"][:, 0],
                 "contacts": batch["contacts"][:, 0]}
        target = {"rotations": batch["rotations"][:, length + 1],
                  "root_position": batch["root_positions"][:, length + 1],
                  "contacts": batch["contacts"][:, length + 1]}
        out = self.rollout(start, target, batch["offsets"][:, 0], length, eps)
        directions = ["forward"] + (["backward"] if m.bidirectional else [])
        terms: dict[str, torch.Tensor] = {}
        for name in directions:
            o = out[name]
            if o is None:  # no frame in this direction: every term is an empty mean, 0 as in stitchjax
                for term in ("state", "kl", "fk"):
                    terms[f"{term}_{name}"] = torch.zeros(())
                continue
            tg = self._targets(batch, length, o["rotations"].shape[1], name == "backward")
            rot = self._norm1(o["rotations"] - tg["rotations"], (-2, -1)).mean()
            vel = self._norm1(o["velocities"] - tg["velocities"], -1).mean()
            con = self._norm1(o["contacts"] - tg["contacts"], -1).mean()
            kl = 0.5 * (o["mu_blend"] ** 2 + torch.exp(o["logvar_blend"]) - 1.0 - o["logvar_blend"])
            kl = (kl.sum(-1) if lc.reduction == "sum" else kl.mean(-1)).mean()
            fk = self._norm1((o["global_positions"] - tg["global_positions"]) / d.position_scale, (-2, -1)).mean()
            terms[f"state_{name}"] = lc.beta_rotation * rot + lc.beta_velocity * vel + lc.beta_contact * con
            terms[f"kl_{name}"], terms[f"fk_{name}"] = kl, fk
        for term in ("state", "kl", "fk"):
            terms[term] = sum(terms[f"{term}_{n}"] for n in directions) / len(directions)
        if out["overlap"] is not None:
            a, b = out["overlap"]
            terms["stitch"] = self._norm1((a - b) / d.position_scale, (-2, -1)).mean()
        else:
            terms["stitch"] = torch.zeros(())
        fake = self.disc_features(out["global_positions"], out["root_positions"])
        total = lc.kl_weight * terms["kl"] + lc.stitch_weight * terms["stitch"] + lc.fk_weight * terms["fk"]
        total = total + terms["state"]
        if lc.gen_weight:
            for name in ("disc_short", "disc_long"):
                disc = self.discriminators[name]
                # a transition shorter than the window has no window position: the term is 0
                term = (0.5 * ((disc(fake) - 1) ** 2).mean() if fake.shape[1] >= disc.window
                        else torch.zeros(()))
                terms["adv_g_" + name[5:]] = term
                total = total + lc.gen_weight * term
        return total, terms, fake

    def discriminator_loss(self, batch: dict, fake):
        frames = fake.shape[1]
        real = self.disc_features(batch["global_positions"][:, :frames], batch["root_positions"][:, :frames])
        fake = fake.detach()
        total = 0.0
        for name in ("disc_short", "disc_long"):
            disc = self.discriminators[name]
            if frames >= disc.window:
                total = total + 0.5 * ((disc(real) - 1) ** 2).mean() + 0.5 * (disc(fake) ** 2).mean()
        return self.config.loss.disc_weight * torch.as_tensor(total)

    # -------------------------------------------------------------------------------- train / infer

    def train_step(self, batch: dict, length: int, eps=None, rng=None) -> dict:
        """One update of both generators and both discriminators; returns float losses."""
        if eps is None:
            rng = rng or np.random.default_rng()
            n = schedule(self.config, length)
            steps = max(n[2], n[3])
            eps = torch.from_numpy(rng.standard_normal(
                (batch["rotations"].shape[0], steps, 2, self.config.model.latent_dim), dtype=np.float32))
        self.discriminator_modules.requires_grad_(False)
        self.gen_opt.zero_grad(set_to_none=True)
        loss, terms, fake = self.generator_loss(batch, length, eps)
        loss.backward()
        self.gen_opt.step()
        self.discriminator_modules.requires_grad_(True)
        self.disc_opt.zero_grad(set_to_none=True)
        disc_loss = self.discriminator_loss(batch, fake)
        disc_loss.backward()
        self.disc_opt.step()
        return {"loss": loss.item(), "disc_loss": disc_loss.item()}

    def make_inference(self, data: dict, length: int, samples: int, seed: int = 0):
        """A function running ``samples`` transitions of ``length`` frames between window 0's frames 0
        and length + 1 of ``data`` (numpy, from run_all.synthetic_dataset) without autograd."""
        def kf(i):
            return {"rotations": torch.from_numpy(data["rotations"][0, i][None]).expand(samples, -1, -1),
                    "root_position": torch.from_numpy(data["root_positions"][0, i][None]).expand(samples, -1),
                    "contacts": torch.from_numpy(data["contacts"][0, i][None]).expand(samples, -1)}

        start, target = kf(0), kf(length + 1)
        offsets = torch.from_numpy(data["offsets"][0, 0][None]).expand(samples, -1, -1)
        generator = torch.Generator().manual_seed(seed)
        h, k, n_fwd, n_bwd = schedule(self.config, length)

        def run():
            with torch.inference_mode():
                eps = torch.randn(samples, max(n_fwd, n_bwd), 2, self.config.model.latent_dim, generator=generator)
                out = self.rollout(start, target, offsets, length, eps)
                return out["global_positions"]

        return run


# ------------------------------------------------------------------------------------------ helpers


def batch_to_torch(dataset: dict, indices) -> dict:
    """Select windows ``indices`` of a prepared (numpy) dataset as float32 torch tensors."""
    return {key: torch.from_numpy(np.ascontiguousarray(np.asarray(value)[np.asarray(indices)], dtype=np.float32))
            for key, value in dataset.items()}


def jax_noise(key, batch_size: int, config, max_length: int) -> np.ndarray:
    """The latent noise (B, n, 2, latent) stitchjax's ``rollout_batch`` draws from ``key``."""
    import jax

    n = num_steps(config, max_length)
    keys = jax.random.split(key, batch_size)
    eps = jax.vmap(lambda k: jax.random.normal(k, (n, 2, config.model.latent_dim)))(keys)
    return np.asarray(eps)


@functools.lru_cache(maxsize=8)
def _jax_losses(config):
    """stitchjax's generator + discriminator losses, jitted once per config (length is traced)."""
    import jax
    from stitchjax import losses

    def both(params, phase_params, batch, key, length):
        total, terms, generated = losses.generator_loss(params, phase_params, batch, key, config, length)
        disc_total, _ = losses.discriminator_loss(params, phase_params, batch, key, config, length, generated)
        return total, terms, disc_total

    return jax.jit(both)


def check_equal_loss(config, params, phase_params, batch_np: dict, length: int, key) -> dict:
    """Generator and discriminator losses of stitchjax and the twin on the same weights, batch and noise.

    batch_np: numpy dict (B, T, ...) as from ``features.prepare_dataset``. Returns
    {"jax_loss", "torch_loss", "jax_terms", "torch_terms", "jax_disc_loss", "torch_disc_loss"}.
    """
    import jax.numpy as jnp

    batch_j = {k_: jnp.asarray(v) for k_, v in batch_np.items()}
    total, terms, disc_total = _jax_losses(config)(params, phase_params, batch_j, key, jnp.int32(length))
    twin = Twin(config)
    twin.load_flax(params, phase_params)
    batch_t = batch_to_torch(batch_np, np.arange(batch_np["rotations"].shape[0]))
    eps = torch.from_numpy(np.array(jax_noise(key, batch_np["rotations"].shape[0], config,
                                              batch_np["rotations"].shape[1] - 2)))
    with torch.no_grad():
        t_total, t_terms, fake = twin.generator_loss(batch_t, length, eps)
        t_disc = twin.discriminator_loss(batch_t, fake)
    return {"jax_loss": float(total), "torch_loss": float(t_total),
            "jax_terms": {k_: float(terms[k_]) for k_ in t_terms},
            "torch_terms": {k_: float(v) for k_, v in t_terms.items()},
            "jax_disc_loss": float(disc_total), "torch_disc_loss": float(t_disc)}


def matmul_flops(config, batch: int, length: int) -> dict:
    """Hand count of the matmul FLOPs (2 per multiply-add) of one train step at transition length L.

    Counts what stitchjax's compiled step does: a scan of n = num_steps(config, L) steps per generator
    (the masked steps are computed too), forward pass = 2*B*n*(per-step MACs), backward pass = 2x forward
    (input and weight gradients), except that the phase network is frozen and gets no weight gradient
    (its input gradient is stopped too, so no backward at all); the discriminators: once on the fake
    motion inside the generator loss (forward + input gradient), twice (real, fake) in their own update
    (forward + weight gradient). Biases, activations, FK and losses are not matmuls and not counted.
    """
    m, d = config.model, config.data
    state = d.num_joints * 4 + 3 + d.num_contacts
    offset = d.num_joints * 4 + 3 + (1 if m.time_to_target_input else 0)

    def chain(sizes):
        return sum(sizes[i] * sizes[i + 1] for i in range(len(sizes) - 1))

    enc = list(m.encoder_widths)
    per_step = {
        "encoders": chain([state] + enc) * 2 + chain([offset] + enc),
        "lstm": (3 * enc[-1] + m.lstm_size) * 4 * m.lstm_size,
        "heads": 2 * m.lstm_size * 2 * m.latent_dim,
    }
    dec_in = m.latent_dim + 2 * state + (m.lstm_size if m.decoder_uses_lstm else 0)
    sizes = [dec_in] + list(m.decoder_widths) + [3 + d.num_joints * 4 + d.num_contacts]
    if m.phase_modulation:
        per_step["experts"] = m.num_experts * chain(sizes) + sum(m.num_experts * s for s in sizes[1:])  # + blend
        per_step["gating"] = chain([2 * d.num_contacts] + list(m.gating_widths) + [m.num_experts])
        phase_macs = chain([state] + [config.phase.hidden_dim] * config.phase.num_layers + [2 * d.num_contacts])
    else:
        per_step["decoder"] = chain(sizes)
        phase_macs = 0
    steps = num_steps(config, length)
    gens = 2 if m.bidirectional else 1
    gen_macs = sum(per_step.values())
    generator_fwd = 2.0 * batch * steps * gens * gen_macs
    phase_fwd = 2.0 * batch * steps * gens * phase_macs
    frames = length + 2
    feat = (d.num_joints - 1) * 3 + 3
    disc_fwd = 0.0
    for window in (m.disc_short_window, m.disc_long_window):
        positions = frames - window + 1
        disc_fwd += 2.0 * batch * positions * (window * feat * m.disc_widths[0] + chain(list(m.disc_widths) + [1]))
    total = 3 * generator_fwd + phase_fwd + 2 * disc_fwd + 2 * 2 * disc_fwd
    return {"total": total, "generator_forward": generator_fwd, "phase_forward": phase_fwd,
            "disc_forward_one_pass": disc_fwd, "per_step_macs_per_example": per_step, "scan_steps": steps}
