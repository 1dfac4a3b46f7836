"""An eager PyTorch twin of the stitchjax model and train step, written the way a PyTorch user would.

Same networks and layer sizes as ``stitchjax.model.networks`` (S-CVAE encoders, LSTM cell, latent heads,
latent interpolation prior, the recognition network q(z | LSTM state, next frame), mixture-of-experts
decoder with a gating MLP on the phase features, or a plain MLP decoder, z fed to every decoder layer,
the phase network, the two LSGAN discriminators), the same bidirectional aligned rollout with stitching as
``stitchjax.model.rollout`` (a Python loop over frames, batched over windows), the same losses as
``stitchjax.model.losses`` and ``objective`` (state, KL(q || p) with free bits and warm-up or the prior's KL, FK,
stitching, LSGAN, foot skate), and ``torch.optim.AdamW`` with the config's settings for the generators and the
discriminators. It exists to measure stitchjax against (benchmarks/run_all.py); it is not part of the
package, and PyTorch is only an optional extra (``pip install -e '.[bench]'``).

Config fields it does not mirror raise :class:`UnsupportedConfig` when the twin is built
(:func:`check_supported`), instead of computing something else.

Differences that are natural in eager code and change no result: the loop runs only the steps the given
transition length needs (stitchjax scans a static maximum and masks), and losses/discriminators look at
the L + 2 frames of the transition only (stitchjax masks the frames past them).

    twin = Twin(config)                       # a stitchjax Config
    twin.load_flax(params, phase_params)      # copy stitchjax parameters in
    loss, terms, fake = twin.generator_loss(batch, length, eps)   # eps: (B, n, 2, latent) pre-drawn noise
    twin.train_step(batch, length)            # one full update (generators + discriminators)
    twin.compile()                            # torch.compile of the per-frame generator step

``generator_noise(key, batch_size, config, max_length)`` draws the noise stitchjax's generator loss uses for
a key, so both implementations can be fed the same samples (``check_equal_loss`` does exactly that).
"""
from __future__ import annotations

import functools
import math
import time
from typing import Any

import numpy as np
import torch
from torch import nn
import torch.nn.functional as Fn

from stitchjax.data.features import NUM_CONTACTS, POSITION_SCALE, VELOCITY_SCALE

__all__ = ["Twin", "Generator", "Posterior", "Discriminator", "PhaseNet", "UnsupportedConfig", "check_supported",
           "batch_to_torch", "jax_noise", "generator_noise", "check_equal_loss", "check_equal_gradients",
           "matmul_flops", "num_steps", "schedule", "interpolation_weight", "kl_warmup"]

_ACTIVATION = nn.ELU  # the generator's hidden layers (networks.ACTIVATION)


class UnsupportedConfig(ValueError):
    """The config asks for something the twin does not compute; the message names the field."""


def check_supported(config) -> None:
    """Raise :class:`UnsupportedConfig` for config values the twin does not mirror."""
    m, lc, tc = config.model, config.loss, config.train
    allowed = {
        "model.posterior": (m.posterior, ("next_frame", "none")),
        "model.matmul_dtype": (m.matmul_dtype, ("float32",)),
        "loss.prior_sample_fraction": (lc.prior_sample_fraction if m.posterior != "none" else 0.0, (0.0,)),
        "loss.foot_skate_contacts": (lc.foot_skate_contacts, ("truth",)),
        "train.lr_decay_to": (tc.lr_decay_to, (1.0,)),
    }
    hints = {"model.matmul_dtype": " (the twin runs float32; time it under torch.autocast for bfloat16)",
             "loss.prior_sample_fraction": " (every window's z comes from the posterior in the twin)",
             "loss.foot_skate_contacts": " (the twin holds the ground truth's contacts still)",
             "train.lr_decay_to": " (the twin keeps the learning rate constant)"}
    for field, (value, ok) in allowed.items():
        if value not in ok:
            raise UnsupportedConfig(f"the PyTorch twin does not support {field}={value!r}; it supports "
                                    f"{', '.join(map(repr, ok))}{hints.get(field, '')}")


def mlp(sizes, activate_last: bool = True) -> nn.Sequential:
    """Linear layers in_dim -> sizes[1] -> ... with the ELU after each (or all but the last)."""
    layers = []
    for i in range(len(sizes) - 1):
        layers.append(nn.Linear(sizes[i], sizes[i + 1]))
        if activate_last or i < len(sizes) - 2:
            layers.append(_ACTIVATION())
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


