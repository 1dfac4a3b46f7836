"""Speed limits on foot locking's corrections: easing a foot between plants adds no joint jump or knee snap.

Mid-swing the generated foot can be far from both plants, so the eased correction flips from pulling back to
pushing ahead within a few frames, and the IK goal crosses near-full extension, where a small change of reach
is a large change of knee angle. :func:`limit_correction_speed` keeps the corrected ankle no faster than the
generated foot's own top speed; :func:`limit_knee_speed` keeps the solved knee angle's change per frame close
to the generated knee's. Anchor frames (plants, keyframes) keep their values exactly. :func:`guard_joint_jumps` is
the last safety net: where a leg joint of the result still moves farther in one frame than any joint of the
generated transition does, the correction is pulled back towards the generated pose there.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from stitchjax import rotations as R
from stitchjax.sample.foot_easing import tent_max
from stitchjax.sample.leg_ik import same_hemisphere, soft_reach

__all__ = ["limit_correction_speed", "knee_angle", "limit_knee_speed", "guard_joint_jumps", "slope_limited"]


def limit_correction_speed(offset, ankle, anchor, floor: float):
    """(T, 3) ``offset`` (the ankle's correction) with its change per frame limited to the generated ankle's
    spare speed: at most max(V - |ankle_t - ankle_t-1|, floor) cm from frame t-1 to t, V the largest such
    step of ``ankle`` (T, 3) over the transition. So the corrected ankle's step is at most max(V, step +
    floor): no faster than the generated foot's own top speed where it moves fast, while a foot slow enough
    to spare the speed still leaves and reaches its plants at rest. anchor: (T,) bool frames whose offset is
    kept exactly (plants, keyframes); between them a forward then a backward pass clip each step towards
    ``offset``, so the limit holds wherever the gap leaves enough room."""
    step = _norm(jnp.diff(ankle, axis=0))
    allowed = jnp.maximum(jnp.max(step) - step, floor)  # (T - 1,) for the step t-1 -> t
    allowed = allowed * _gap_scale(_norm(jnp.diff(offset, axis=0)), allowed, anchor)
    return _limit_steps(offset, allowed, anchor)


def knee_angle(reach, upper, lower):
    """(...) the knee's inner angle (radians, pi: straight) of a leg whose ankle is ``reach`` from its hip."""
    return jnp.arccos(jnp.clip((upper**2 + lower**2 - reach**2) / (2.0 * upper * lower), -1.0, 1.0))


def limit_knee_speed(hip, goal, ankle, upper, lower, anchor, soft: float, step_degrees: float):
    """(T, 3) ankle goals ``goal`` moved along the hip's line so that the knee angle :func:`two_bone_ik` solves
    changes per frame by at most the generated knee's change plus ``step_degrees``.

    hip, goal, ankle: (T, 3) the hip, the ankle's goal and the generated ankle; upper, lower: the thigh and
    shin lengths; anchor: (T,) bool frames whose goal is kept (plants, keyframes); soft: the IK's
    ``soft_reach``. The angles of the softened reaches are limited as in :func:`limit_correction_speed` (the
    limit gives way where a gap between anchors is too short), then turned back into distances from the hip.
    Frames the limit leaves alone keep their goal exactly."""
    length = upper + lower
    to_goal = goal - hip
    distance = _norm(to_goal)
    shortest = jnp.abs(upper - lower) + 1e-4 * length
    angle = knee_angle(jnp.maximum(soft_reach(distance, length, soft), shortest), upper, lower)
    generated = knee_angle(_norm(ankle - hip), upper, lower)
    allowed = jnp.abs(jnp.diff(generated)) + jnp.radians(step_degrees)
    allowed = allowed * _gap_scale(jnp.diff(angle), allowed, anchor)
    limited = _limit_steps(angle, allowed, anchor)
    reach = jnp.sqrt(jnp.maximum(upper**2 + lower**2 - 2.0 * upper * lower * jnp.cos(limited), 0.0))
    knee, span = soft * length, (1.0 - soft) * length  # soft_reach inverted
    unsoftened = knee - span * jnp.log(jnp.maximum(1.0 - (reach - knee) / span, 1e-6))
    reach = jnp.where(reach > knee, unsoftened, reach)
    moved = hip + (reach / distance)[:, None] * to_goal
    return jnp.where((jnp.abs(limited - angle) > 1e-6)[:, None], moved, goal)


def _norm(x):
    """(...) Euclidean norm over the last axis (smooth at 0)."""
    return jnp.sqrt(jnp.sum(x**2, axis=-1) + 1e-12)


def _gap_scale(need, allowed, anchor):
    """(T - 1,) factor >= 1 on the allowed steps (T - 1,) between two anchors (T,) bool, so that their sum over
    each gap is at least |the sum of ``need``| (T - 1,) there (the unlimited sequence's path length, or for an
    angle its signed steps: the change from anchor to anchor): the limit gives way where a gap is too short
    for it, instead of breaking at the anchor."""
    n = anchor.shape[0]
    gap = jnp.cumsum(anchor[:-1].astype(jnp.int32))  # the steps t-1 -> t between the same two anchors
    total_need = jnp.abs(jax.ops.segment_sum(need, gap, num_segments=n + 1))[gap]
    total_allowed = jax.ops.segment_sum(allowed, gap, num_segments=n + 1)[gap]
    return jnp.maximum(1.0, total_need / jnp.maximum(total_allowed, 1e-6))


