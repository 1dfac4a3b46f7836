"""How a leg reaches its foot's goal (:mod:`stitchjax.sample.footlock`): leg chains, two-bone IK, speed limits and
the guard against joint jumps and knee snaps.

A leg is hip -> knee -> ankle -> toe. :func:`two_bone_ik` turns the hip and the knee so the ankle reaches a goal;
bones keep their lengths exactly (only rotations change), the knee stays in the plane of the generated pose (pole
vector, biased over the toes) and the reach is softened near full extension (:func:`soft_reach`), so a leg is
straightened, never stretched, and never snaps straight. :func:`limit_correction_speed` and
:func:`limit_knee_speed` keep the goal no faster than the generated leg before the IK; :func:`guard_legs` checks
the solved legs and cuts the correction back wherever a joint still jumps or a knee still snaps.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from stitchjax import rotations as R
from stitchjax.skeleton import Skeleton

__all__ = ["FOOT_NAMES", "leg_chains", "same_hemisphere", "soft_reach", "two_bone_ik", "leg_rotations", "knee_angle",
           "limit_correction_speed", "limit_knee_speed", "guard_bounds", "guard_legs", "tent_max", "slope_limited"]

FOOT_NAMES = ("LeftFoot", "LeftToe", "RightFoot", "RightToe")
SOFT_REACH = 0.97  # fraction of the leg's length from which the reach is softened: a leg is never snapped straight
POLE_HINT = 0.3  # the ankle-to-toe vector times this biases the knee's pole, so a straight leg bends over the toes
JUMP_FLOOR = 10.0  # cm: the guard lets a leg joint step this far in a frame even where the whole transition is slower
KNEE_FLOOR = 10.0  # degrees: ... and a knee turn this much in a frame even where the generated knees turn less
GUARD_ROUNDS = 8  # rounds of halving the correction where a step is too long (1/256 of it is left after all 8)
GUARD_SPREAD = 3  # frames either side over which a cut tapers, so it leaves no dip


def leg_chains(skeleton: Skeleton, feet=None) -> tuple:
    """((hip, knee, ankle, toe, ankle channel, toe channel), ...) per leg, from the contact joints ``feet``
    (ankle, toe, ankle, toe, ... in contact-channel order; default: LAFAN1's names looked up in the skeleton).
    The knee is the ankle's parent and the hip the knee's parent."""
    if feet is None:
        try:
            feet = tuple(skeleton.index(n) for n in FOOT_NAMES)
        except KeyError:
            raise ValueError(f"foot lock: the skeleton has no joints named {', '.join(FOOT_NAMES)}; pass feet= "
                             f"(ankle, toe, ankle, toe joint indices in contact-channel order)") from None
    feet = tuple(int(f) for f in feet)
    if len(feet) % 2:
        raise ValueError(f"foot lock: feet must come in (ankle, toe) pairs, got {feet}")
    parents = skeleton.parents
    legs = []
    for k in range(0, len(feet), 2):
        ankle, toe = feet[k], feet[k + 1]
        if parents[toe] != ankle or parents[ankle] < 1 or parents[parents[ankle]] < 1:
            raise ValueError(f"foot lock: joints {ankle}, {toe} are not an ankle and its toe below a knee and a hip")
        knee = parents[ankle]
        legs.append((parents[knee], knee, ankle, toe, k, k + 1))
    return tuple(legs)


def same_hemisphere(q, reference):
    """q with the sign that puts it in the hemisphere of ``reference``; (..., 4) each."""
    return jnp.where(jnp.sum(q * reference, axis=-1, keepdims=True) < 0, -q, q)


def soft_reach(distance, length, soft: float = SOFT_REACH):
    """Reach distance (...) eased below the leg's full ``length``: unchanged up to soft x length, then
    approaching length exponentially (smooth, always < length)."""
    knee = soft * length
    span = (1.0 - soft) * length
    eased = knee + span * (1.0 - jnp.exp(-(distance - knee) / span))
    return jnp.where(distance > knee, eased, distance)


def two_bone_ik(hip, knee, ankle, target, upper, lower, hint=None):
    """Two-bone IK: the hip and knee turns that bring the ankle to ``target`` (softened near full reach).

    hip, knee, ankle: (..., 3) the joints' positions now; target: (..., 3); upper, lower: (...) the thigh and shin
    lengths. The knee stays in the plane through the hip, the target and the current knee (pole vector: the
    current knee), so it bends the way it bends now and never flips. hint: (..., 3) or None: a direction added to
    the pole, so the knee bends a known way where the leg is nearly straight and the current knee says little.
    Returns (hip turn (..., 4), knee turn (..., 4), new knee (..., 3), new ankle (..., 3)): global rotations applied
    before the joints' own (new global rotation of the hip = hip turn * old; of the knee = knee turn * hip turn *
    old)."""
    length = upper + lower
    to_target = target - hip
    distance = jnp.sqrt(jnp.sum(to_target**2, axis=-1) + 1e-12)
    direction = to_target / distance[..., None]
    reach = jnp.maximum(soft_reach(distance, length), jnp.abs(upper - lower) + 1e-4 * length)
    along = (upper**2 - lower**2 + reach**2) / (2.0 * reach)
    across = jnp.sqrt(jnp.maximum(upper**2 - along**2, 0.0))
    bend = knee - hip
    pole = bend if hint is None else bend + hint
    pole = pole - jnp.sum(pole * direction, axis=-1, keepdims=True) * direction
    pole = pole / jnp.sqrt(jnp.sum(pole**2, axis=-1, keepdims=True) + (1e-6 * length[..., None]) ** 2)
    new_knee = hip + along[..., None] * direction + across[..., None] * pole
    new_ankle = hip + reach[..., None] * direction
    hip_turn = R.quat_between(bend, new_knee - hip)
    shin_now = R.quat_rotate(hip_turn, ankle - knee)
    knee_turn = R.quat_between(shin_now, new_ankle - new_knee)
    return hip_turn, knee_turn, new_knee, new_ankle


def leg_rotations(rotations, global_rotations, global_positions, leg: tuple, parents: tuple, goal, turn, upper,
                  lower) -> dict:
    """{hip, knee, ankle: (T, 4) new local rotation} that move one leg's ankle to ``goal`` and turn its foot.

    rotations: (T, J, 4) local rotations; global_rotations, global_positions: (T, J, 4), (T, J, 3) their forward
    kinematics; leg: (hip, knee, ankle, toe, ...) of :func:`leg_chains`; goal: (T, 3) the ankle's new position;
    turn: (T, 4) the foot's correcting global rotation; upper, lower: the thigh and shin lengths. Each new
    rotation is put in the hemisphere of the joint's old one."""
    hip, knee, ankle, toe = leg[:4]
    g_rot, g_pos = global_rotations, global_positions
    hint = POLE_HINT * (g_pos[:, toe] - g_pos[:, ankle])
    hip_turn, knee_turn, _, _ = two_bone_ik(g_pos[:, hip], g_pos[:, knee], g_pos[:, ankle], goal, upper, lower, hint)
    hip_global = R.quat_mul(hip_turn, g_rot[:, hip])
    knee_global = R.quat_mul(knee_turn, R.quat_mul(hip_turn, g_rot[:, knee]))
    foot_global = R.quat_mul(turn, g_rot[:, ankle])
    parent_of_hip = g_rot[:, parents[hip]]
    local = {hip: R.quat_mul(R.quat_conjugate(parent_of_hip), hip_global),
             knee: R.quat_mul(R.quat_conjugate(hip_global), knee_global),
             ankle: R.quat_mul(R.quat_conjugate(knee_global), foot_global)}
    return {joint: same_hemisphere(R.quat_normalize(q), rotations[:, joint]) for joint, q in local.items()}