class Posterior(nn.Module):
    """q(z | h, next frame): [h, next_state, next_state - state] -> hidden layer -> (mu_q, logvar_q)."""

    def __init__(self, lstm_size: int, state: int, width: int, latent: int):
        super().__init__()
        self.latent = latent
        self.hidden = nn.Linear(lstm_size + 2 * state, width)
        self.act = _ACTIVATION()
        self.head = nn.Linear(width, 2 * latent)

    def forward(self, h, state, next_state):
        out = self.head(self.act(self.hidden(torch.cat([h, next_state, next_state - state], -1))))
        return out[:, :self.latent], out[:, self.latent:]


class Generator(nn.Module):
    """One S-CVAE generator (one direction). ``forward`` is one autoregressive step for a batch."""

    def __init__(self, config):
        super().__init__()
        m, d = config.model, config.data
        self.config = config
        joints = d.num_joints
        state = joints * 4 + 3 + NUM_CONTACTS
        offset = joints * 4 + 3 + 1  # the offsets and the time to the target
        widths = list(m.encoder_widths)
        self.state_encoder = mlp([state] + widths)
        self.offset_encoder = mlp([offset] + widths)
        self.target_encoder = mlp([state] + widths)
        self.lstm = nn.LSTMCell(3 * widths[-1], m.lstm_size)
        self.current_head = nn.Linear(m.lstm_size, 2 * m.latent_dim)
        self.target_head = nn.Linear(m.lstm_size, 2 * m.latent_dim)
        self.posterior = (Posterior(m.lstm_size, state, widths[-1], m.latent_dim)
                          if m.posterior == "next_frame" else None)
        num_out = 3 + joints * 4 + NUM_CONTACTS
        outs = list(m.decoder_widths) + [num_out]
        ins = [m.latent_dim + 2 * state] + [width + m.latent_dim for width in outs[:-1]]  # z at every layer
        if m.phase_modulation:
            self.gating = mlp([2 * NUM_CONTACTS] + list(m.gating_widths) + [m.num_experts], activate_last=False)
            self.layers = nn.ModuleList(MoELayer(i, o, m.num_experts) for i, o in zip(ins, outs))
        else:
            self.layers = nn.ModuleList(nn.Linear(i, o) for i, o in zip(ins, outs))
        self.act = _ACTIVATION()

    def forward(self, carry, state, target, offset, gamma, phase, eps, next_state=None):
        """carry (c, h); state, target (B, S); offset (B, J*4+3[+1]); gamma () tensor; phase (B, P);
        eps (B, latent); next_state (B, S) ground truth of the frame made (z from q) or None (z from p).
        Returns ((c, h), decoder output (B, 3 + J*4 + C), Gaussians {mu_blend, logvar_blend (p),
        mu_posterior, logvar_posterior (q, = p without next_state)})."""
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
            std = (1 - gamma) * torch.exp(0.5 * logvar) + gamma * torch.exp(0.5 * logvar_t)
            mu_p, logvar_p = mean, 2.0 * torch.log(std)
        else:
            mu_p, logvar_p = mu, logvar
        if self.posterior is not None and next_state is not None:
            mu_q, logvar_q = self.posterior(h, state, next_state)
        else:
            mu_q, logvar_q = mu_p, logvar_p
        z = mu_q + torch.exp(0.5 * logvar_q) * eps
        y = torch.cat([z, state, target], -1)
        coefficients = torch.softmax(self.gating(phase), -1) if m.phase_modulation else None
        for i, layer in enumerate(self.layers):
            if i > 0:
                y = torch.cat([y, z], -1)
            y = layer(y, coefficients) if coefficients is not None else layer(y)
            if i < len(self.layers) - 1:
                y = self.act(y)
        gaussians = {"mu_blend": mu_p, "logvar_blend": logvar_p, "mu_posterior": mu_q, "logvar_posterior": logvar_q}
        return (c, h), y, gaussians


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
    """(h, k, n_forward, n_backward): split point, stitch buffer, frames each direction makes."""
    if not config.model.bidirectional:
        return length, 0, length, 0
    h = length // 2
    k = min(config.model.stitch_buffer, h)
    return h, k, h + k, length - h + k


def interpolation_weight(frame_number: int, frames_in_direction: int) -> float:
    """gamma for the step making a direction's ``frame_number``-th frame: n / N."""
    return min(max(frame_number / max(float(frames_in_direction), 1.0), 0.0), 1.0)


