"""The generator and discriminator objectives (paper Eq. 9) over one rollout of a batch, weighing the terms of
:mod:`stitchjax.model.losses` (weights in ``config.loss``)::

    L = L_state + 1.0 L_kl + 0.5 L_stitch + 0.5 L_fk + 0.1 L_D + 0.1 L_G

Every mechanism beyond Eq. 9 is off by default and named in ``config.EXTENSIONS`` (``config.extensions_on``
says which a config turns on). Optional, not in the paper: ``loss.foot_skate_weight`` x ``losses.foot_skate_loss``,
``loss.foot_velocity_weight`` x ``losses.foot_velocity_loss`` and ``loss.ground_penetration_weight`` x
``losses.ground_penetration_loss``.

L_kl: with ``model.posterior="next_frame"`` KL(q || p) of the posterior against the latent-interpolation
prior (``loss.free_bits``, warm-up ``loss.kl_warmup_steps``); with "none" the paper's KL(p || N(0, I)).

L_state, L_kl and L_fk are averaged over the forward and backward generators. The generator update
minimises ``generator_loss`` (everything but L_D); the discriminator update minimises
``discriminator_loss`` = 0.1 L_D (``model.discriminators=false``, Appendix D: neither L_G nor L_D, and no
discriminator update). One train step does ONE rollout (``generator_rollouts``), which
``generator_objective`` scores; it returns the (stop-gradient) discriminator features of the generated
motion as its third output, which ``discriminator_loss`` takes as its ``generated`` argument. The
objective reads frozen specs built once where the train step is made (``stitchjax.specs``): a
``TrainSpec`` holds the rollout's ``RolloutSpec`` (the model), the ``LossSpec`` (``config.loss`` and the model
switches that decide which terms exist) and the ``SkeletonSpec`` (feet, up axis, scales of the dataset).
The rollout is ``batch.rollout_batch`` unless the caller passes another with the same signature and values
(``rollout_batch``: the training step passes its own).
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from stitchjax.model import batch as batch_lib
from stitchjax.model import networks
from stitchjax.model.losses import (disc_features, fk_loss, foot_height_contacts, foot_skate_loss,
                                    foot_velocity_loss, ground_penetration_loss, kl_loss, lsgan_discriminator_loss,
                                    lsgan_generator_loss, masked_mean, posterior_kl_loss, state_loss, stitching_loss)

__all__ = [
    "generator_loss", "generator_rollouts", "generator_objective", "discriminator_loss", "direction_targets",
    "kl_warmup", "adversarial_generator_terms",
]


def generator_loss(params, phase_params, batch, key, spec, length, kl_scale=1.0,
                   rollout_batch=batch_lib.rollout_batch):
    """Generator objective for one batch (paper Eq. 9 without L_D): :func:`generator_rollouts` (the
    train step's one rollout) scored by :func:`generator_objective`.

    Args:
      params: {"forward", "backward", "disc_short", "disc_long"}.
      phase_params: frozen phase network params (or None: zero phase features).
      batch: dict from ``features.prepare_dataset`` with leading (B, T); T - 2 is the maximum length.
      key: PRNG key; spec: ``specs.TrainSpec`` (static: ``specs.train_spec(config)``); length: traced int
      transition length.
      kl_scale: factor on the KL weight (the warm-up, :func:`kl_warmup`).
      rollout_batch: the batch's rollout (``batch.rollout_batch``, or one with its signature and values).
    Returns:
      (total, terms, generated): total scalar; terms dict of scalars "state", "kl", "kl_prior", "fk",
      "stitch", "adv_g", "adv_g_short", "adv_g_long" (not without discriminators), "rotation", "velocity",
      "contact" (and per-direction "state_forward", ...; "foot_skate", "foot_velocity", "ground_penetration"
      with their weights); generated = {"features" (B, T, F) stop-gradient discriminator input of the stitched
      motion the adversarial terms saw, "mask" (B, T)} for :func:`discriminator_loss`.
    """
    out = generator_rollouts(params, phase_params, batch, key, spec, length, rollout_batch)
    return generator_objective(params, out, batch, length, spec.loss, spec.skeleton, kl_scale)


def generator_rollouts(params, phase_params, batch, key, spec, length, rollout_batch=batch_lib.rollout_batch) -> dict:
    """The rollout the generator objective scores: ``rollout_batch`` (default ``batch.rollout_batch``; the
    training step passes its own, same values) of the batch, z from the posterior when ``model.posterior`` has
    one (the windows of ``loss.prior_sample_fraction`` from the prior). spec: the ``TrainSpec`` (its
    ``rollout`` spec is the model)."""
    posterior_key, _ = jax.random.split(key)  # the first of two keys: the randomness every run was trained with
    return rollout_batch(params, phase_params, batch, posterior_key, spec.rollout, length)


def generator_objective(params, out, batch, length, spec, skeleton, kl_scale=1.0):
    """Generator objective (paper Eq. 9 without L_D) of the rollout ``out`` of :func:`generator_rollouts`.

    params: the discriminators' params {"disc_short", "disc_long"} (others ignored); batch: the ground truth;
    spec: the ``LossSpec`` (weights, posterior, directions, discriminators); skeleton: the ``SkeletonSpec``
    (scales, feet, up axis); kl_scale: factor on the KL weight (the warm-up, :func:`kl_warmup`).
    Returns (total, terms, generated) as :func:`generator_loss`.
    """
    lc = spec.loss
    n = out["forward"]["mask"].shape[1]
    directions = ["forward"] + (["backward"] if spec.bidirectional else [])
    terms = {}
    for name in directions:
        target = direction_targets(batch, length, n, name == "backward", skeleton)
        for term, value in _direction_terms(out[name], target, lc, skeleton, spec.posterior).items():
            terms[f"{term}_{name}"] = value
    for term in ("state", "kl", "kl_penalty", "kl_prior", "fk", "rotation", "velocity", "contact"):
        terms[term] = sum(terms[f"{term}_{d}"] for d in directions) / len(directions)
    terms["stitch"] = _overlap_stitching_loss(out, skeleton)
    if spec.discriminators is not None:  # model.discriminators=false: no adversarial term at all
        terms.update(adversarial_generator_terms(params, out, spec, skeleton))
    if lc.foot_skate_weight:
        terms["foot_skate"] = _foot_skate_term(out, batch, lc, skeleton)
    if lc.foot_velocity_weight:
        terms["foot_velocity"] = _foot_velocity_term(out, batch, skeleton)
    if lc.ground_penetration_weight:
        terms["ground_penetration"] = _ground_penetration_term(out, batch, skeleton)
    kl_weight = lc.kl_weight * kl_scale
    total = (terms["state"] + kl_weight * terms.pop("kl_penalty") + lc.stitch_weight * terms["stitch"]
             + lc.fk_weight * terms["fk"] + lc.gen_weight * terms.get("adv_g", 0.0)
             + lc.foot_skate_weight * terms.get("foot_skate", 0.0)
             + lc.foot_velocity_weight * terms.get("foot_velocity", 0.0)
             + lc.ground_penetration_weight * terms.get("ground_penetration", 0.0))
    for name in directions:
        terms.pop(f"kl_penalty_{name}")
    fake = disc_features(out["global_positions"], out["root_positions"], skeleton)
    generated = {"features": jax.lax.stop_gradient(fake), "mask": out["mask"]}
    return total, terms, generated


def discriminator_loss(params, phase_params, batch, key, spec, length, generated=None):
    """Discriminator objective: ``loss.disc_weight`` * L_D summed over the short and long discriminators.

    spec: ``specs.TrainSpec``. generated: the third output of :func:`generator_loss` (reuses its rollout);
    None = run a rollout here (``batch.rollout_batch``, under stop_gradient). Returns (total, {"adv_d",
    "adv_d_short", "adv_d_long", "d_real", "d_fake"}). ValueError for a model without discriminators.
    """
    skeleton, ls, discriminators = spec.skeleton, spec.loss, spec.loss.discriminators
    if discriminators is None:
        raise ValueError("the model has no discriminators (model.discriminators=false): there is no L_D to train")
    if generated is None:
        out = batch_lib.rollout_batch(jax.lax.stop_gradient(params), phase_params, batch, key, spec.rollout,
                                      length)
        generated = {"features": disc_features(out["global_positions"], out["root_positions"], skeleton),
                     "mask": out["mask"]}
    fake = jax.lax.stop_gradient(generated["features"])
    mask = generated["mask"]
    real = _real_features(batch, skeleton, fake.shape[1])
    real_short, real_long = _disc_scores(params, discriminators, real)
    fake_short, fake_long = _disc_scores(params, discriminators, fake)
    m_short = _window_mask(mask, discriminators.short_window)
    m_long = _window_mask(mask, discriminators.long_window)
    terms = {
        "adv_d_short": lsgan_discriminator_loss(real_short, fake_short, m_short),
        "adv_d_long": lsgan_discriminator_loss(real_long, fake_long, m_long),
        "d_real": 0.5 * (masked_mean(real_short, m_short) + masked_mean(real_long, m_long)),
        "d_fake": 0.5 * (masked_mean(fake_short, m_short) + masked_mean(fake_long, m_long)),
    }
    terms["adv_d"] = terms["adv_d_short"] + terms["adv_d_long"]
    return ls.loss.disc_weight * terms["adv_d"], terms


def _direction_terms(out_dir, target, loss_config, skeleton, posterior: str):
    """Per-direction terms: "state" and its parts, "fk", "kl" (the KL that is reported), "kl_penalty" (what
    the objective weights: with free bits) and "kl_prior" (KL(p || N(0, I)), reported)."""
    lc = loss_config
    mask = out_dir["mask"]
    state, parts = state_loss(out_dir, target, mask, lc)
    prior_kl = kl_loss(out_dir["mu_blend"], out_dir["logvar_blend"], mask)
    if posterior == "none":
        kl = penalty = prior_kl  # the paper's term: the sampling distribution against N(0, I)
    else:
        kl, penalty = posterior_kl_loss(out_dir, mask, lc.free_bits)
    fk = fk_loss(out_dir["global_positions"], target["global_positions"], mask, skeleton.position_scale)
    return {"state": state, "kl": kl, "kl_penalty": penalty, "kl_prior": prior_kl, "fk": fk, **parts}


def direction_targets(batch, length, num_steps: int, backward: bool, skeleton):
    """Ground truth for one direction's per-step outputs (``batch.direction_frames``; `skeleton` gives
    the velocity scale)."""
    return batch_lib.direction_frames(batch, length, num_steps, backward, skeleton.velocity_scale)


def kl_warmup(step, warmup_steps: int):
    """KL weight factor min(1, step / warmup_steps) (1 when warmup_steps <= 0)."""
    if warmup_steps <= 0:
        return jnp.ones((), jnp.float32)
    return jnp.clip(jnp.asarray(step, jnp.float32) / float(warmup_steps), 0.0, 1.0)


def adversarial_generator_terms(params, out, spec, skeleton) -> dict:
    """LSGAN generator terms of a stitched rollout: "adv_g_short", "adv_g_long", "adv_g" (their sum).
    spec: the ``LossSpec``; skeleton: the ``SkeletonSpec``."""
    fake = disc_features(out["global_positions"], out["root_positions"], skeleton)
    if not spec.loss.gen_weight:
        zero = jnp.zeros((), fake.dtype)
        return {"adv_g_short": zero, "adv_g_long": zero, "adv_g": zero}
    mask = out["mask"]
    discriminators = spec.discriminators
    short, long = _disc_scores(params, discriminators, fake)
    terms = {"adv_g_short": lsgan_generator_loss(short, _window_mask(mask, discriminators.short_window)),
             "adv_g_long": lsgan_generator_loss(long, _window_mask(mask, discriminators.long_window))}
    terms["adv_g"] = terms["adv_g_short"] + terms["adv_g_long"]
    return terms


def _disc_scores(params, spec, features):
    """Scores of the short and long discriminators of a ``networks.DiscriminatorSpec``."""
    short = networks.make_discriminator(spec, "disc_short").apply(params["disc_short"], features)
    long = networks.make_discriminator(spec, "disc_long").apply(params["disc_long"], features)
    return short, long


def _real_features(batch, skeleton, num_frames: int):
    return disc_features(batch["global_positions"][:, :num_frames], batch["root_positions"][:, :num_frames],
                         skeleton)


def _window_mask(motion_mask, window: int):
    """Valid window positions (..., T - window + 1): every frame of the window inside the motion."""
    t = motion_mask.shape[-1]
    count = jnp.sum(motion_mask.astype(jnp.int32), axis=-1, keepdims=True)
    start = jnp.arange(t - window + 1)
    return start + window <= count


def _overlap_stitching_loss(out, skeleton):
    ov = out["overlap"]
    return stitching_loss(ov["forward_positions"], ov["backward_positions"], ov["mask"], skeleton.position_scale)


def _fixed_feet(skeleton, field: str):
    """The contact joints of `skeleton` (a ``SkeletonSpec``); a ValueError naming `field` when the dataset
    reads them per file."""
    if skeleton.feet is None:
        raise ValueError(f"{field} needs a dataset with fixed feet; {skeleton.dataset!r} reads them from its "
                         f"files (set {field}=0)")
    return skeleton.feet


def _foot_skate_term(out, batch, loss_config, skeleton):
    """loss.foot_skate_weight's term on the stitched motion `out`, with the feet of `skeleton` (a
    ``SkeletonSpec``) and the contacts that ``loss.foot_skate_contacts`` names."""
    feet = _fixed_feet(skeleton, "loss.foot_skate_weight")
    positions, mask = out["global_positions"], out["mask"]
    t = positions.shape[1]
    if loss_config.foot_skate_contacts == "truth":
        return foot_skate_loss(positions, batch["contacts"][:, :t], mask, feet, skeleton.position_scale)
    if loss_config.foot_skate_contacts == "predicted":  # the generator's own contacts, as weights only
        return foot_skate_loss(positions, jax.lax.stop_gradient(out["contacts"]), mask, feet,
                               skeleton.position_scale, up_axis=skeleton.up_index)
    if skeleton.up_sign < 0:  # heights would be measured downwards
        raise ValueError(f"loss.foot_skate_contacts={loss_config.foot_skate_contacts!r} needs windows with a "
                         f"positive up axis; {skeleton.dataset!r} loads them {skeleton.up_axis!r} up (use 'truth')")
    up_axis = skeleton.up_index
    contacts = foot_height_contacts(positions, batch["global_positions"][:, :t], mask, feet, up_axis,
                                    either_end=loss_config.foot_skate_contacts == "height_either")
    return foot_skate_loss(positions, contacts, mask, feet, skeleton.position_scale, up_axis=up_axis)


def _foot_velocity_term(out, batch, skeleton):
    """loss.foot_velocity_weight's term on the stitched motion `out`, with the feet of `skeleton`."""
    feet = _fixed_feet(skeleton, "loss.foot_velocity_weight")
    positions = out["global_positions"]
    return foot_velocity_loss(positions, batch["global_positions"][:, :positions.shape[1]], out["mask"], feet,
                              skeleton.position_scale)


def _ground_penetration_term(out, batch, skeleton):
    """loss.ground_penetration_weight's term on the stitched motion `out`, with the feet of `skeleton`."""
    feet = _fixed_feet(skeleton, "loss.ground_penetration_weight")
    if skeleton.up_sign < 0:  # heights would be measured downwards
        raise ValueError(f"loss.ground_penetration_weight needs windows with a positive up axis; "
                         f"{skeleton.dataset!r} loads them {skeleton.up_axis!r} up (set it to 0)")
    positions = out["global_positions"]
    return ground_penetration_loss(positions, batch["global_positions"][:, :positions.shape[1]], out["mask"], feet,
                                   skeleton.position_scale, skeleton.up_index)
