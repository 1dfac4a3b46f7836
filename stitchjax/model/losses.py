"""Loss terms (paper section 3.2): state, KL, FK, stitching, LSGAN (Eq. 3-8), and the optional foot terms.

The objectives that weigh them (paper Eq. 9) and the rollout they score are :mod:`stitchjax.model.objective`'s.
Optional, not in the paper: :func:`foot_skate_loss` (``loss.foot_skate_weight``), :func:`foot_velocity_loss`
(``loss.foot_velocity_weight``) and :func:`ground_penetration_loss` (``loss.ground_penetration_weight``).

Norms: ||.||_1 as written, the sum over the components of a frame, then the mean over valid frames and the
batch (the stitching loss may also average over components: ``reduction="mean"``, the sampler's per-motion
score). Positions enter FK, stitching and discriminator features divided by ``features.POSITION_SCALE``
(centimetres -> metres; ``SkeletonSpec.position_scale``).
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from stitchjax.data import features as F
from stitchjax.data.windows import FOOT_HEIGHT_THRESHOLD_CM

__all__ = [
    "masked_mean", "state_loss", "kl_loss", "gaussian_kl", "posterior_kl_loss", "fk_loss", "stitching_loss",
    "foot_skate_loss", "foot_velocity_loss", "foot_height_contacts", "window_ground", "ground_penetration_loss",
    "lsgan_generator_loss",
    "lsgan_discriminator_loss", "disc_features",
]


def masked_mean(values, mask):
    """Mean of ``values`` (...,) over entries where ``mask`` (...,) is true; 0 when none is. A float mask
    weighs the entries: sum(values * mask) / sum(mask)."""
    mask = mask.astype(values.dtype)
    return jnp.sum(values * mask) / jnp.maximum(jnp.sum(mask), 1.0)


def _norm1(x, reduction: str, axes):
    if reduction == "sum":
        return jnp.sum(jnp.abs(x), axis=axes)
    if reduction == "mean":
        return jnp.mean(jnp.abs(x), axis=axes)
    raise ValueError(f"reduction={reduction!r}: use 'sum' or 'mean'")


def state_loss(pred, true, mask, loss_config):
    """Paper Eq. 4: beta1 |q^ - q|_1 + beta2 |v^ - v|_1 + beta3 |c^ - c|_1 per frame, mean over valid frames.

    pred/true: dicts with "rotations" (..., T, J, 4), "velocities" (..., T, 3) scaled, "contacts"
    (..., T, C); mask (..., T); loss_config: ``config.loss`` (the betas). Returns (total, {"rotation",
    "velocity", "contact"}).
    """
    r = "sum"
    rot = masked_mean(_norm1(pred["rotations"] - true["rotations"], r, (-2, -1)), mask)
    vel = masked_mean(_norm1(pred["velocities"] - true["velocities"], r, -1), mask)
    con = masked_mean(_norm1(pred["contacts"] - true["contacts"], r, -1), mask)
    total = loss_config.beta_rotation * rot + loss_config.beta_velocity * vel + loss_config.beta_contact * con
    return total, {"rotation": rot, "velocity": vel, "contact": con}


def kl_loss(mu, logvar, mask):
    """Paper Eq. 5: KL(N(mu, exp(logvar)) || N(0, I)) per frame (summed over latent dims), mean over valid
    frames. With ``model.posterior="none"`` the objective's L_kl is this term on the sampling distribution p."""
    kl = 0.5 * (jnp.square(mu) + jnp.exp(logvar) - 1.0 - logvar)
    return masked_mean(jnp.sum(kl, axis=-1), mask)


def gaussian_kl(mu_q, logvar_q, mu_p, logvar_p):
    """KL(q || p) between diagonal Gaussians per frame, (..., latent) -> (...,) (summed over dims)."""
    kl = 0.5 * (logvar_p - logvar_q + (jnp.exp(logvar_q) + jnp.square(mu_q - mu_p)) / jnp.exp(logvar_p) - 1.0)
    return jnp.sum(kl, axis=-1)