def kl_warmup(step: int, warmup_steps: int) -> float:
    """KL weight factor min(1, step / warmup_steps) (1 without a warm-up)."""
    if warmup_steps <= 0:
        return 1.0
    return min(max(step / float(warmup_steps), 0.0), 1.0)


class Twin:
    """Generators, discriminators, phase network and AdamW optimisers; train step and inference."""

    def __init__(self, config, threads: int | None = None):
        check_supported(config)
        if threads:
            torch.set_num_threads(threads)
        self.config = config
        m, d, lc = config.model, config.data, config.loss
        state = d.num_joints * 4 + 3 + NUM_CONTACTS
        # plain dicts (nn.ModuleDict cannot hold a key named "forward"); parameters via ModuleLists
        self.generators = {"forward": Generator(config), "backward": Generator(config)}
        disc_in = (d.num_joints - 1) * 3 + 3
        self.discriminators = {"disc_short": Discriminator(disc_in, m.disc_short_window, m.disc_widths),
                               "disc_long": Discriminator(disc_in, m.disc_long_window, m.disc_widths)}
        self.generator_modules = nn.ModuleList(self.generators.values())
        self.discriminator_modules = nn.ModuleList(self.discriminators.values())
        self.phase_net = PhaseNet(state, (config.phase.hidden_dim,) * config.phase.num_layers,
                                  2 * NUM_CONTACTS)
        self.phase_net.requires_grad_(False)  # frozen after pretraining
        self.has_phase = True
        self.feet = None
        if lc.foot_skate_weight:
            from stitchjax.data import datasets  # the contact joints of the dataset's skeleton

            self.feet = datasets.get(d.dataset).feet
            if self.feet is None:
                raise UnsupportedConfig(f"loss.foot_skate_weight needs a dataset with fixed feet; {d.dataset!r} "
                                        "reads them from its files")
            self.feet = [int(j) for j in self.feet]
        tc = config.train
        kwargs = dict(lr=tc.learning_rate, betas=(tc.adam_b1, tc.adam_b2), eps=1e-8, weight_decay=tc.weight_decay)
        self.gen_opt = torch.optim.AdamW(self.generator_modules.parameters(), **kwargs)
        self.disc_opt = torch.optim.AdamW(self.discriminator_modules.parameters(), **kwargs)
        self.step = 0  # updates done (the KL warm-up reads it)
        self.frame_step = self._frame_step  # torch.compile'd by compile()
        self.compiled = None

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
            if g.posterior is not None:
                load_linear(g.posterior.hidden, p["posterior"]["hidden"])
                load_linear(g.posterior.head, p["posterior"]["head"])
            if m.phase_modulation:
                load_mlp(g.gating, p["gating"])
                for i, layer in enumerate(g.layers):
                    layer.weight.copy_(t(p[f"expert_{i}"]["kernel"]).permute(1, 0, 2))  # (in, E, out) -> (E, in, out)
                    layer.bias.copy_(t(p[f"expert_{i}"]["bias"]))
            else:
                for i, layer in enumerate(g.layers):
                    load_linear(layer, p["decoder"][f"dense_{i}"])
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

    def compile(self, **options) -> None:
        """Run the per-frame generator step (state and offset features, phase network, generator, next
        frame) through ``torch.compile(**options)``; the loop over frames, stitching, FK, losses and the
        optimisers stay eager. Graphs are built at the first calls (one per generator, with and without
        the posterior's ground truth, with and without autograd)."""
        self.frame_step = torch.compile(self._frame_step, **options)
        self.compiled = {"what": "per-frame generator step (Twin._frame_step)", "options": options}

    def _frame_step(self, gen: Generator, carry, current, target, time_to_target, gamma, eps, next_state):
        """One generator step for a batch: frame dicts "rotations" (B, J, 4), "root" (B, 3), "velocity"
        (B, 3), "contacts" (B, C); time_to_target, gamma: () tensors; eps (B, latent); next_state (B, S)
        or None. Returns (carry, next frame, Gaussians)."""
        m, d = self.config.model, self.config.data
        batch = current["rotations"].shape[0]
        contacts, target_contacts = current["contacts"], target["contacts"]
        if not m.contact_input_gradient:
            contacts, target_contacts = contacts.detach(), target_contacts.detach()
        state = torch.cat([current["rotations"].flatten(1), current["velocity"], contacts], -1)
        target_state = torch.cat([target["rotations"].flatten(1), target["velocity"], target_contacts], -1)
        offset = torch.cat([(target["rotations"] - current["rotations"]).flatten(1),
                            (target["root"] - current["root"]) / POSITION_SCALE], -1)
        offset = torch.cat([offset, time_to_target.reshape(1, 1).expand(batch, 1)], -1)
        if m.phase_modulation and self.has_phase:
            phase = self.phase_net(state.detach())
        else:
            phase = state.new_zeros(batch, 2 * NUM_CONTACTS)
        carry, y, gaussians = gen(carry, state, target_state, offset, gamma, phase, eps, next_state)
        n = d.num_joints * 4
        velocity = y[:, :3]
        frame = {"rotations": quat_normalize(current["rotations"] + y[:, 3:3 + n].reshape(batch, d.num_joints, 4)),
                 "root": current["root"] + velocity * VELOCITY_SCALE,
                 "velocity": velocity,
                 "contacts": torch.sigmoid(y[:, 3 + n:])}
        return carry, frame, gaussians

    def rollout(self, start: dict, target: dict, offsets, length: int, eps, truth: dict | None = None):
        """Bidirectional aligned rollout + stitching for a batch.

        start/target: dicts "rotations" (B, J, 4), "root_position" (B, 3), "contacts" (B, C);
        offsets (B, J, 3); eps (B, n >= steps, 2, latent); truth: None (z from the prior) or
        {"forward", "backward"} (B, >= steps, S) ground-truth states of the frames each step makes
        (:meth:`next_frame_states`; z from the posterior). Returns the stitched motion of L + 2 frames
        ("rotations", "root_positions", "contacts", "global_positions"), per-direction sequences with
        their Gaussians, and the overlap positions.
        """
        m, d = self.config.model, self.config.data
        parents = tuple(d.parents)
        batch = start["rotations"].shape[0]
        h, k, n_fwd, n_bwd = schedule(self.config, length)
        steps = max(n_fwd, n_bwd)
        zeros = start["rotations"].new_zeros(batch, 3)
        start_frame = {"rotations": start["rotations"], "root": start["root_position"], "velocity": zeros,
                       "contacts": start["contacts"]}
        target_frame = {"rotations": target["rotations"], "root": target["root_position"], "velocity": zeros,
                        "contacts": target["contacts"]}
        carry0 = (zeros.new_zeros(batch, m.lstm_size), zeros.new_zeros(batch, m.lstm_size))
        fwd, bwd = start_frame, target_frame
        fwd_carry, bwd_carry = carry0, carry0
        seqs = {"forward": [], "backward": []}
        gauss = {"forward": [], "backward": []}
        bidir, aligned = m.bidirectional, m.bidirectional_aligning
        scalar = functools.partial(torch.tensor, dtype=torch.float32)

        def reverse(frame):
            return {**frame, "velocity": -frame["velocity"]}

        def time_to_target(distance):
            return scalar(float(distance)) / d.fps

        for i in range(steps):
            if i < n_fwd:
                if bidir and aligned:
                    f_target, f_dist = reverse(bwd), length + 1 - 2 * i
                else:
                    f_target, f_dist = target_frame, length + 1 - i
                gamma = scalar(interpolation_weight(i + 1, n_fwd))
                fwd_carry, fwd, g = self.frame_step(self.generators["forward"], fwd_carry, fwd, f_target,
                                                    time_to_target(f_dist), gamma, eps[:, i, 0],
                                                    None if truth is None else truth["forward"][:, i])
                seqs["forward"].append(fwd)
                gauss["forward"].append(g)
            if bidir and i < n_bwd:
                if aligned:
                    b_target, b_dist = reverse(fwd), length - 2 * i
                else:
                    b_target, b_dist = start_frame, length + 1 - i
                gamma = scalar(interpolation_weight(i + 1, n_bwd))
                bwd_carry, bwd, g = self.frame_step(self.generators["backward"], bwd_carry, bwd, b_target,
                                                    time_to_target(b_dist), gamma, eps[:, i, 1],
                                                    None if truth is None else truth["backward"][:, i])
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
        w3 = w[:, None, None]
        q_f = torch.where(w3 >= 0.5, sign * q_f, q_f)  # the lighter-weighted side joins the other's hemisphere
        q_b = torch.where(w3 < 0.5, sign * q_b, q_b)
        rot = quat_normalize((1 - w3) * q_f + w3 * q_b)
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
                         **{key: torch.stack([g[key] for g in gauss[name]], 1)[:, :count] for key in gauss[name][0]}}
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
        rel = (global_positions[:, :, 1:] - global_positions[:, :, :1]) / POSITION_SCALE
        vel = torch.cat([torch.zeros_like(root_positions[:, :1]), root_positions[:, 1:] - root_positions[:, :-1]],
                        1) / VELOCITY_SCALE
        return torch.cat([rel.flatten(2), vel], -1)

    def _norm1(self, x, dims):
        return x.abs().sum(dims)

    def _latent_sum(self, x):
        return x.sum(-1)

    def _targets(self, batch, length: int, count: int, backward: bool):
        """Ground truth of a direction's first ``count`` frames in its own time (forward frame i + 1, or
        backward frame L - i, reversed-time velocities), as ``batch.direction_frames``."""
        i = np.arange(count + 1)
        frames = np.clip((length + 1 - i) if backward else i, 0, batch["rotations"].shape[1] - 1)
        root = batch["root_positions"][:, frames]
        return {"rotations": batch["rotations"][:, frames][:, 1:],
                "velocities": (root[:, 1:] - root[:, :-1]) / VELOCITY_SCALE,
                "contacts": batch["contacts"][:, frames][:, 1:],
                "global_positions": batch["global_positions"][:, frames][:, 1:]}

    def next_frame_states(self, batch: dict, length: int, steps: int | None = None) -> dict:
        """The posterior's inputs {"forward", "backward"}: (B, steps, S) ground-truth states of the frame each
        step makes (``batch.next_frame_states``); steps defaults to what a rollout of ``length`` runs."""
        if steps is None:
            steps = max(schedule(self.config, length)[2:])
        out = {}
        for name in ("forward", "backward"):
            tg = self._targets(batch, length, steps, name == "backward")
            out[name] = torch.cat([tg["rotations"].flatten(2), tg["velocities"], tg["contacts"]], -1)
        return out

    def _foot_skate(self, out, batch, length: int):
        feet_positions = out["global_positions"][:, :, self.feet]
        step = (feet_positions[:, 1:] - feet_positions[:, :-1]) / POSITION_SCALE
        weighted = step * batch["contacts"][:, 1:length + 2, :, None]
        return self._norm1(weighted, (-2, -1)).mean()

    def generator_loss(self, batch: dict, length: int, eps, kl_scale: float = 1.0):
        """(total, terms, fake discriminator features) for a batch dict of tensors (B, T, ...).

        eps: (B, n, 2, latent) standard normal noise; kl_scale: factor on loss.kl_weight (the warm-up)."""
        lc, d, m = self.config.loss, self.config.data, self.config.model
        start = {"rotations": batch["rotations"][:, 0], "root_position": batch["root_positions"][:, 0],
                 "contacts": batch["contacts"][:, 0]}
        target = {"rotations": batch["rotations"][:, length + 1],
                  "root_position": batch["root_positions"][:, length + 1],
                  "contacts": batch["contacts"][:, length + 1]}
        truth = self.next_frame_states(batch, length) if m.posterior != "none" else None
        out = self.rollout(start, target, batch["offsets"][:, 0], length, eps, truth)
        directions = ["forward"] + (["backward"] if m.bidirectional else [])
        per_direction = ("state", "kl", "kl_penalty", "kl_prior", "fk", "rotation", "velocity", "contact")
        terms: dict[str, torch.Tensor] = {}
        for name in directions:
            o = out[name]
            if o is None:  # no frame in this direction: every term is an empty mean, 0 as in stitchjax
                for term in per_direction:
                    terms[f"{term}_{name}"] = torch.zeros(())
                continue
            tg = self._targets(batch, length, o["rotations"].shape[1], name == "backward")
            rot = self._norm1(o["rotations"] - tg["rotations"], (-2, -1)).mean()
            vel = self._norm1(o["velocities"] - tg["velocities"], -1).mean()
            con = self._norm1(o["contacts"] - tg["contacts"], -1).mean()
            mu_p, logvar_p = o["mu_blend"], o["logvar_blend"]
            prior_kl = self._latent_sum(0.5 * (mu_p ** 2 + torch.exp(logvar_p) - 1.0 - logvar_p))
            if m.posterior == "none":
                kl = penalty = prior_kl.mean()
            else:  # KL(q || p), and with free bits max(KL, free_bits) per frame in the objective
                mu_q, logvar_q = o["mu_posterior"], o["logvar_posterior"]
                per_frame = self._latent_sum(0.5 * (logvar_p - logvar_q
                                                    + (torch.exp(logvar_q) + (mu_q - mu_p) ** 2) / torch.exp(logvar_p)
                                                    - 1.0))
                kl, penalty = per_frame.mean(), torch.clamp(per_frame, min=lc.free_bits).mean()
            fk = self._norm1((o["global_positions"] - tg["global_positions"]) / POSITION_SCALE, (-2, -1)).mean()
            values = {"state": lc.beta_rotation * rot + lc.beta_velocity * vel + lc.beta_contact * con,
                      "kl": kl, "kl_penalty": penalty, "kl_prior": prior_kl.mean(), "fk": fk,
                      "rotation": rot, "velocity": vel, "contact": con}
            for term, value in values.items():
                terms[f"{term}_{name}"] = value
        for term in per_direction:
            terms[term] = sum(terms[f"{term}_{n}"] for n in directions) / len(directions)
        if out["overlap"] is not None:
            a, b = out["overlap"]
            terms["stitch"] = self._norm1((a - b) / POSITION_SCALE, (-2, -1)).mean()
        else:
            terms["stitch"] = torch.zeros(())
        fake = self.disc_features(out["global_positions"], out["root_positions"])
        zero = torch.zeros(())
        terms["adv_g_short"] = terms["adv_g_long"] = zero
        if lc.gen_weight:
            for name in ("disc_short", "disc_long"):
                disc = self.discriminators[name]
                # a transition shorter than the window has no window position: the term is 0
                terms["adv_g_" + name[5:]] = (0.5 * ((disc(fake) - 1) ** 2).mean() if fake.shape[1] >= disc.window
                                              else zero)
        terms["adv_g"] = terms["adv_g_short"] + terms["adv_g_long"]
        if lc.foot_skate_weight:
            terms["foot_skate"] = self._foot_skate(out, batch, length)
        total = (terms["state"] + lc.kl_weight * kl_scale * terms.pop("kl_penalty")
                 + lc.stitch_weight * terms["stitch"] + lc.fk_weight * terms["fk"] + lc.gen_weight * terms["adv_g"])
        if lc.foot_skate_weight:
            total = total + lc.foot_skate_weight * terms["foot_skate"]
        for name in directions:
            terms.pop(f"kl_penalty_{name}")
        return total, terms, fake

    def discriminator_loss(self, batch: dict, fake):
        """(loss.disc_weight * L_D, {"adv_d_short", "adv_d_long", "adv_d"}) on the real windows and ``fake``."""
        frames = fake.shape[1]
        real = self.disc_features(batch["global_positions"][:, :frames], batch["root_positions"][:, :frames])
        fake = fake.detach()
        terms = {}
        for name in ("disc_short", "disc_long"):
            disc = self.discriminators[name]
            terms["adv_d_" + name[5:]] = (0.5 * ((disc(real) - 1) ** 2).mean() + 0.5 * (disc(fake) ** 2).mean()
                                          if frames >= disc.window else torch.zeros(()))
        terms["adv_d"] = terms["adv_d_short"] + terms["adv_d_long"]
        return self.config.loss.disc_weight * terms["adv_d"], terms

    # -------------------------------------------------------------------------------- train / infer

    def train_step(self, batch: dict, length: int, eps=None, rng=None) -> dict:
        """One update of both generators and both discriminators; returns float losses."""
        if eps is None:
            rng = rng or np.random.default_rng()
            steps = max(schedule(self.config, length)[2:])
            eps = torch.from_numpy(rng.standard_normal(
                (batch["rotations"].shape[0], steps, 2, self.config.model.latent_dim), dtype=np.float32))
        kl_scale = kl_warmup(self.step, self.config.loss.kl_warmup_steps)
        self.discriminator_modules.requires_grad_(False)
        self.gen_opt.zero_grad(set_to_none=True)
        loss, terms, fake = self.generator_loss(batch, length, eps, kl_scale)
        loss.backward()
        self.gen_opt.step()
        self.discriminator_modules.requires_grad_(True)
        self.disc_opt.zero_grad(set_to_none=True)
        disc_loss, _ = self.discriminator_loss(batch, fake)
        disc_loss.backward()
        self.disc_opt.step()
        self.step += 1
        return {"loss": loss.item(), "disc_loss": disc_loss.item()}

    def make_inference(self, data: dict, length: int, samples: int, seed: int = 0):
        """A function running ``samples`` transitions of ``length`` frames between window 0's frames 0
        and length + 1 of ``data`` (numpy, from run_all.synthetic_dataset) without autograd, z from the
        prior (as ``inbetween.sample_transitions``)."""
        def kf(i):
            return {"rotations": torch.from_numpy(data["rotations"][0, i][None]).expand(samples, -1, -1),
                    "root_position": torch.from_numpy(data["root_positions"][0, i][None]).expand(samples, -1),
                    "contacts": torch.from_numpy(data["contacts"][0, i][None]).expand(samples, -1)}

        start, target = kf(0), kf(length + 1)
        offsets = torch.from_numpy(data["offsets"][0, 0][None]).expand(samples, -1, -1)
        generator = torch.Generator().manual_seed(seed)
        steps = max(schedule(self.config, length)[2:])

        def run():
            with torch.inference_mode():
                eps = torch.randn(samples, steps, 2, self.config.model.latent_dim, generator=generator)
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


