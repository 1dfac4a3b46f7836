"""Quaternion maths, shared by the data pipeline (numpy, float64) and the model (jax.numpy, float32).

Quaternions are arrays whose last axis holds (w, x, y, z); products are Hamilton products, and
``quat_mul(a, b)`` applies ``b`` first, then ``a``. Every function accepts any leading batch shape.
NumPy inputs give NumPy outputs; JAX inputs give JAX outputs (jit, vmap and grad safe: the
degenerate points — zero quaternions, equal or opposite slerp endpoints, zero rotation vectors —
give finite values and finite gradients).
"""
from __future__ import annotations

import sys

import numpy as np

_AXES = {"x": 0, "y": 1, "z": 2}


def array_module(*arrays):
    """The array module for the inputs: jax.numpy if any of them is a JAX array or tracer.

    JAX is not imported here: data-only processes (BVH parsing, statistics) never pay for it, and an
    input can only be a JAX array if the caller already imported jax.
    """
    jax = sys.modules.get("jax")
    if jax is not None and any(isinstance(a, jax.Array) for a in arrays):
        import jax.numpy as jnp

        return jnp
    return np


def _split(q):
    return q[..., 0], q[..., 1], q[..., 2], q[..., 3]


def quat_identity(shape=(), like=None):
    """Identity quaternions of shape ``shape + (4,)`` (dtype and array module follow ``like``)."""
    xp = array_module(like) if like is not None else np
    dtype = like.dtype if like is not None else np.float64
    one = xp.ones(tuple(shape) + (1,), dtype=dtype)
    return xp.concatenate([one, xp.zeros(tuple(shape) + (3,), dtype=dtype)], axis=-1)


def quat_mul(a, b):
    """Hamilton product ``a * b`` (rotation ``b`` then ``a``). Shapes broadcast: (..., 4)."""
    xp = array_module(a, b)
    aw, ax, ay, az = _split(a)
    bw, bx, by, bz = _split(b)
    return xp.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def quat_conjugate(q):
    """(w, -x, -y, -z): the inverse of a unit quaternion."""
    xp = array_module(q)
    return xp.concatenate([q[..., :1], -q[..., 1:]], axis=-1)


def quat_inverse(q, eps: float = 1e-12):
    """Inverse ``conj(q) / |q|²`` of any non-zero quaternion."""
    xp = array_module(q)
    return quat_conjugate(q) / xp.maximum(xp.sum(q * q, axis=-1, keepdims=True), eps)


def quat_normalize(q, eps: float = 1e-8):
    """Unit quaternion ``q / |q|``. Safe at zero: returns a finite value with finite gradients
    (the norm is computed as ``sqrt(|q|² + eps²)``, so a zero input maps to zero, not NaN)."""
    xp = array_module(q)
    return q / xp.sqrt(xp.sum(q * q, axis=-1, keepdims=True) + eps * eps)


def quat_rotate(q, v):
    """Rotate vectors ``v`` (..., 3) by unit quaternions ``q`` (..., 4)."""
    xp = array_module(q, v)
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * xp.cross(u, v)
    return v + w * t + xp.cross(u, t)


def quat_from_axis_angle(axis, angle):
    """Rotation of ``angle`` radians (...) about unit ``axis`` (..., 3)."""
    xp = array_module(axis, angle)
    half = 0.5 * angle[..., None]
    return xp.concatenate([xp.cos(half), xp.sin(half) * axis], axis=-1)


def _check_order(order: str) -> str:
    order = order.lower()
    if len(order) != 3 or any(c not in _AXES for c in order):
        raise ValueError(f"Euler order must be three of 'x', 'y', 'z' (e.g. 'zyx'), got {order!r}")
    return order


def _axis_quat(xp, angle, axis_letter):
    half = 0.5 * angle
    c, s = xp.cos(half), xp.sin(half)
    zero = xp.zeros_like(angle)
    parts = [c, zero, zero, zero]
    parts[1 + _AXES[axis_letter]] = s
    return xp.stack(parts, axis=-1)


def euler_to_quat(angles, order: str = "zyx"):
    """Euler angles (..., 3) in radians to quaternions, BVH convention.

    ``order`` lists the channels as they appear in the file, e.g. ``"zyx"`` for
    ``Zrotation Yrotation Xrotation``: q = q_z(angles[..., 0]) * q_y(angles[..., 1]) * q_x(angles[..., 2]).
    Any order of three axes is accepted, including repeated ones such as ``"zxz"``.
    """
    order = _check_order(order)
    xp = array_module(angles)
    q0 = _axis_quat(xp, angles[..., 0], order[0])
    q1 = _axis_quat(xp, angles[..., 1], order[1])
    q2 = _axis_quat(xp, angles[..., 2], order[2])
    return quat_mul(q0, quat_mul(q1, q2))


