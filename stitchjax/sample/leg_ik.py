"""The legs of foot locking (:mod:`stitchjax.sample.footlock`): which joints make a leg, and two-bone IK.

A leg is hip -> knee -> ankle -> toe. :func:`two_bone_ik` turns the hip and the knee so the ankle reaches a
target; bones keep their lengths exactly (only rotations change), the knee stays in the plane of the current
pose (pole vector, optionally biased by a hint) and the reach is softened near full extension
(:func:`soft_reach`), so a leg is straightened, never stretched, and never snaps straight.
:func:`leg_rotations` turns the result, with the foot's own turn, into the three joints' local rotations.
"""
from __future__ import annotations

import jax.numpy as jnp

from stitchjax import rotations as R
from stitchjax.skeleton import Skeleton

__all__ = ["FOOT_NAMES", "SOFT_REACH", "leg_chains", "same_hemisphere", "soft_reach", "two_bone_ik", "leg_rotations"]

FOOT_NAMES = ("LeftFoot", "LeftToe", "RightFoot", "RightToe")
SOFT_REACH = 0.97  # fraction of the leg's length from which the reach is softened (FootLockConfig's default)


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


def soft_reach(distance, length, soft: float):
    """Reach distance (...) eased below the leg's full ``length``: unchanged up to soft x length, then
    approaching length exponentially (smooth, always < length)."""
    knee = soft * length
    span = (1.0 - soft) * length
    eased = knee + span * (1.0 - jnp.exp(-(distance - knee) / span))
    return jnp.where(distance > knee, eased, distance)


def two_bone_ik(hip, knee, ankle, target, upper, lower, soft: float = SOFT_REACH, hint=None):
    """Two-bone IK: the hip and knee turns that bring the ankle to ``target`` (softened near full reach).

    hip, knee, ankle: (..., 3) the joints' positions now; target: (..., 3); upper, lower: (...) the thigh
    and shin lengths. The knee stays in the plane through the hip, the target and the current knee (pole
    vector: the current knee), so it bends the way it bends now and never flips.
    hint: (..., 3) or None: a direction added to the pole (e.g. the foot's forward direction, scaled), so the
    knee bends a known way where the leg is nearly straight and the current knee says little.
    Returns (hip turn (..., 4), knee turn (..., 4), new knee (..., 3), new ankle (..., 3), reach ratio (...)):
    the turns are global rotations applied before the joints' own (new global rotation of the hip =
    hip turn * old; of the knee = knee turn * hip turn * old); the ratio is |target - hip| / (upper + lower).
    """
    length = upper + lower
    to_target = target - hip
    distance = jnp.sqrt(jnp.sum(to_target**2, axis=-1) + 1e-12)
    direction = to_target / distance[..., None]
    reach = soft_reach(distance, length, soft)
    reach = jnp.maximum(reach, jnp.abs(upper - lower) + 1e-4 * length)
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
    return hip_turn, knee_turn, new_knee, new_ankle, distance / length


def leg_rotations(rotations, global_rotations, global_positions, leg: tuple, parents: tuple, goal, turn, upper,
                  lower, soft: float = SOFT_REACH, pole_hint: float = 0.0) -> dict:
    """{hip, knee, ankle: (T, 4) new local rotation} that move one leg's ankle to ``goal`` and turn its foot.

    rotations: (T, J, 4) local rotations; global_rotations, global_positions: (T, J, 4), (T, J, 3) their
    forward kinematics; leg: (hip, knee, ankle, toe, ...) of :func:`leg_chains`; goal: (T, 3) the ankle's
    new position; turn: (T, 4) the foot's correcting global rotation; upper, lower: the thigh and shin lengths.
    The knee's pole is biased by ``pole_hint`` x the ankle-to-toe vector (0: off). Each new rotation is put
    in the hemisphere of the joint's old one."""
    hip, knee, ankle, toe = leg[:4]
    g_rot, g_pos = global_rotations, global_positions
    hip_turn, knee_turn, _, _, _ = two_bone_ik(g_pos[:, hip], g_pos[:, knee], g_pos[:, ankle],
                                               goal, upper, lower, soft,
                                               pole_hint * (g_pos[:, toe] - g_pos[:, ankle])
                                               if pole_hint > 0 else None)
    hip_global = R.quat_mul(hip_turn, g_rot[:, hip])
    knee_global = R.quat_mul(knee_turn, R.quat_mul(hip_turn, g_rot[:, knee]))
    foot_global = R.quat_mul(turn, g_rot[:, ankle])
    parent_of_hip = g_rot[:, parents[hip]]
    local = {hip: R.quat_mul(R.quat_conjugate(parent_of_hip), hip_global),
             knee: R.quat_mul(R.quat_conjugate(hip_global), knee_global),
             ankle: R.quat_mul(R.quat_conjugate(knee_global), foot_global)}
    return {joint: same_hemisphere(R.quat_normalize(q), rotations[:, joint]) for joint, q in local.items()}
