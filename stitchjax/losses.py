"""Losses (paper section 3.2): state, KL, FK, stitching, LSGAN; the generator and discriminator objectives.

Overall (paper Eq. 8, weights in ``config.loss``)::

    L = L_state + 1.0 L_kl + 0.5 L_stitch + 0.5 L_fk + 0.1 L_D + 0.1 L_G

L_state, L_kl and L_fk are averaged over the forward and backward generators. The generator update
minimises ``generator_loss`` (everything but L_D); the discriminator update minimises
``discriminator_loss`` = 0.1 L_D. One train step does ONE rollout: ``generator_loss`` returns the
(stop-gradient) discriminator features of the generated motion as its third output, which
``discriminator_loss`` takes as its ``generated`` argument.

Norms: ``loss.reduction="sum"`` takes ||.||_1 literally (sum over the components of a frame), then the
mean over valid frames and the batch; "mean" also averages over components. Positions enter FK,
stitching and discriminator features divided by ``data.position_scale`` (LAFAN1: metres).
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from stitchjax import features as F
from stitchjax import networks
from stitchjax import rollout as rollout_lib

__all__ = [
    "masked_mean", "state_loss", "kl_loss", "fk_loss", "stitching_loss", "lsgan_generator_loss",
    "lsgan_discriminator_loss", "disc_features", "direction_targets", "generator_loss",
    "discriminator_loss",
]


def masked_mean(values, mask):
    """Mean of ``values`` (...,) over entries where ``mask`` (...,) is true; 0 when none is."""
    mask = mask.astype(values.dtype)
    return jnp.sum(values * mask) / jnp.maximum(jnp.sum(mask), 1.0)


def _norm1(x, reduction: str, axes):
    if reduction == "sum":
        return jnp.sum(jnp.abs(x), axis=axes)
    if reduction == "mean":
        return jnp.mean(jnp.abs(x), axis=axes)
    raise ValueError(f"loss.reduction={reduction!r}: use 'sum' or 'mean'")


def state_loss(pred, true, mask, loss_config):
    """Paper Eq. 4: beta1 |q^ - q|_1 + beta2 |v^ - v|_1 + beta3 |c^ - c|_1 per frame, mean over valid frames.

    pred/true: dicts with "rotations" (..., T, J, 4), "velocities" (..., T, 3) scaled, "contacts"
    (..., T, C); mask (..., T). Returns (total, {"rotation", "velocity", "contact"}).
    """
    r = loss_config.reduction
    rot = masked_mean(_norm1(pred["rotations"] - true["rotations"], r, (-2, -1)), mask)
    vel = masked_mean(_norm1(pred["velocities"] - true["velocities"], r, -1), mask)
    con = masked_mean(_norm1(pred["contacts"] - true["contacts"], r, -1), mask)
    total = loss_config.beta_rotation * rot + loss_config.beta_velocity * vel + loss_config.beta_contact * con
    return total, {"rotation": rot, "velocity": vel, "contact": con}


def kl_loss(mu, logvar, mask, reduction: str = "sum"):
    """KL(N(mu, exp(logvar)) || N(0, I)) per frame (sum or mean over latent dims), mean over valid frames."""
    kl = 0.5 * (jnp.square(mu) + jnp.exp(logvar) - 1.0 - logvar)
    per_frame = jnp.sum(kl, axis=-1) if reduction == "sum" else jnp.mean(kl, axis=-1)
    return masked_mean(per_frame, mask)


def fk_loss(pred_positions, true_positions, mask, position_scale: float, reduction: str = "sum"):
    """Paper Eq. 6: L1 between FK global positions (..., T, J, 3) / position_scale, mean over valid frames."""
    diff = (pred_positions - true_positions) / position_scale
    return masked_mean(_norm1(diff, reduction, (-2, -1)), mask)


def stitching_loss(pos_fwd, pos_bwd, mask, position_scale: float = 1.0, reduction: str = "sum"):
    """Stitching loss, paper Eq. 3: mean L1 distance between the forward and backward sequences' FK global
    positions over the 2K overlapping frames.

    pos_fwd, pos_bwd: (..., 2K, J, 3) positions of the same frames (``rollout(...)["overlap"]``);
    mask (..., 2K) true on the overlap (fewer than 2K frames for short transitions). Zero when the two
    sequences agree, positive otherwise.
    """
    return fk_loss(pos_fwd, pos_bwd, mask, position_scale, reduction)


def lsgan_generator_loss(fake_scores, mask):
    """Paper Eq. 7: 1/2 E[(D(G(z)) - 1)^2] over valid window positions."""
    return 0.5 * masked_mean(jnp.square(fake_scores - 1.0), mask)


def lsgan_discriminator_loss(real_scores, fake_scores, mask):
    """Paper Eq. 8 (L_D): 1/2 E[(D(x) - 1)^2] + 1/2 E[D(G(z))^2] over valid window positions."""
    return 0.5 * masked_mean(jnp.square(real_scores - 1.0), mask) + 0.5 * masked_mean(jnp.square(fake_scores), mask)


def disc_features(global_positions, root_positions, config):
    """Per-frame discriminator input (..., T, (J-1)*3 + 3): joint positions relative to the root joint
    and the root velocity (frame 0: 0), both scaled (``data.position_scale``, ``data.velocity_scale``)."""
    rel = (global_positions[..., 1:, :] - global_positions[..., :1, :]) / config.data.position_scale
    rel = rel.reshape(rel.shape[:-2] + (-1,))
    vel = F.root_velocities(root_positions, config.data.velocity_scale)
    return jnp.concatenate([rel, vel], axis=-1)


def _window_mask(motion_mask, window: int):
    """Valid window positions (..., T - window + 1): every frame of the window inside the motion."""
    t = motion_mask.shape[-1]
    count = jnp.sum(motion_mask.astype(jnp.int32), axis=-1, keepdims=True)
    start = jnp.arange(t - window + 1)
    return start + window <= count


def direction_targets(batch, length, num_steps: int, backward: bool, config):
    """Ground truth for one direction's per-step outputs (entry i = forward frame i + 1, or backward
    frame L - i), in that direction's time: "rotations", "velocities" (scaled), "contacts",
    "global_positions", each with a leading (B, num_steps)."""
    length = jnp.asarray(length, jnp.int32)
    i = jnp.arange(num_steps + 1, dtype=jnp.int32)  # entry 0 = the keyframe the direction starts from
    frames = (length + 1 - i) if backward else i

    def take(x):
        return jnp.take(x, frames, axis=1, mode="clip")

    root = take(batch["root_positions"])
    velocity = (root[:, 1:] - root[:, :-1]) / config.data.velocity_scale
    return {"rotations": take(batch["rotations"])[:, 1:], "velocities": velocity,
            "contacts": take(batch["contacts"])[:, 1:], "global_positions": take(batch["global_positions"])[:, 1:]}


def _direction_terms(out_dir, target, config):
    lc = config.loss
    mask = out_dir["mask"]
    state, parts = state_loss(out_dir, target, mask, lc)
    kl = kl_loss(out_dir["mu_blend"], out_dir["logvar_blend"], mask, lc.reduction)
    fk = fk_loss(out_dir["global_positions"], target["global_positions"], mask, config.data.position_scale,
                 lc.reduction)
    return {"state": state, "kl": kl, "fk": fk, **parts}


def _disc_scores(params, config, features):
    short = networks.make_discriminator(config, "disc_short").apply(params["disc_short"], features)
    long = networks.make_discriminator(config, "disc_long").apply(params["disc_long"], features)
    return short, long


def _real_features(batch, config, num_frames: int):
    return disc_features(batch["global_positions"][:, :num_frames], batch["root_positions"][:, :num_frames], config)


def generator_loss(params, phase_params, batch, key, config, length):
    """Generator objective for one batch (one rollout).

    Args:
      params: {"forward", "backward", "disc_short", "disc_long"}.
      phase_params: frozen phase network params (or None: zero phase features).
      batch: dict from ``features.prepare_dataset`` with leading (B, T); T - 2 is the maximum length.
      key: PRNG key; config: Config (static); length: traced int transition length.
    Returns:
      (total, terms, generated): total scalar; terms dict of scalars "state", "kl", "fk", "stitch",
      "adv_g", "adv_g_short", "adv_g_long", "rotation", "velocity", "contact" (and per-direction
      "state_forward", ...); generated = {"features" (B, T, F) stop-gradient discriminator input of
      the stitched motion, "mask" (B, T)} for :func:`discriminator_loss`.
    """
    lc = config.loss
    out = rollout_lib.rollout_batch(params, phase_params, batch, key, config, length)
    n = out["forward"]["mask"].shape[1]
    directions = ["forward"] + (["backward"] if config.model.bidirectional else [])
    terms = {}
    for name in directions:
        target = direction_targets(batch, length, n, name == "backward", config)
        for term, value in _direction_terms(out[name], target, config).items():
            terms[f"{term}_{name}"] = value
    for term in ("state", "kl", "fk", "rotation", "velocity", "contact"):
        terms[term] = sum(terms[f"{term}_{d}"] for d in directions) / len(directions)
    ov = out["overlap"]
    terms["stitch"] = stitching_loss(ov["forward_positions"], ov["backward_positions"], ov["mask"],
                                     config.data.position_scale, lc.reduction)

    fake = disc_features(out["global_positions"], out["root_positions"], config)
    mask = out["mask"]
    total = lc.kl_weight * terms["kl"] + lc.stitch_weight * terms["stitch"] + lc.fk_weight * terms["fk"]
    total = total + terms["state"]
    if lc.gen_weight:
        short, long = _disc_scores(params, config, fake)
        terms["adv_g_short"] = lsgan_generator_loss(short, _window_mask(mask, config.model.disc_short_window))
        terms["adv_g_long"] = lsgan_generator_loss(long, _window_mask(mask, config.model.disc_long_window))
    else:
        terms["adv_g_short"] = terms["adv_g_long"] = jnp.zeros((), total.dtype)
    terms["adv_g"] = terms["adv_g_short"] + terms["adv_g_long"]
    total = total + lc.gen_weight * terms["adv_g"]
    generated = {"features": jax.lax.stop_gradient(fake), "mask": mask}
    return total, terms, generated


def discriminator_loss(params, phase_params, batch, key, config, length, generated=None):
    """Discriminator objective: ``loss.disc_weight`` * L_D summed over the short and long discriminators.

    generated: the third output of :func:`generator_loss` (reuses its rollout); None = run a rollout here
    (under stop_gradient). Returns (total, {"adv_d", "adv_d_short", "adv_d_long", "d_real", "d_fake"}).
    """
    if generated is None:
        out = rollout_lib.rollout_batch(jax.lax.stop_gradient(params), phase_params, batch, key, config, length)
        generated = {"features": disc_features(out["global_positions"], out["root_positions"], config),
                     "mask": out["mask"]}
    fake = jax.lax.stop_gradient(generated["features"])
    mask = generated["mask"]
    real = _real_features(batch, config, fake.shape[1])
    real_short, real_long = _disc_scores(params, config, real)
    fake_short, fake_long = _disc_scores(params, config, fake)
    m_short = _window_mask(mask, config.model.disc_short_window)
    m_long = _window_mask(mask, config.model.disc_long_window)
    terms = {
        "adv_d_short": lsgan_discriminator_loss(real_short, fake_short, m_short),
        "adv_d_long": lsgan_discriminator_loss(real_long, fake_long, m_long),
        "d_real": 0.5 * (masked_mean(real_short, m_short) + masked_mean(real_long, m_long)),
        "d_fake": 0.5 * (masked_mean(fake_short, m_short) + masked_mean(fake_long, m_long)),
    }
    terms["adv_d"] = terms["adv_d_short"] + terms["adv_d_long"]
    return config.loss.disc_weight * terms["adv_d"], terms