def quat_to_matrix(q):
    """Unit quaternions (..., 4) to rotation matrices (..., 3, 3) acting on column vectors."""
    xp = array_module(q)
    w, x, y, z = _split(q)
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    rows = [
        [1 - 2 * (yy + zz), 2 * (xy - wz), 2 * (xz + wy)],
        [2 * (xy + wz), 1 - 2 * (xx + zz), 2 * (yz - wx)],
        [2 * (xz - wy), 2 * (yz + wx), 1 - 2 * (xx + yy)],
    ]
    return xp.stack([xp.stack(r, axis=-1) for r in rows], axis=-2)


def matrix_to_quat(m):
    """Rotation matrices (..., 3, 3) to unit quaternions (..., 4) with w >= 0.

    Uses the numerically best-conditioned of the four standard formulas per element.
    """
    xp = array_module(m)
    m00, m01, m02 = m[..., 0, 0], m[..., 0, 1], m[..., 0, 2]
    m10, m11, m12 = m[..., 1, 0], m[..., 1, 1], m[..., 1, 2]
    m20, m21, m22 = m[..., 2, 0], m[..., 2, 1], m[..., 2, 2]
    trace = m00 + m11 + m22
    # Four candidate (unnormalised) quaternions, each well conditioned when its pivot is largest.
    cands = xp.stack(
        [
            xp.stack([1 + trace, m21 - m12, m02 - m20, m10 - m01], axis=-1),
            xp.stack([m21 - m12, 1 + m00 - m11 - m22, m01 + m10, m02 + m20], axis=-1),
            xp.stack([m02 - m20, m01 + m10, 1 - m00 + m11 - m22, m12 + m21], axis=-1),
            xp.stack([m10 - m01, m02 + m20, m12 + m21, 1 - m00 - m11 + m22], axis=-1),
        ],
        axis=-2,
    )
    pivots = xp.stack([trace, m00, m11, m22], axis=-1)
    best = xp.argmax(pivots, axis=-1)
    q = xp.take_along_axis(cands, best[..., None, None], axis=-2)[..., 0, :]
    q = quat_normalize(q)
    return xp.where(q[..., :1] < 0, -q, q)


def quat_to_euler(q, order: str = "zyx"):
    """Inverse of :func:`euler_to_quat`: unit quaternions (..., 4) to angles (..., 3) in radians.

    For Tait-Bryan orders (three distinct axes) the middle angle lies in [-pi/2, pi/2]; for proper
    Euler orders (first axis == last axis) it lies in [0, pi]. At gimbal lock the first angle is 0.
    """
    order = _check_order(order)
    xp = array_module(q)
    i, j, k = (_AXES[c] for c in order)
    r = quat_to_matrix(q)
    if i != k:
        # R = R_i(a) R_j(b) R_k(c); sign of the cyclic permutation (i, j, k).
        sign = 1.0 if (j - i) % 3 == 1 else -1.0
        sin_b = xp.clip(sign * r[..., i, k], -1.0, 1.0)
        b = xp.arcsin(sin_b)
        a = xp.arctan2(-sign * r[..., j, k], r[..., k, k])
        c = xp.arctan2(-sign * r[..., i, j], r[..., i, i])
        # Gimbal lock: put the whole rotation into c.
        locked = xp.abs(sin_b) > 1.0 - 1e-9
        c_locked = xp.arctan2(sign * r[..., j, i], r[..., j, j])
        a = xp.where(locked, 0.0, a)
        c = xp.where(locked, c_locked, c)
        return xp.stack([a, b, c], axis=-1)
    # Proper Euler angles: R = R_i(a) R_j(b) R_i(c); l is the remaining axis.
    l = 3 - i - j
    sign = 1.0 if (j - i) % 3 == 1 else -1.0
    cos_b = xp.clip(r[..., i, i], -1.0, 1.0)
    b = xp.arccos(cos_b)
    a = xp.arctan2(r[..., j, i], -sign * r[..., l, i])
    c = xp.arctan2(r[..., i, j], sign * r[..., i, l])
    locked = xp.abs(cos_b) > 1.0 - 1e-9
    c_locked = xp.arctan2(sign * r[..., l, j], r[..., j, j])
    a = xp.where(locked, 0.0, a)
    c = xp.where(locked, c_locked, c)
    return xp.stack([a, b, c], axis=-1)