def generator_noise(key, batch_size: int, config, max_length: int) -> np.ndarray:
    """The latent noise (B, n, 2, latent) of ``objective.generator_loss(..., key, ...)``: its rollout
    (``objective.generator_rollouts``) draws from the first half of ``jax.random.split(key)``."""
    import jax

    return jax_noise(jax.random.split(key)[0], batch_size, config, max_length)


@functools.lru_cache(maxsize=8)
def _jax_losses(config):
    """stitchjax's generator + discriminator losses, jitted once per config (length is traced)."""
    import jax
    from stitchjax import specs
    from stitchjax.accel import fast_rollout
    from stitchjax.model import objective

    spec, rollout_batch = specs.train_spec(config), fast_rollout.training_rollout_batch(config.train)

    def both(params, phase_params, batch, key, length, kl_scale):
        total, terms, generated = objective.generator_loss(params, phase_params, batch, key, spec, length, kl_scale,
                                                           rollout_batch)
        disc_total, disc_terms = objective.discriminator_loss(params, phase_params, batch, key, spec, length,
                                                              generated)
        return total, terms, disc_total, disc_terms

    return jax.jit(both)


def _twin_and_batch(config, params, phase_params, batch_np: dict, key):
    twin = Twin(config)
    twin.load_flax(params, phase_params)
    batch_t = batch_to_torch(batch_np, np.arange(batch_np["rotations"].shape[0]))
    eps = torch.from_numpy(np.array(generator_noise(key, batch_np["rotations"].shape[0], config,
                                                    batch_np["rotations"].shape[1] - 2)))
    return twin, batch_t, eps