# ------------------------------------------------------------------------------------------ speed limits


def _norm(x):
    """(...) Euclidean norm over the last axis (smooth at 0)."""
    return jnp.sqrt(jnp.sum(x**2, axis=-1) + 1e-12)


def knee_angle(reach, upper, lower):
    """(...) the knee's inner angle (radians, pi: straight) of a leg whose ankle is ``reach`` from its hip."""
    return jnp.arccos(jnp.clip((upper**2 + lower**2 - reach**2) / (2.0 * upper * lower), -1.0, 1.0))


def _gap_scale(need, allowed, anchor):
    """(T - 1,) factor >= 1 on the allowed steps (T - 1,) between two anchors (T,) bool, so that their sum over
    each gap is at least |the sum of ``need``| (T - 1,) there: the limit gives way where a gap is too short for
    it, instead of breaking at the anchor."""
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


def limit_correction_speed(offset, ankle, anchor, floor: float, ceiling=jnp.inf):
    """(T, 3) ``offset`` (the ankle's correction) with its change per frame limited to the generated ankle's
    spare speed: at most max(V - |ankle_t - ankle_t-1|, floor) cm from frame t-1 to t, V the largest such step of
    ``ankle`` (T, 3) over the transition, so the corrected ankle is no faster than the generated foot's own top
    speed where it moves fast, and its step at most ``ceiling`` (the guard's bound). anchor: (T,) bool frames
    whose offset is kept exactly (plants, keyframes); the limit gives way where a gap between them is too short."""
    step = _norm(jnp.diff(ankle, axis=0))
    allowed = jnp.minimum(jnp.maximum(jnp.max(step) - step, floor), jnp.maximum(ceiling - step, 0.0))
    allowed = allowed * _gap_scale(_norm(jnp.diff(offset, axis=0)), allowed, anchor)
    return _limit_steps(offset, allowed, anchor)


