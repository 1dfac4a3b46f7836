"""The rollout's latent noise: standard normal per step and direction, drawn as a :class:`NoiseSpec` says:
scaled, optionally correlated over steps and ramped in from the keyframes (sampling settings; the paper's
sampling is the default, independent full noise at every step).
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

__all__ = ["NoiseSpec", "latent_noise", "noise_ramp", "correlated_noise"]


@dataclasses.dataclass(frozen=True)
class NoiseSpec:
    """How a rollout draws its latent noise (static, hashable; the defaults are the paper's sampling).

    scale: factor on the noise (0: every sample is the prior's or posterior's mean path); correlation: rho in
    [0, 1], each direction's noise correlated from one step to the next (:func:`correlated_noise`; 0:
    independent per frame); ramp_steps: whole steps >= 0, the noise rising from 0 at each direction's first
    step to full at this step (:func:`noise_ramp`; 0: full from the first step). Checked where they are used.
    """

    scale: float = 1.0
    correlation: float = 0.0
    ramp_steps: int = 0


def latent_noise(key, noise, shape: tuple, dtype, spec: NoiseSpec = NoiseSpec()):
    """The standard normal latent noise `shape` = (num_steps, 2, latent_dim), drawn from `key` unless
    `noise` is given, correlated over steps by ``spec.correlation``, times ``spec.scale`` and times
    :func:`noise_ramp` per step (``spec``: a :class:`NoiseSpec`)."""
    if noise is None:
        eps = jax.random.normal(key, shape, dtype)
    else:
        eps = jnp.asarray(noise, dtype)
        if eps.shape != shape:
            raise ValueError(f"noise has shape {eps.shape}; rollout needs {shape} "
                             f"= (num_steps(spec, max_length), 2, latent_dim)")
    ramp = jnp.asarray(noise_ramp(shape[0], spec.ramp_steps), dtype)[:, None, None]
    return correlated_noise(eps, spec.correlation) * jnp.asarray(spec.scale, dtype) * ramp


def noise_ramp(num_steps: int, ramp_steps: int) -> np.ndarray:
    """(num_steps,) factors on each direction's latent noise: i / ramp_steps at step i (0-based), 1 from
    step ramp_steps on. Step 0 of each direction makes the frame next to its keyframe, so with a ramp those
    frames come from the prior's mean and the samples part towards mid-transition, where the keyframes
    constrain the motion least. ramp_steps = 0: 1 everywhere (the paper's sampling). Not in the paper: an
    inference setting, part of a model's default sampling."""
    if int(ramp_steps) != ramp_steps or ramp_steps < 0:  # a fraction would be truncated silently
        raise ValueError(f"noise_ramp_steps must be a whole number of steps >= 0, got {ramp_steps}")
    ramp_steps = int(ramp_steps)
    if ramp_steps == 0:
        return np.ones((num_steps,), np.float32)
    return np.minimum(np.arange(num_steps, dtype=np.float32) / ramp_steps, 1.0)


def correlated_noise(eps, rho: float):
    """Temporally correlated latent noise: the AR(1) filter e_0 = n_0, e_t = rho e_(t-1) + sqrt(1 - rho^2) n_t
    along axis 0 (steps) of standard normal noise ``eps`` (n, ...).

    Every e_t stays standard normal (so the prior's spread is unchanged) and corr(e_t, e_s) = rho^|t-s|:
    rho = 0 returns ``eps`` itself (independent per frame, the paper's sampling), rho = 1 repeats n_0 on
    every step (one draw per transition). Not in the paper: a sampling setting that spreads the samples
    along the whole transition instead of frame by frame. rho: a static Python float in [0, 1].
    """
    rho = float(rho)
    if not 0.0 <= rho <= 1.0:
        raise ValueError(f"noise_correlation must be in [0, 1], got {rho}")
    if rho == 0.0:
        return eps
    n = eps.shape[0]
    t = np.arange(n)
    lag = t[:, None] - t[None, :]  # (n, n): t - s
    weights = np.where(lag >= 0, rho ** np.maximum(lag, 0), 0.0)
    weights[:, 1:] *= np.sqrt(1.0 - rho * rho)  # innovations n_s, s >= 1, carry sqrt(1 - rho^2)
    return jnp.tensordot(jnp.asarray(weights, eps.dtype), eps, axes=1)