def check_equal_loss(config, params, phase_params, batch_np: dict, length: int, key, step: int = 0) -> dict:
    """Generator and discriminator losses of stitchjax and the twin on the same weights, batch and noise.

    batch_np: numpy dict (B, T, ...) as from ``features.prepare_dataset``; step: the train step whose KL
    warm-up factor both use. Returns {"jax_loss", "torch_loss", "jax_terms", "torch_terms", "jax_disc_loss",
    "torch_disc_loss", "jax_disc_terms", "torch_disc_terms", "kl_scale"} (floats and dicts of floats).
    """
    import jax.numpy as jnp

    kl_scale = kl_warmup(step, config.loss.kl_warmup_steps)
    batch_j = {k_: jnp.asarray(v) for k_, v in batch_np.items()}
    total, terms, disc_total, disc_terms = _jax_losses(config)(params, phase_params, batch_j, key,
                                                               jnp.int32(length), jnp.float32(kl_scale))
    twin, batch_t, eps = _twin_and_batch(config, params, phase_params, batch_np, key)
    with torch.no_grad():
        t_total, t_terms, fake = twin.generator_loss(batch_t, length, eps, kl_scale)
        t_disc, t_disc_terms = twin.discriminator_loss(batch_t, fake)
    return {"jax_loss": float(total), "torch_loss": float(t_total), "kl_scale": kl_scale,
            "jax_terms": {k_: float(v) for k_, v in terms.items()},
            "torch_terms": {k_: float(v) for k_, v in t_terms.items()},
            "jax_disc_loss": float(disc_total), "torch_disc_loss": float(t_disc),
            "jax_disc_terms": {k_: float(disc_terms[k_]) for k_ in t_disc_terms},
            "torch_disc_terms": {k_: float(v) for k_, v in t_disc_terms.items()}}