def limit_knee_speed(hip, goal, ankle, upper, lower, anchor, step_degrees: float, ceiling_degrees=jnp.inf):
    """(T, 3) ankle goals ``goal`` moved along the hip's line so that the knee angle :func:`two_bone_ik` solves
    changes per frame by at most the generated knee's change plus ``step_degrees``, and by at most
    ``ceiling_degrees`` (the guard's bound).

    hip, goal, ankle: (T, 3) the hip, the ankle's goal and the generated ankle; upper, lower: the thigh and shin
    lengths; anchor: (T,) bool frames whose goal is kept (plants, keyframes). The limit gives way where a gap
    between anchors is too short for it; frames it leaves alone keep their goal exactly."""
    length = upper + lower
    to_goal = goal - hip
    distance = _norm(to_goal)
    shortest = jnp.abs(upper - lower) + 1e-4 * length
    angle = knee_angle(jnp.maximum(soft_reach(distance, length), shortest), upper, lower)
    generated = knee_angle(_norm(ankle - hip), upper, lower)
    allowed = jnp.minimum(jnp.abs(jnp.diff(generated)) + jnp.radians(step_degrees), jnp.radians(ceiling_degrees))
    allowed = allowed * _gap_scale(jnp.diff(angle), allowed, anchor)
    limited = _limit_steps(angle, allowed, anchor)
    reach = jnp.sqrt(jnp.maximum(upper**2 + lower**2 - 2.0 * upper * lower * jnp.cos(limited), 0.0))
    knee, span = SOFT_REACH * length, (1.0 - SOFT_REACH) * length  # soft_reach inverted
    unsoftened = knee - span * jnp.log(jnp.maximum(1.0 - (reach - knee) / span, 1e-6))
    reach = jnp.where(reach > knee, unsoftened, reach)
    moved = hip + (reach / distance)[:, None] * to_goal
    return jnp.where((jnp.abs(limited - angle) > 1e-6)[:, None], moved, goal)


# ------------------------------------------------------------------------------------------ the guard


def _knee_degrees(hip, knee, ankle):
    """(...) the knee's inner angle in degrees from the three joints' positions (..., 3)."""
    thigh, shin = hip - knee, ankle - knee
    cos = jnp.sum(thigh * shin, axis=-1) / (_norm(thigh) * _norm(shin))
    return jnp.degrees(jnp.arccos(jnp.clip(cos, -1.0, 1.0)))


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


def guard_bounds(global_positions, legs: tuple):
    """(the longest step a leg joint may take in a frame (cm), the largest knee turn per frame (degrees)) of a
    generated transition's global positions (T, J, 3): its own longest joint step and fastest knee turn, or
    :data:`JUMP_FLOOR` and :data:`KNEE_FLOOR` where those are more."""
    knees = jnp.stack([_knee_degrees(*(global_positions[:, j] for j in leg[:3])) for leg in legs], -1)
    return (jnp.maximum(jnp.linalg.norm(jnp.diff(global_positions, axis=0), axis=-1).max(), JUMP_FLOOR),
            jnp.maximum(jnp.abs(jnp.diff(knees, axis=0)).max(), KNEE_FLOOR))