def posterior_kl_loss(out_dir, mask, free_bits: float = 0.0):
    """Paper Eq. 5 as read with a posterior (docs/design.md §5.5): KL(q || p) of one direction, q the posterior, p the
    latent-interpolation prior (``mu_blend``), per frame; the objective's L_kl with ``model.posterior="next_frame"``.

    Returns (raw, penalised): the mean over valid frames of the KL, and of max(KL, free_bits) (free bits:
    below ``free_bits`` nats per frame the term has no gradient, so q keeps that much information)."""
    kl = gaussian_kl(out_dir["mu_posterior"], out_dir["logvar_posterior"], out_dir["mu_blend"],
                     out_dir["logvar_blend"])
    return masked_mean(kl, mask), masked_mean(jnp.maximum(kl, free_bits), mask)


def fk_loss(pred_positions, true_positions, mask, position_scale: float, reduction: str = "sum"):
    """Paper Eq. 6: L1 between FK global positions (..., T, J, 3) / position_scale, mean over valid frames."""
    diff = (pred_positions - true_positions) / position_scale
    return masked_mean(_norm1(diff, reduction, (-2, -1)), mask)


def stitching_loss(pos_fwd, pos_bwd, mask, position_scale: float = 1.0, reduction: str = "sum",
                   per_motion: bool = False):
    """Stitching loss, paper Eq. 3: mean L1 distance between the forward and backward sequences' FK global
    positions over the 2K overlapping frames.

    pos_fwd, pos_bwd: (..., 2K, J, 3) positions of the same frames (``rollout(...)["overlap"]``);
    mask (..., 2K) true on the overlap (fewer than 2K frames for short transitions). Zero when the two
    sequences agree, positive otherwise. Returns a scalar (the mean over every motion's valid frames, as
    training uses it), or with ``per_motion`` one value per motion (...,) (the latent-pair search).
    """
    if not per_motion:
        return fk_loss(pos_fwd, pos_bwd, mask, position_scale, reduction)
    per_frame = _norm1((pos_fwd - pos_bwd) / position_scale, reduction, (-2, -1))
    mask = mask.astype(per_frame.dtype)
    return (per_frame * mask).sum(-1) / jnp.maximum(mask.sum(-1), 1.0)


def foot_skate_loss(global_positions, contacts, mask, feet, position_scale: float, up_axis: int | None = None):
    """Foot skate: L1 movement of the contact joints from frame t - 1 to frame t, weighted by the contact of
    that joint at frame t, / position_scale, mean over valid frames (not in the paper).

    global_positions (..., T, J, 3) generated motion; contacts (..., T, C) contact weights of the same frames
    (0 / 1 labels, or soft weights in [0, 1]); mask (..., T) valid frames; feet: the C joint indices of the
    contact channels; up_axis: None counts every component of the movement, an axis index leaves that one
    out (horizontal sliding only, so a foot may lift off). Zero when every foot in contact stays where it was.
    """
    feet_positions = global_positions[..., list(feet), :]
    step = (feet_positions[..., 1:, :, :] - feet_positions[..., :-1, :, :]) / position_scale
    if up_axis is not None:
        step = step * (jnp.arange(step.shape[-1]) != up_axis).astype(step.dtype)
    weighted = step * contacts[..., 1:, :, None]
    valid = mask[..., 1:] & mask[..., :-1]
    return masked_mean(_norm1(weighted, "sum", (-2, -1)), valid)


def foot_velocity_loss(global_positions, truth_positions, mask, feet, position_scale: float):
    """Foot velocity: L1 between the generated and the ground-truth movement of the contact joints from frame
    t - 1 to frame t, / position_scale, mean over valid frame pairs (not in the paper). The foot-skate term
    leaves a foot in the air free to move any distance in one frame; this term holds every foot to the
    ground truth's speed, next to the keyframes too.

    global_positions, truth_positions (..., T, J, 3); mask (..., T) valid frames; feet: joint indices.
    """
    feet = list(feet)
    generated = global_positions[..., feet, :]
    truth = truth_positions[..., feet, :]
    step = (generated[..., 1:, :, :] - generated[..., :-1, :, :]) - (truth[..., 1:, :, :] - truth[..., :-1, :, :])
    valid = mask[..., 1:] & mask[..., :-1]
    return masked_mean(_norm1(step / position_scale, "sum", (-2, -1)), valid)