def check_equal_gradients(config, params, phase_params, batch_np: dict, length: int, key, step: int = 0) -> dict:
    """Gradients of the generator objective with respect to a few generator kernels, stitchjax and twin.

    Returns {"name": (jax array, torch array)} in stitchjax's layout (in, out) for the forward and backward
    generators' LSTM input kernel, first expert / decoder layer and (with a posterior) the posterior's
    hidden layer: kernels whose gradients pass through the whole rollout.
    """
    import jax
    import jax.numpy as jnp
    from stitchjax import specs
    from stitchjax.accel import fast_rollout
    from stitchjax.model import objective

    kl_scale = kl_warmup(step, config.loss.kl_warmup_steps)
    batch_j = {k_: jnp.asarray(v) for k_, v in batch_np.items()}
    generators = {name: params[name] for name in ("forward", "backward")}
    spec, rollout_batch = specs.train_spec(config), fast_rollout.training_rollout_batch(config.train)
    discriminators = {name: params[name] for name in ("disc_short", "disc_long")}

    def generator_loss(gen_params):
        return objective.generator_loss({**gen_params, **discriminators}, phase_params, batch_j, key, spec,
                                        jnp.int32(length), kl_scale, rollout_batch)[0]

    grads = jax.jit(jax.grad(generator_loss))(generators)
    twin, batch_t, eps = _twin_and_batch(config, params, phase_params, batch_np, key)
    twin.discriminator_modules.requires_grad_(False)
    loss, _, _ = twin.generator_loss(batch_t, length, eps, kl_scale)
    loss.backward()
    m = config.model
    out = {}
    for name in ("forward", "backward"):
        g, gp = twin.generators[name], grads[name]["params"]
        out[f"{name}/lstm/input_kernel"] = (gp["lstm"]["input_kernel"], g.lstm.weight_ih.grad.T)
        if m.phase_modulation:
            kernel = gp["expert_0"]["kernel"]  # (in, E, out); the twin's is (E, in, out)
            out[f"{name}/expert_0/kernel"] = (kernel.reshape(kernel.shape[0], -1),
                                              g.layers[0].weight.grad.permute(1, 0, 2).flatten(1))
        else:
            out[f"{name}/decoder/dense_0/kernel"] = (gp["decoder"]["dense_0"]["kernel"], g.layers[0].weight.grad.T)
        if g.posterior is not None:
            out[f"{name}/posterior/hidden/kernel"] = (gp["posterior"]["hidden"]["kernel"],
                                                      g.posterior.hidden.weight.grad.T)
    return {name: (np.asarray(a), b.detach().numpy()) for name, (a, b) in out.items()}


