"""Naive in-betweening baselines of the LAFAN1 benchmark (docs/design.md §4), float64 numpy.

Both take the start keyframe and (for interpolation) the target keyframe as local poses and return
the ``length`` in-between frames, as local rotations (..., L, J, 4) and local positions (..., L, J, 3).
"""
from __future__ import annotations

import numpy as np

# The official benchmark falls back to a normalised linear blend when 1 - |dot| < 0.01
# (nearly equal rotations); keeping it reproduces its numbers to the last digit.
OFFICIAL_LINEAR_THRESHOLD = 0.01


def transition_weights(length: int) -> np.ndarray:
    """Blend weights of the ``length`` in-between frames: linspace(0, 1, length + 2)[1:-1]."""
    return np.linspace(0.0, 1.0, length + 2)[1:-1]


def _normalise(q, eps=1e-8):
    return q / (np.linalg.norm(q, axis=-1, keepdims=True) + eps)


def slerp_to_hemisphere(
    start, end, weights, linear_threshold: float = OFFICIAL_LINEAR_THRESHOLD
) -> np.ndarray:
    """Spherical interpolation from ``start`` to ``end`` after flipping ``end`` into the start's
    hemisphere, as in the official benchmark.

    start, end: (..., 4) quaternions (w, x, y, z), normalised here; weights: (L,) in [0, 1].
    Where 1 - |dot| < linear_threshold the blend is linear; every result is normalised.
    Returns (L, ..., 4): one interpolated quaternion array per weight.
    """
    q0 = _normalise(np.asarray(start, dtype=np.float64))
    q1 = _normalise(np.asarray(end, dtype=np.float64))
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)  # (..., 1)
    q1 = np.where(dot < 0, -q1, q1)
    dot = np.abs(dot)
    w = np.asarray(weights, dtype=np.float64).reshape((-1,) + (1,) * q0.ndim)  # (L, 1, ..., 1)
    linear = (1.0 - dot) < linear_threshold
    omega = np.arccos(np.clip(dot, -1.0, 1.0))
    sin_omega = np.where(linear, 1.0, np.sin(omega))
    a0 = np.where(linear, 1.0 - w, np.sin((1.0 - w) * omega) / sin_omega)
    a1 = np.where(linear, w, np.sin(w * omega) / sin_omega)
    return _normalise(a0 * q0 + a1 * q1)


def zero_velocity(start_rotations, start_positions, length: int) -> tuple[np.ndarray, np.ndarray]:
    """Zero-velocity baseline: the start keyframe's local pose held for every in-between frame.

    start_rotations: (..., J, 4) local quaternions; start_positions: (..., J, 3) local positions.
    Returns local rotations (..., L, J, 4) and local positions (..., L, J, 3), L = length.
    """
    r = np.asarray(start_rotations, dtype=np.float64)[..., None, :, :]
    p = np.asarray(start_positions, dtype=np.float64)[..., None, :, :]
    shape = r.shape[:-3] + (length,)
    return (
        np.broadcast_to(r, shape + r.shape[-2:]).copy(),
        np.broadcast_to(p, shape + p.shape[-2:]).copy(),
    )


def interpolation(
    start_rotations,
    start_positions,
    target_rotations,
    target_positions,
    length: int,
    linear_threshold: float = OFFICIAL_LINEAR_THRESHOLD,
) -> tuple[np.ndarray, np.ndarray]:
    """Interpolation baseline: local quaternions by slerp (target flipped into the start's
    hemisphere), local positions (the root trajectory; bone offsets are constant) linearly,
    with weights linspace(0, 1, length + 2) without its two ends.

    start_*/target_*: (..., J, 4) local quaternions and (..., J, 3) local positions.
    Returns local rotations (..., L, J, 4) and local positions (..., L, J, 3).
    """
    w = transition_weights(length)
    rotations = slerp_to_hemisphere(start_rotations, target_rotations, w, linear_threshold)
    rotations = np.moveaxis(rotations, 0, -3)  # (L, ..., J, 4) -> (..., L, J, 4)
    p0 = np.asarray(start_positions, dtype=np.float64)[..., None, :, :]
    p1 = np.asarray(target_positions, dtype=np.float64)[..., None, :, :]
    positions = p0 + w[:, None, None] * (p1 - p0)
    return rotations, positions