def foot_height_contacts(global_positions, truth_positions, mask, feet, up_axis: int = 1,
                         threshold: float = FOOT_HEIGHT_THRESHOLD_CM, either_end: bool = False):
    """Soft contacts of the generated feet from their height, as the foot-slide metric weighs them, shifted
    so that frame t carries the weight of frame t - 1 (the frame a movement to t starts from).

    w = clip(2 - 2^(h / threshold), 0, 1), h the joint's height above the ground: the lowest ground-truth
    foot height over the valid frames. global_positions / truth_positions (..., T, J, 3) in data units
    (centimetres for every registered dataset); mask (..., T). either_end: frame t carries the larger of the
    weights of t - 1 and t, so a foot that lands in frame t from the air is held too (``loss.
    foot_skate_contacts="height_either"``). Returns (..., T, C) weights, no gradient.
    """
    ground = window_ground(truth_positions, mask, feet, up_axis)
    height = global_positions[..., list(feet), up_axis] - ground[..., None, None]
    weight = jnp.clip(2.0 - jnp.power(2.0, height / threshold), 0.0, 1.0)
    shifted = jnp.concatenate([jnp.zeros_like(weight[..., :1, :]), weight[..., :-1, :]], axis=-2)
    if either_end:
        shifted = jnp.maximum(shifted, weight.at[..., :1, :].set(0.0))
    return jax.lax.stop_gradient(shifted)


def window_ground(truth_positions, mask, feet, up_axis: int = 1):
    """The window's ground (..., ), as the foot metrics define it: the lowest ground-truth height of any foot
    joint over the valid frames (0 where no frame is valid). truth_positions (..., T, J, 3); mask (..., T)."""
    truth_heights = truth_positions[..., list(feet), up_axis]  # (..., T, C)
    ground = jnp.min(jnp.where(mask[..., :, None], truth_heights, jnp.inf), axis=(-2, -1))
    return jnp.where(jnp.isfinite(ground), ground, 0.0)


def ground_penetration_loss(global_positions, truth_positions, mask, feet, position_scale: float,
                            up_axis: int = 1):
    """Ground penetration: how far each generated foot joint is below the window's ground (:func:`window_ground`),
    max(ground - height, 0) / position_scale, summed over the foot joints, mean over valid frames (not in the
    paper). Zero when no foot joint is below the ground; the ground truth scores zero by construction.

    global_positions, truth_positions (..., T, J, 3) in data units; mask (..., T); feet: joint indices.
    """
    ground = jax.lax.stop_gradient(window_ground(truth_positions, mask, feet, up_axis))
    heights = global_positions[..., list(feet), up_axis]  # (..., T, C)
    depth = jnp.maximum(ground[..., None, None] - heights, 0.0) / position_scale
    return masked_mean(jnp.sum(depth, axis=-1), mask)


def lsgan_generator_loss(fake_scores, mask):
    """Paper Eq. 7: 1/2 E[(D(G(z)) - 1)^2] over valid window positions."""
    return 0.5 * masked_mean(jnp.square(fake_scores - 1.0), mask)


def lsgan_discriminator_loss(real_scores, fake_scores, mask):
    """Paper Eq. 8 (L_D): 1/2 E[(D(x) - 1)^2] + 1/2 E[D(G(z))^2] over valid window positions."""
    return 0.5 * masked_mean(jnp.square(real_scores - 1.0), mask) + 0.5 * masked_mean(jnp.square(fake_scores), mask)


def disc_features(global_positions, root_positions, skeleton):
    """Per-frame discriminator input (..., T, (J-1)*3 + 3): joint positions relative to the root joint
    and the root velocity (frame 0: 0), both scaled (``position_scale``, ``velocity_scale`` of `skeleton`,
    a ``specs.SkeletonSpec``)."""
    rel = (global_positions[..., 1:, :] - global_positions[..., :1, :]) / skeleton.position_scale
    rel = rel.reshape(rel.shape[:-2] + (-1,))
    vel = F.root_velocities(root_positions, skeleton.velocity_scale)
    return jnp.concatenate([rel, vel], axis=-1)