def matmul_flops(config, batch: int, length: int) -> dict:
    """Hand count of the matmul FLOPs (2 per multiply-add) of one train step at transition length L.

    Counts what stitchjax's compiled step does: a scan of n = num_steps(config, L) steps per generator
    (the masked steps are computed too), forward pass = 2*B*n*(per-step MACs), backward pass = 2x forward
    (input and weight gradients), except that the phase network is frozen and gets no weight gradient
    (its input gradient is stopped too, so no backward at all); the discriminators: once on the fake
    motion inside the generator loss (forward + input gradient), twice (real, fake) in their own update
    (forward + weight gradient). The posterior network runs at training only. Biases, activations, FK and
    losses are not matmuls and not counted.
    """
    m, d = config.model, config.data
    state = d.num_joints * 4 + 3 + NUM_CONTACTS
    offset = d.num_joints * 4 + 3 + 1

    def chain(sizes):
        return sum(sizes[i] * sizes[i + 1] for i in range(len(sizes) - 1))

    enc = list(m.encoder_widths)
    per_step = {
        "encoders": chain([state] + enc) * 2 + chain([offset] + enc),
        "lstm": (3 * enc[-1] + m.lstm_size) * 4 * m.lstm_size,
        "heads": 2 * m.lstm_size * 2 * m.latent_dim,
    }
    if m.posterior == "next_frame":
        per_step["posterior"] = (m.lstm_size + 2 * state) * enc[-1] + enc[-1] * 2 * m.latent_dim
    outs = list(m.decoder_widths) + [3 + d.num_joints * 4 + NUM_CONTACTS]
    ins = [m.latent_dim + 2 * state] + [w + m.latent_dim for w in outs[:-1]]
    decoder = sum(i * o for i, o in zip(ins, outs))
    if m.phase_modulation:
        per_step["experts"] = m.num_experts * decoder + sum(m.num_experts * o for o in outs)  # + blend
        per_step["gating"] = chain([2 * NUM_CONTACTS] + list(m.gating_widths) + [m.num_experts])
        phase_macs = chain([state] + [config.phase.hidden_dim] * config.phase.num_layers + [2 * NUM_CONTACTS])
    else:
        per_step["decoder"] = decoder
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
