"""The easing of foot locking (:mod:`stitchjax.sample.footlock`): corrections between plants, and clearance lifts.

Given the anchor frames of one foot (its held span frames and both keyframes) and their plants,
:func:`eased_plants` (or :func:`blended_corrections`, easing the corrections themselves) says how far to move
the ankle and turn the foot on every frame, so the foot leaves a plant and lands on one at rest;
:func:`clearance_lift` lifts a foot that still moves low between plants, so it steps instead of skating.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from stitchjax import rotations as R
from stitchjax.sample.leg_ik import same_hemisphere

__all__ = ["eased_plants", "blended_corrections", "clearance_lift", "tent_max"]


def _frames_from(anchor):
    """(T,) frames since the last anchor and (T,) frames to the next one (0 at anchors; T where none)."""
    n = anchor.shape[0]

    def step(d, a):
        d = jnp.where(a, 0, d + 1)
        return d, d
    since = jax.lax.scan(step, jnp.asarray(n), anchor)[1]
    until = jax.lax.scan(step, jnp.asarray(n), anchor[::-1])[1][::-1]
    return since, until


def eased_plants(anchor, free, target, target_rotation, ankle, foot_rotation, blend_frames: int,
                 lift_power: float = 1.0, up_axis: int = 1):
    """Ankle corrections that ease the foot between its plants and the generated foot.

    anchor: (T,) bool (the kept span frames and both keyframes); free: (T,) bool anchors that plant nothing
    (keyframes outside spans: no correction there); target: (T, 3) the plant of each anchor; target_rotation:
    (T, 4) its foot rotation; ankle: (T, 3) the generated ankle; foot_rotation: (T, 4) its global rotation.
    Between two anchors dp frames after the one and dn before the next, each side's plant has the weight
    w = smoothstep(1 - d / min(blend_frames + 1, dp + dn)) (the two sum to at most 1, as in
    :func:`blended_corrections`), and the foot is put at w_prev plant_prev + w_next plant_next + the rest
    of the generated foot (vertically with the weights to the power ``lift_power``): it leaves a plant and
    lands on one at rest, and follows the generated foot in between. Returns (offset (T, 3) to add to the
    ankle, turn (T, 4) the foot's correcting rotation (identity where no plant weighs), weight (T,) the
    larger plant weight, 1 at planting anchors, arc (T,): 4 w (1 - w) x the horizontal distance from each
    side's plant, summed, 0 at anchors)."""
    identity = jnp.zeros_like(foot_rotation).at[:, 0].set(1.0)
    planting = (anchor & ~free).astype(ankle.dtype)

    def step(carry, x):
        a, p, q, k = x
        carry = tuple(jnp.where(a, new, old) for new, old in zip((p, q, k), carry))
        return carry, carry

    init = (jnp.zeros(3, ankle.dtype), identity[0], jnp.asarray(0.0, ankle.dtype))
    xs = (anchor, target, target_rotation, planting)
    _, (p_prev, q_prev, k_prev) = jax.lax.scan(step, init, xs)
    _, (p_next, q_next, k_next) = jax.lax.scan(step, init, tuple(x[::-1] for x in xs))
    p_next, q_next, k_next = p_next[::-1], q_next[::-1], k_next[::-1]
    since, until = _frames_from(anchor)
    gap = jnp.maximum(since + until, 1)
    reach = jnp.minimum(blend_frames + 1, gap).astype(ankle.dtype)
    w_prev = jnp.where(anchor, 1.0, _smoothstep(1.0 - since / reach)) * k_prev
    w_next = jnp.where(anchor, 0.0, _smoothstep(1.0 - until / reach)) * k_next
    to_prev, to_next = p_prev - ankle, p_next - ankle
    offset = w_prev[:, None] * to_prev + w_next[:, None] * to_next
    vertical = w_prev**lift_power * to_prev[:, up_axis] + w_next**lift_power * to_next[:, up_axis]
    offset = offset.at[:, up_axis].set(vertical)
    across = lambda o: jnp.sqrt(jnp.sum(o.at[:, up_axis].set(0.0) ** 2, axis=-1) + 1e-12)  # noqa: E731
    arc = 4.0 * (w_prev * (1.0 - w_prev) * across(to_prev) + w_next * (1.0 - w_next) * across(to_next))
    rest = (1.0 - w_prev - w_next)[:, None]
    foot = R.quat_normalize(w_prev[:, None] * same_hemisphere(q_prev, foot_rotation)
                            + w_next[:, None] * same_hemisphere(q_next, foot_rotation) + rest * foot_rotation)
    weight = jnp.maximum(w_prev, w_next)
    turn = jnp.where((weight > 0)[:, None], R.quat_mul(foot, R.quat_conjugate(foot_rotation)), identity)
    return offset, turn, weight, arc


def clearance_lift(height, speed, contact, anchor, clearance: float, clearance_speed: float, frames: int,
                   from_below: bool = False, keyframe=None, key_frames: int = 0, key_clearance: float = 0.0,
                   max_lift: float = float("inf")):
    """(T,) how far (cm) to lift a foot that moves low outside its plants, so that it steps clear.

    height: (T,) the foot's lowest joint above the ground (cm) after the plants' corrections; speed: (T,)
    its horizontal speed (cm/frame); contact: (T,) in [0, 1] the contact factor (0: the model predicts no
    contact, no lift); anchor: (T,) bool planted frames and keyframes (no lift). The need at a frame is
    (clearance - height)+ x ramp(speed) (0 below half ``clearance_speed``, 1 from it) x contact, at most
    ``clearance``; with ``from_below`` it is capped at ``max_lift`` instead (a foot below the ground is lifted
    to ``clearance`` above it too) and a foot below the ground is lifted at least to the ground, moving or
    not, by at most ``max_lift`` (a foot deeper than that belongs to a pose the lift cannot mend). The lift is
    the largest need within ``frames`` frames, tapered linearly with the distance, and eased to 0 over
    ``frames`` + 1 frames next to an anchor, so it starts before the foot moves and never jumps. Where
    ``keyframe`` (T,) bool is given, the clearance falls to ``key_clearance`` over ``key_frames`` + 1 frames
    next to a keyframe (the lift eased between the two), so the frames next to a keyframe stay near it."""
    if keyframe is not None and key_frames > 0:
        high = clearance_lift(height, speed, contact, anchor, clearance, clearance_speed, frames, from_below,
                              max_lift=max_lift)
        low = clearance_lift(height, speed, contact, anchor, key_clearance, clearance_speed, frames, from_below,
                             max_lift=max_lift)
        since, until = _frames_from(keyframe)
        far = _smoothstep(jnp.minimum(since, until).astype(high.dtype) / (key_frames + 1.0))
        return far * high + (1.0 - far) * low
    ramp = jnp.clip(2.0 * speed / clearance_speed - 1.0, 0.0, 1.0)
    short = jnp.maximum(clearance - height, 0.0)
    need = (short if from_below else jnp.minimum(short, clearance)) * ramp * contact
    if from_below:
        need = jnp.minimum(jnp.maximum(need, jnp.maximum(-height, 0.0)), max_lift)
    lift = tent_max(jnp.where(anchor, 0.0, need), frames)
    since, until = _frames_from(anchor)
    near = jnp.minimum(since, until).astype(need.dtype)
    return lift * _smoothstep(near / (frames + 1.0))


def tent_max(x, frames: int):
    """(T, ...) the largest of ``x`` (T, ...) within ``frames`` frames along the first axis, each neighbour
    weighted by 1 - d / (frames + 1) at distance d: a peak spread as a tent, so what follows it never jumps."""
    n = x.shape[0]
    out = x
    for d in range(1, frames + 1):
        padded = jnp.pad(x, [(d, d)] + [(0, 0)] * (x.ndim - 1))
        out = jnp.maximum(out, (1.0 - d / (frames + 1.0)) * jnp.maximum(padded[:n], padded[2 * d:]))
    return out


def _smoothstep(x):
    x = jnp.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def blended_corrections(anchor, offset, turn, blend_frames: int, lift_power: float = 1.0, up_axis: int = 1):
    """Corrections of every frame from those of the anchor frames, eased in between.

    anchor: (T,) bool (the kept span frames and both keyframes); offset: (T, 3) the ankle correction at
    anchors (0 at keyframes); turn: (T, 4) the foot's correcting rotation there (identity at keyframes).
    Between two anchors dp frames after the one and dn before the next (gap n = dp + dn), each side's
    correction is weighted by smoothstep(1 - d / min(blend_frames + 1, n)): eased out over ``blend_frames``
    frames, and the two weights sum to at most 1; the vertical part (``up_axis``) by those weights to the
    power ``lift_power``. Returns (offset (T, 3), turn (T, 4), weight (T,) the
    larger of the two side weights, 1 at anchors, arc (T,): the sum over both sides of 4 w (1 - w) times the
    horizontal length of that side's correction, 0 at anchors, at most that length mid-ease)."""
    identity = jnp.zeros_like(turn).at[:, 0].set(1.0)
    turn = same_hemisphere(turn, identity)

    def step(carry, x):
        a, o, q = x
        o_c, q_c, d_c = carry
        carry = (jnp.where(a, o, o_c), jnp.where(a, q, q_c), jnp.where(a, 0, d_c + 1))
        return carry, carry

    init = (jnp.zeros(3, offset.dtype), identity[0], jnp.asarray(0))
    _, (o_prev, q_prev, d_prev) = jax.lax.scan(step, init, (anchor, offset, turn))
    _, (o_next, q_next, d_next) = jax.lax.scan(step, init, (anchor[::-1], offset[::-1], turn[::-1]))
    o_next, q_next, d_next = o_next[::-1], q_next[::-1], d_next[::-1]
    gap = jnp.maximum(d_prev + d_next, 1)
    reach = jnp.minimum(blend_frames + 1, gap).astype(offset.dtype)
    w_prev = jnp.where(anchor, 1.0, _smoothstep(1.0 - d_prev / reach))
    w_next = jnp.where(anchor, 0.0, _smoothstep(1.0 - d_next / reach))
    blended = w_prev[:, None] * o_prev + w_next[:, None] * o_next
    vertical = w_prev**lift_power * o_prev[:, up_axis] + w_next**lift_power * o_next[:, up_axis]
    blended = blended.at[:, up_axis].set(vertical)
    across = lambda o: jnp.sqrt(jnp.sum(o.at[:, up_axis].set(0.0) ** 2, axis=-1))  # noqa: E731
    arc = 4.0 * (w_prev * (1.0 - w_prev) * across(o_prev) + w_next * (1.0 - w_next) * across(o_next))
    rest = (1.0 - w_prev - w_next)[:, None]
    rotation = R.quat_normalize(w_prev[:, None] * q_prev + w_next[:, None] * q_next + rest * identity)
    return blended, rotation, jnp.maximum(w_prev, w_next), arc