def guard_legs(locked, generated, generated_global, offsets, legs: tuple, parents: tuple):
    """(T, J, 4) ``locked`` local rotations with no leg joint stepping farther in one frame than any joint of the
    ``generated`` transition does (or :data:`JUMP_FLOOR` cm), and no knee turning faster than the generated
    transition's fastest knee (or :data:`KNEE_FLOOR` degrees per frame), so the pass never makes a transition's
    fastest motion faster.

    generated: (T, J, 4) the transition before the pass, generated_global: its global (rotations (T, J, 4),
    positions (T, J, 3)); offsets: (J, 3) bone offsets; legs: :func:`leg_chains` (only their hip, knee and ankle
    rotations may differ between ``locked`` and ``generated``); parents: the skeleton's. Each of
    :data:`GUARD_ROUNDS` rounds halves a leg's correction (the weight of ``locked`` in a normalised blend with
    ``generated`` of its hip, knee and ankle rotations) on both frames of every step still too fast, tapered over
    :data:`GUARD_SPREAD` frames each side, and the weight changes by at most 1 / (2 GUARD_SPREAD + 2) per frame,
    so the cuts leave no steep edge. Both frames of a step still too fast after the rounds are returned as
    generated, and a leg still too fast somewhere after that is returned as generated throughout.
    Frames where no weight was cut, and joints ``locked`` leaves as generated, are ``locked`` exactly."""
    global_rotations, global_positions = generated_global
    jump_bound, knee_bound = guard_bounds(global_positions, legs)
    joints = [jnp.asarray(leg[:3]) for leg in legs]

    def blended(weight):  # [(T, 3, 4) each leg's hip, knee and ankle rotations]; weight (T, legs): the share kept
        out = []
        for k, j in enumerate(joints):
            a, b = generated[:, j], same_hemisphere(locked[:, j], generated[:, j])
            mixed = (1.0 - weight[:, k, None, None]) * a + weight[:, k, None, None] * b
            out.append(mixed / jnp.linalg.norm(mixed, axis=-1, keepdims=True))
        return out

    def too_fast(weight):  # (T-1, legs): a step of the leg's knee, ankle or toe, or of its knee angle, too fast
        out = []
        for leg, rotations in zip(legs, blended(weight)):
            hip = global_positions[:, leg[0]]
            chain = _leg_joints(rotations, global_rotations[:, parents[leg[0]]], hip, offsets, leg)
            jump = jnp.linalg.norm(jnp.diff(chain, axis=0), axis=-1).max(-1)
            turn = jnp.abs(jnp.diff(_knee_degrees(hip, chain[:, 0], chain[:, 1])))
            out.append((jump > jump_bound + 1e-3) | (turn > knee_bound + 1e-3))
        return jnp.stack(out, -1)

    def step(weight, _):
        cut_at = too_fast(weight)
        none = jnp.zeros_like(cut_at[:1])
        frames = (jnp.concatenate([none, cut_at]) | jnp.concatenate([cut_at, none])).astype(weight.dtype)
        cut = weight * (1.0 - 0.5 * tent_max(frames, GUARD_SPREAD))
        return slope_limited(cut, 0.5 / (GUARD_SPREAD + 1.0), 2 * GUARD_SPREAD + 2), None

    weight = jax.lax.scan(step, jnp.ones((locked.shape[0], len(legs)), locked.dtype), None, length=GUARD_ROUNDS)[0]
    late = too_fast(weight)  # after the rounds, a step still too fast: both its frames as generated
    none = jnp.zeros_like(late[:1])
    weight = jnp.where(jnp.concatenate([none, late]) | jnp.concatenate([late, none]), 0.0, weight)
    weight = jnp.where(jnp.any(too_fast(weight), axis=0), 0.0, weight)  # and if that is not enough, the whole leg
    guarded = locked
    for k, (j, rotations) in enumerate(zip(joints, blended(weight))):
        rotations = jnp.where(weight[:, k, None, None] > 0, rotations, generated[:, j])
        same = (weight[:, k, None, None] >= 1.0) | jnp.all(locked[:, j] == generated[:, j], axis=-1, keepdims=True)
        guarded = guarded.at[:, j].set(jnp.where(same, locked[:, j], rotations))
    return guarded


def tent_max(x, frames: int):
    """(T, ...) the largest of ``x`` (T, ...) within ``frames`` frames along the first axis, each neighbour
    weighted by 1 - d / (frames + 1) at distance d: a peak spread as a tent, so what follows it never jumps."""
    n = x.shape[0]
    out = x
    for d in range(1, frames + 1):
        padded = jnp.pad(x, [(d, d)] + [(0, 0)] * (x.ndim - 1))
        out = jnp.maximum(out, (1.0 - d / (frames + 1.0)) * jnp.maximum(padded[:n], padded[2 * d:]))
    return out


def slope_limited(weight, rate: float, frames: int):
    """(T, ...) the largest sequence at most ``weight`` (T, ...) whose value changes by at most ``rate`` per frame
    along the first axis: min over d <= ``frames`` of weight(t +- d) + rate d (``frames`` >= 1 / rate makes the
    limit exact for weights in [0, 1])."""
    n = weight.shape[0]
    out = weight
    for d in range(1, frames + 1):
        padded = jnp.pad(weight, [(d, d)] + [(0, 0)] * (weight.ndim - 1), constant_values=jnp.inf)
        out = jnp.minimum(out, jnp.minimum(padded[:n], padded[2 * d:]) + rate * d)
    return out