def quat_slerp(q0, q1, t, eps: float = 1e-6):
    """Spherical linear interpolation from ``q0`` (t = 0) to ``q1`` (t = 1) along the arc between them.

    ``t`` broadcasts against the leading shape (...). No hemisphere flip is applied (flip ``q1`` first
    if the short way is wanted). Equal endpoints fall back to linear interpolation (finite values and
    gradients); opposite endpoints pass through a well-defined perpendicular quaternion.
    """
    xp = array_module(q0, q1, t)
    t = xp.asarray(t)[..., None]
    dot = xp.clip(xp.sum(q0 * q1, axis=-1, keepdims=True), -1.0, 1.0)
    # Opposite endpoints: the arc is pi long, any perpendicular direction works; pick a fixed one.
    near = xp.abs(dot) > 1.0 - eps
    theta = xp.arccos(xp.where(near, 0.0, dot))
    sin_theta = xp.sin(theta)
    w0 = xp.where(near, 1.0 - t, xp.sin((1.0 - t) * theta) / xp.where(near, 1.0, sin_theta))
    w1 = xp.where(near, t, xp.sin(t * theta) / xp.where(near, 1.0, sin_theta))
    opposite = dot < -(1.0 - eps)
    perp = xp.stack([-q0[..., 1], q0[..., 0], -q0[..., 3], q0[..., 2]], axis=-1)
    half_pi = 0.5 * np.pi
    via_perp = xp.cos(t * 2 * half_pi) * q0 + xp.sin(t * 2 * half_pi) * perp
    linear = w0 * q0 + w1 * q1
    out = xp.where(opposite, via_perp, linear)
    return xp.where(near & ~opposite, quat_normalize(out), out)


def quat_continuity(q, axis: int = 0):
    """Flip signs along ``axis`` (time) so each quaternion has a non-negative dot with its predecessor.

    Works on numpy (any float dtype) and on JAX arrays (via a cumulative product of sign flips).
    """
    xp = array_module(q)
    q = xp.moveaxis(q, axis, 0)
    dots = xp.sum(q[1:] * q[:-1], axis=-1, keepdims=True)
    flips = xp.where(dots < 0, -1.0, 1.0).astype(q.dtype)
    signs = xp.cumprod(flips, axis=0)
    out = xp.concatenate([q[:1], q[1:] * signs], axis=0)
    return xp.moveaxis(out, 0, axis)


def quat_angle(a, b):
    """Angle in radians (in [0, pi]) of the rotation taking ``b`` to ``a`` (sign-invariant)."""
    xp = array_module(a, b)
    dot = xp.abs(xp.sum(quat_normalize(a) * quat_normalize(b), axis=-1))
    return 2.0 * xp.arccos(xp.clip(dot, 0.0, 1.0))


def quat_between(u, v, eps: float = 1e-12):
    """Shortest-arc unit quaternion rotating direction ``u`` (..., 3) onto direction ``v``."""
    xp = array_module(u, v)
    w = xp.sqrt(xp.sum(u * u, axis=-1) * xp.sum(v * v, axis=-1)) + xp.sum(u * v, axis=-1)
    q = xp.concatenate([w[..., None], xp.cross(u, v)], axis=-1)
    return quat_normalize(q, eps)


def expmap_to_quat(e, eps: float = 1e-8):
    """Rotation vectors (axis * angle in radians, ..., 3) to unit quaternions. Finite at zero."""
    xp = array_module(e)
    sq = xp.sum(e * e, axis=-1, keepdims=True)
    small = sq < eps
    angle = xp.sqrt(xp.where(small, 1.0, sq))
    half = 0.5 * angle
    # sin(angle/2)/angle, with its Taylor series near zero.
    scale = xp.where(small, 0.5 - sq / 48.0, xp.sin(half) / angle)
    w = xp.where(small, 1.0 - sq / 8.0, xp.cos(half))
    return xp.concatenate([w, scale * e], axis=-1)


def quat_to_expmap(q, eps: float = 1e-8):
    """Unit quaternions to rotation vectors (..., 3) with angle in [0, pi]. Finite at identity."""
    xp = array_module(q)
    q = xp.where(q[..., :1] < 0, -q, q)
    v = q[..., 1:]
    sq = xp.sum(v * v, axis=-1, keepdims=True)
    small = sq < eps
    s = xp.sqrt(xp.where(small, 1.0, sq))
    angle = 2.0 * xp.arctan2(s, q[..., :1])
    scale = xp.where(small, 2.0 / xp.maximum(q[..., :1], eps), angle / s)
    return scale * v
