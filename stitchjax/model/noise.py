"""The rollout's latent noise: standard normal per step and direction, optionally correlated over steps
(``model.noise_correlation``) and ramped in from the keyframes (``noise_ramp_steps``, an inference setting).
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

__all__ = ["latent_noise", "noise_ramp", "correlated_noise"]


def latent_noise(key, noise, shape: tuple, dtype, noise_scale, noise_correlation=0.0, noise_ramp_steps=0):
    """The standard normal latent noise `shape` = (num_steps, 2, latent_dim), drawn from `key` unless
    `noise` is given, correlated over steps by `noise_correlation`, times `noise_scale` and times
    :func:`noise_ramp` per step."""
    if noise is None:
        eps = jax.random.normal(key, shape, dtype)
    else:
        eps = jnp.asarray(noise, dtype)
        if eps.shape != shape:
            raise ValueError(f"noise has shape {eps.shape}; rollout needs {shape} "
                             f"= (num_steps(spec, max_length), 2, latent_dim)")
    ramp = jnp.asarray(noise_ramp(shape[0], noise_ramp_steps), dtype)[:, None, None]
    return correlated_noise(eps, noise_correlation) * jnp.asarray(noise_scale, dtype) * ramp


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
    every step (one draw per transition). Not in the paper: z from the posterior moves smoothly from frame
    to frame at training (q follows the ground truth), and independent prior noise per frame does not.
    rho: a static Python float in [0, 1].
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
