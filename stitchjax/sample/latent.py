"""Latent-space exploration: rollouts with given latent noise, and every per-step output of them.

    start, target, offsets = window_keyframes(model, windows, start=9, length=30)
    noise = rng.standard_normal((len(windows), 8) + noise_shape(model, 30))   # (B, S, n, 2, latent)
    out = rollout_details(model, start, target, offsets, 30, noise)   # + "mu", "mu_target", "stitch_loss", ...

Used by ``notebooks/latent_space.ipynb`` (PCA of the codes, where the forward and backward latents meet,
latent interpolation, diversity against length); sampling from the prior is ``stitchjax.sample.inbetween``.
"""
from __future__ import annotations

import functools
import os
import pathlib

import jax
import jax.numpy as jnp
import numpy as np

from stitchjax.model import rollout as rollout_lib
from stitchjax.sample.inbetween import align_keyframes, check_request, check_skeleton, stitch_losses
from stitchjax.sample.trained_model import InbetweenError, Model

__all__ = ["noise_shape", "window_keyframes", "rollout_details", "checkpoint_from_env", "DEMO"]

DEMO = "demo"  # STITCHJAX_CHECKPOINT=demo: the notebook trains a tiny model for a few steps (an untrained demo)


def checkpoint_from_env(environ=None):
    """The run folder the notebook is asked to explore: ``STITCHJAX_CHECKPOINT`` as a path, or :data:`DEMO`.

    A relative path is taken from the directory the command was run in: ``STITCHJAX_CWD``, else the shell's
    ``PWD`` (``jupyter nbconvert`` runs the kernel in ``notebooks/``, so the kernel's own working directory is
    not it). Raises FileNotFoundError when the variable is unset or names nothing (the message names the
    resolved path); no model is ever made up unless asked for by name (``STITCHJAX_CHECKPOINT=demo``).
    """
    environ = os.environ if environ is None else environ
    value = environ.get("STITCHJAX_CHECKPOINT", "").strip()
    if not value:
        raise FileNotFoundError("STITCHJAX_CHECKPOINT is not set: set it to a training run folder (bin/train "
                                "--workdir DIR), e.g. STITCHJAX_CHECKPOINT=runs/quickstart, or to 'demo' for "
                                "a tiny model trained for 3 steps (an untrained demo)")
    if value == DEMO:
        return DEMO
    path = pathlib.Path(value).expanduser()
    base = None
    if not path.is_absolute():
        base = environ.get("STITCHJAX_CWD") or environ.get("PWD") or os.getcwd()
        path = pathlib.Path(base) / path
    if not path.exists():
        where = f" (a relative path is taken from {base}, the directory the command was run in)" if base else ""
        raise FileNotFoundError(f"STITCHJAX_CHECKPOINT={value}: {path} does not exist{where}; pass a training "
                                f"run folder (bin/train --workdir DIR) or one of its checkpoints/<step> folders")
    return path


def noise_shape(model: Model, length: int) -> tuple:
    """Shape (n, 2, latent_dim) of the standard-normal noise one rollout of ``length`` frames draws:
    n scan steps, [forward, backward] generator, latent size."""
    spec = model.rollout_spec
    return (rollout_lib.num_steps(spec, int(length)), 2, int(spec.generator.latent_dim))


def _rollout_with_noise(params, phase_params, start, target, offsets, noise, spec, length):
    """``rollout.rollout`` with its latent noise (n, 2, latent) given instead of drawn from a key."""
    return rollout_lib.rollout(params, phase_params, (start, target, offsets), jax.random.PRNGKey(0), spec,
                               length, length, latent={"noise": noise})


@functools.lru_cache(maxsize=16)
def _compiled_details(spec, length: int):
    def one(params, phase_params, start, target, offsets, noise):
        out = _rollout_with_noise(params, phase_params, start, target, offsets, noise, spec, length)
        out["stitch_loss"] = stitch_losses(out)
        return out

    per_window = jax.vmap(one, in_axes=(None, None, None, None, None, 0))  # samples
    return jax.jit(jax.vmap(per_window, in_axes=(None, None, 0, 0, 0, 0)))  # windows


def window_keyframes(model: Model, windows, start: int, length: int) -> tuple:
    """Keyframes of B windows in the model's frame: (start, target, offsets) as ``sample_transitions``
    takes them; target = frame start + length + 1; contacts from ``windows.contacts``."""
    check_skeleton(model, windows.skeleton)
    target = start + length + 1
    if not 0 <= start < target < windows.rotations.shape[1]:
        raise InbetweenError(f"keyframes {start} and {target} are outside windows of {windows.rotations.shape[1]} frames")
    rot, pos = np.asarray(windows.rotations, np.float64), np.asarray(windows.positions, np.float64)
    aligned_rot, aligned_pos, _, _ = align_keyframes(rot[:, start], pos[:, start], rot[:, target], pos[:, target],
                                                model.parents, model.forward_axis)
    contacts = np.asarray(windows.contacts, np.float64)
    start_kf = {"rotations": aligned_rot[:, 0], "root_position": aligned_pos[:, 0, 0], "contacts": contacts[:, start]}
    target_kf = {"rotations": aligned_rot[:, 1], "root_position": aligned_pos[:, 1, 0],
                 "contacts": contacts[:, target]}
    return start_kf, target_kf, pos[:, start]


def rollout_details(model: Model, start: dict, target: dict, offsets, length: int, noise) -> dict:
    """Full rollouts (model frame) of B keyframe pairs with given latent noise, for exploring the latent space.

    start, target, offsets: as from :func:`window_keyframes` (leading B); noise: (B, S, n, 2, latent)
    standard-normal draws (``noise_shape``), e.g. interpolations between two draws. Returns numpy
    ``rollout.rollout`` dicts with leading (B, S): the stitched motion, the forward and backward
    generators' per-step outputs including their Gaussians ("mu", "mu_target", "mu_blend", ...) and
    "stitch_loss" (B, S). Compiled once per (length, B, S).
    """
    check_request(model, length, 1, 0, warn=True)
    noise = jnp.asarray(noise, jnp.float32)
    expected = noise_shape(model, length)
    if noise.ndim != 5 or noise.shape[2:] != expected:
        raise InbetweenError(f"noise must be (B, S) + {expected} for length {length}, got {noise.shape}")
    as32 = functools.partial(jnp.asarray, dtype=jnp.float32)
    out = _compiled_details(model.rollout_spec, int(length))(
        model.params, model.phase_params, jax.tree.map(as32, start), jax.tree.map(as32, target), as32(offsets), noise)
    return jax.tree.map(np.asarray, out)