def _limit_steps(x, allowed, anchor):
    """(T, ...) ``x`` with each step t-1 -> t at most ``allowed`` (T - 1,) long: a forward then a backward pass
    clip each step towards ``x``; anchor (T,) bool frames keep ``x`` exactly."""
    def clip(v, limit):
        return v * jnp.minimum(1.0, limit / _norm(v[..., None] if v.ndim == 0 else v))

    def step_to(previous, xs):
        value, a, limit = xs
        free = a | (_norm((value - previous)[..., None] if value.ndim == 0 else value - previous) <= limit)
        out = jnp.where(free, value, previous + clip(value - previous, limit))
        return out, out

    _, forward = jax.lax.scan(step_to, x[0], (x[1:], anchor[1:], allowed))
    forward = jnp.concatenate([x[:1], forward])
    _, backward = jax.lax.scan(step_to, forward[-1], (forward[:-1], anchor[:-1], allowed), reverse=True)
    return jnp.concatenate([backward, forward[-1:]])


def guard_joint_jumps(locked, generated, generated_global, offsets, legs: tuple, parents: tuple, iterations: int,
                      floor: float = 0.0, spread: int = 3):
    """(T, J, 4) ``locked`` local rotations with no leg joint stepping farther in one frame than the largest
    step of any joint of the ``generated`` transition (T, J, 4; its global rotations and positions
    ``generated_global``: ((T, J, 4), (T, J, 3))), or than ``floor`` cm where that is more (so the pass never
    makes a fast transition's fastest motion faster). offsets: (J, 3) bone offsets; legs: (hip, knee, ankle,
    toe, ...) per leg (:func:`leg_ik.leg_chains`; only their hip, knee and ankle rotations may differ from
    ``generated``); parents: the skeleton's. Each of ``iterations`` rounds halves the leg's correction (the
    weight of ``locked`` against ``generated`` in a normalised blend of its hip, knee and ankle rotations) on
    both frames of every step of that leg still too long, and by less over ``spread``
    frames each side (a tent), so the cut leaves no dip; after each round the weight changes by at most
    1 / (2 ``spread`` + 2) per frame (:func:`slope_limited`), so cuts repeated over rounds leave no steep edge
    (a knee snapping back to its correction); frames where ``locked`` equals ``generated`` (keyframes among
    them) are returned exactly. Each round poses the legs alone (:func:`_leg_joints`), not the skeleton."""
    if iterations <= 0:
        return locked
    global_rotations, global_positions = generated_global
    steps_generated = jnp.linalg.norm(global_positions[1:] - global_positions[:-1], axis=-1)
    bound = jnp.maximum(steps_generated.max(), floor)
    joints = [jnp.asarray(leg[:3]) for leg in legs]

    def blended(weight):  # [(T, 3, 4) each leg's hip, knee and ankle rotations]; weight (T, legs): the share kept
        out = []
        for k, j in enumerate(joints):
            a, b = generated[:, j], same_hemisphere(locked[:, j], generated[:, j])
            mixed = (1.0 - weight[:, k, None, None]) * a + weight[:, k, None, None] * b
            out.append(mixed / jnp.linalg.norm(mixed, axis=-1, keepdims=True))
        return out

    def too_long(weight):  # (T-1, legs): a step of the leg's knee, ankle or toe longer than the bound
        longest = []
        for leg, rotations in zip(legs, blended(weight)):
            chain = _leg_joints(rotations, global_rotations[:, parents[leg[0]]], global_positions[:, leg[0]],
                                offsets, leg)
            longest.append(jnp.linalg.norm(chain[1:] - chain[:-1], axis=-1).max(-1))
        return jnp.stack(longest, -1) > bound

    def step(weight, _):
        cut_at = too_long(weight)
        none = jnp.zeros_like(cut_at[:1])
        frames = (jnp.concatenate([none, cut_at]) | jnp.concatenate([cut_at, none])).astype(weight.dtype)
        cut = weight * (1.0 - 0.5 * tent_max(frames, spread))  # cut smoothly over ``spread`` frames
        return slope_limited(cut, 0.5 / (spread + 1.0), 2 * spread + 2), None  # and rounds add no steep edge

    weight = jax.lax.scan(step, jnp.ones((locked.shape[0], len(legs)), locked.dtype), None, length=iterations)[0]
    guarded = locked
    for j, rotations in zip(joints, blended(weight)):
        guarded = guarded.at[:, j].set(rotations)
    same = jnp.all(locked == generated, axis=-1, keepdims=True)
    return jnp.where(same | jnp.all(weight >= 1.0, axis=1)[:, None, None], locked, guarded)


def _leg_joints(rotations, parent_rotation, hip_position, offsets, leg: tuple):
    """(T, 3, 3) the global positions of one leg's knee, ankle and toe, posed by its hip, knee and ankle local
    rotations ``rotations`` (T, 3, 4) below the hip's parent (its global rotation ``parent_rotation`` (T, 4);
    the hip's global position ``hip_position`` (T, 3)); offsets: (J, 3) bone offsets."""
    rotation, position, out = parent_rotation, hip_position, []
    for k, child in enumerate(leg[1:4]):
        rotation = R.quat_mul(rotation, rotations[:, k])
        position = position + R.quat_rotate(rotation, offsets[child])
        out.append(position)
    return jnp.stack(out, 1)


def slope_limited(weight, rate: float, frames: int):
    """(T, ...) the largest sequence at most ``weight`` (T, ...) whose value changes by at most ``rate`` per
    frame along the first axis: min over d <= ``frames`` of weight(t +- d) + rate d (``frames`` >= 1 / rate
    makes the limit exact for weights in [0, 1])."""
    n = weight.shape[0]
    out = weight
    for d in range(1, frames + 1):
        padded = jnp.pad(weight, [(d, d)] + [(0, 0)] * (weight.ndim - 1), constant_values=jnp.inf)
        out = jnp.minimum(out, jnp.minimum(padded[:n], padded[2 * d:]) + rate * d)
    return out
