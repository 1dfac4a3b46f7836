"""The rollout of a batch of training windows: keyframes, ground truth and latent source from the batch dict,
then :func:`rollout.rollout` of every window.

Frames of a window (``features.prepare_dataset``, leading (B, T)): the start keyframe is frame 0, the target
keyframe frame L + 1, the generated frames 1..L (docs/design.md §6). Each direction's ground truth is in its
own time (:func:`direction_frames`): the backward generator's in reversed time.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from stitchjax.data import features as F
from stitchjax.model.rollout import StepHook, num_steps, rollout

__all__ = ["rollout_batch", "vmapped_rollout", "latent_inputs", "keyframes_from_batch", "direction_frames",
           "next_frame_states", "prior_sample_flags"]


def rollout_batch(gen_params, phase_params, batch: dict, key, spec, length, max_length: int | None = None,
                  posterior: bool = True, runner=None):
    """:func:`rollout.rollout` of every window of a batch dict (from ``features.prepare_dataset``, leading B).

    Keyframes: frame 0 and frame ``length + 1`` of each window; max_length defaults to T - 2.
    Per-example noise from ``jax.random.split(key, B)``. posterior: draw z from the posterior on the
    batch's ground truth (when ``model.posterior`` has one); False = from the prior, as at inference. With
    ``loss.prior_sample_fraction`` > 0 each window draws z from the prior instead with that probability
    (:func:`prior_sample_flags`).
    runner: how the windows' rollouts run, ``runner(generators, inputs, constants, spec, max_length)`` with
    the arguments of :func:`vmapped_rollout` (None: that one, the plain vmap); another runner gives the same
    values by other means.
    Returns rollout's dict with a leading B axis, and "prior_sampled" (B,) bool: the windows whose z came
    from the prior (every window with posterior=False or posterior "none").
    Differentiable in gen_params, phase_params and the batch.
    """
    num_frames = batch["rotations"].shape[1]
    max_length = num_frames - 2 if max_length is None else int(max_length)
    if max_length + 2 > num_frames:
        raise ValueError(f"max_length={max_length} needs windows of {max_length + 2} frames, batch has {num_frames}")
    start, target, offsets = keyframes_from_batch(batch, length)
    keys = jax.random.split(key, batch["rotations"].shape[0])
    generators = {name: gen_params[name] for name in ("forward", "backward")}
    length = jnp.asarray(length, jnp.int32)
    truth, use_prior = _latent_source(batch, key, keys.shape[0], spec, length, max_length, posterior)
    run = vmapped_rollout if runner is None else runner
    out = run(generators, (phase_params, start, target, offsets, truth), (keys, length, use_prior), spec, max_length)
    return {**out, "prior_sampled": _prior_sampled(truth, use_prior, keys.shape[0])}


def vmapped_rollout(generators, inputs, constants, spec, max_length: int, checkpoint_policy=None):
    """The plain runner of :func:`rollout_batch`: :func:`rollout.rollout` vmapped over the windows.

    generators: {"forward", "backward"} params; inputs (what gradients reach): (phase_params, start, target,
    offsets, truth), all but phase_params with a leading B, truth None or {"forward", "backward"} (B, n, S);
    constants: (keys (B, 2), length () int32, use_prior (B,) bool or None); checkpoint_policy: the scan
    body's (``rollout``'s argument). Returns rollout's dict with a leading B axis.
    """
    phase_params, start, target, offsets, truth = inputs
    keys, length, use_prior = constants

    def one(s, t, o, k, g, u):
        return rollout(generators, phase_params, (s, t, o), k, spec, length, max_length,
                       latent=latent_inputs(g, u), hook=StepHook(checkpoint_policy))

    return jax.vmap(one)(start, target, offsets, keys, truth, use_prior)


def latent_inputs(truth, use_prior) -> dict | None:
    """``rollout``'s ``latent`` of one window: its posterior inputs ``truth`` ({"forward", "backward"} or None:
    z from the prior) and ``use_prior`` (() bool or None)."""
    if truth is None:
        return None
    return truth if use_prior is None else {**truth, "use_prior": use_prior}


def _latent_source(batch, key, batch_size: int, spec, length, max_length: int, posterior: bool):
    """(truth, use_prior) of :func:`rollout_batch`: the posterior inputs (None: z from the prior) and the (B,)
    windows that draw z from the prior anyway (None: no window)."""
    if not (posterior and spec.generator.posterior != "none"):
        return None, None
    truth = next_frame_states(batch, length, num_steps(spec, max_length), spec.velocity_scale)
    if spec.prior_sample_fraction != 0:  # prior_sample_flags refuses values outside [0, 1]
        return truth, prior_sample_flags(key, batch_size, spec.prior_sample_fraction)
    return truth, None


def _prior_sampled(truth, use_prior, batch_size: int):
    """(B,) bool: the windows whose z came from the prior (all of them without posterior inputs)."""
    if truth is None:  # posterior=False or posterior "none": every window from the prior
        return jnp.ones((batch_size,), bool)
    return jnp.zeros((batch_size,), bool) if use_prior is None else use_prior


def keyframes_from_batch(batch: dict, length):
    """(start, target, offsets) of a batch dict (B, T, ...): start = frame 0, target = frame length + 1."""
    index = jnp.asarray(length, jnp.int32) + 1

    def at(x, i):
        return jax.lax.dynamic_index_in_dim(x, i, axis=1, keepdims=False)

    def keyframe(i):
        return {"rotations": at(batch["rotations"], i), "root_position": at(batch["root_positions"], i),
                "contacts": at(batch["contacts"], i)}

    return keyframe(0), keyframe(index), batch["offsets"][:, 0]


def direction_frames(batch: dict, length, num_steps: int, backward: bool, velocity_scale: float) -> dict:
    """Ground truth of one direction's per-step frames (entry i = forward frame i + 1, or backward frame
    L - i), in that direction's time: "rotations" (B, n, J, 4), "velocities" (B, n, 3) scaled by
    ``velocity_scale`` (``features.VELOCITY_SCALE``; reversed time for the backward direction), "contacts"
    (B, n, C), "global_positions" (B, n, J, 3)."""
    length = jnp.asarray(length, jnp.int32)
    made = jnp.arange(1, num_steps + 1, dtype=jnp.int32)  # direction time of the frame each step makes
    frames = (length + 1 - made) if backward else made
    before = (length + 2 - made) if backward else made - 1  # the frame each step starts from

    def take(x, index=frames):
        return jnp.take(x, index, axis=1, mode="clip")

    root = batch["root_positions"]
    velocity = take(root) - take(root, before)
    velocity = velocity / velocity_scale
    return {"rotations": take(batch["rotations"]), "velocities": velocity, "contacts": take(batch["contacts"]),
            "global_positions": take(batch["global_positions"])}


def next_frame_states(batch: dict, length, num_steps: int, velocity_scale: float) -> dict:
    """Posterior inputs {"forward", "backward"}: (B, n, S) ground-truth state of the frame each step makes
    (:func:`direction_frames`; ``velocity_scale``: ``features.VELOCITY_SCALE``)."""
    out = {}
    for name in ("forward", "backward"):
        d = direction_frames(batch, length, num_steps, name == "backward", velocity_scale)
        out[name] = F.state_vector(d["rotations"], d["velocities"], d["contacts"])
    return out


def prior_sample_flags(key, batch_size: int, fraction: float):
    """(B,) bool: which windows of a training batch draw z from the prior p instead of the posterior q
    (``loss.prior_sample_fraction``), each with probability ``fraction``, from ``fold_in(key, 1)`` (the
    per-window noise keys come from ``split(key, B)``)."""
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"loss.prior_sample_fraction must be in [0, 1], got {fraction}")
    return jax.random.bernoulli(jax.random.fold_in(key, 1), fraction, (batch_size,))
