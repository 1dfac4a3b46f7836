"""Foot locking: feet that stand stay where they stand, on the keyframes' ground; the legs are solved by two-bone IK.

A post-process over generated transitions (start keyframe, L generated frames, target keyframe), leg by leg:

1. **Stance.** A foot stands where the model predicts contact and the generated foot is low (within ``height`` of
   the keyframes' ground) and slow (under ``speed`` per frame). Runs of such frames, flickers bridged and short runs
   dropped, are its stance spans. Samples of one keyframe pair whose feet stay close share their spans, so the
   pass adds no spread between samples that hardly differ.
2. **Plants** (:mod:`~stitchjax.sample.footlock.plants`). A span holds the foot (ankle position and foot
   orientation) at one place standing on the ground: the generated foot's mean place over the plant, moved so its
   lower joint (ankle or toe) is at that joint's ground, or the keyframe's own foot where the span touches a
   keyframe. Where the generated foot drifts ``replant_distance`` from where the plant began, or the plant leaves
   the leg's reach, the foot takes a step of ``step_frames`` frames to a new plant.
3. **Easing.** Over ``blend_frames`` frames after a plant (and before the next) the foot is eased between the plant
   and the generated foot, on a small arc, so it leaves a plant and lands on one at rest.
4. **Ground.** Elsewhere a foot below the ground is lifted onto it, and outside the stance spans a foot that moves
   within ``clearance`` of the ground is lifted to that height: it steps instead of skating.
5. **Legs** (:mod:`~stitchjax.sample.footlock.legs`). Hip, knee and ankle turn so the ankle reaches its goal;
   bones keep their lengths, the knee bends in the generated leg's plane, and a leg is straightened, never
   stretched. The correction changes no faster than the generated foot's spare speed, and the knee angle no faster
   than the generated knee's plus a few degrees per frame. A guard then cuts the correction wherever a leg joint
   still steps farther in a frame than any joint of the generated transition, or a knee turns faster than its
   fastest knee; a leg it cannot bring within both is left as generated.

The ground is each foot joint's lowest height at the two keyframes (ankles and toes apart). Frames no step touches, both keyframes among them, are returned bit for bit; the root, the
upper body and every joint's offset are unchanged. Lengths in the data's units (LAFAN1: cm), speeds per frame.

    out = lock_feet(rotations, root_positions, contacts, skeleton, sample_axis=1)   # (B, S, T, ...); jit-able
    out["rotations"], out["planted"], out["changed"], out["lifted"]
"""
from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np

from stitchjax import rotations as R
from stitchjax.sample.footlock.legs import (guard_bounds, guard_legs, leg_chains, leg_rotations,
                                            limit_correction_speed, limit_knee_speed)
from stitchjax.sample.footlock.plants import (bridge_gaps, clearance_lift, drop_short_spans, eased_plants, hysteresis,
                                              plant_runs, plant_targets, release_room, shared_scores)
from stitchjax.skeleton import Skeleton, forward_kinematics

__all__ = ["FootLockConfig", "DEFAULT_CONFIG", "stance_score", "lock_feet", "lock_transitions"]

CONTACT_FULL = 0.1  # a predicted contact at or above this counts fully: the model's contacts are low even in stance
ENTER, LEAVE = 0.5, 0.1  # a span starts where the stance score rises above ENTER and ends where it falls below LEAVE
BRIDGE_FRAMES = 2  # gaps of up to this many frames between two spans are filled: a flicker ends no span
MIN_FRAMES = 3  # spans and plants shorter than this are dropped: too short to be seen standing
RELEASE_SPEED = 0.5  # cm/frame: a plant frame is held only if its correction can fade by the next keyframe this slowly
LIFT_POWER = 3.0  # the vertical correction eases with the plant's weight to this power: a foot lifts off first
STEP_LIFT = 0.2  # a foot eased to or from a plant rises on an arc of this fraction of the distance ...
MAX_STEP_HEIGHT = 3.0  # ... by at most this many cm: a step, not a hop
CORRECTION_STEP = 6.0  # cm/frame: the correction may always change this fast, however fast the generated foot moves
KNEE_STEP = 6.0  # degrees/frame: the solved knee may turn this much faster than the generated knee
SHARE_DISTANCE = 5.0  # cm: samples whose ankles stay this close (root mean square) share their stance spans


@dataclasses.dataclass(frozen=True)
class FootLockConfig:
    """The settings of foot locking a user may tune (hashable: a static argument of jit). Lengths in the data's
    units (cm), speeds in cm per frame.

    height: a foot within this height of the ground can stand (the stance score falls from 1 on the ground to 0
      here).
    speed: a foot slower than this can stand (the score falls from 1 at rest to 0 at this horizontal speed).
    replant_distance: a plant ends where the generated foot has drifted this far (horizontally) from where it
      began: the foot steps to a new plant instead of being held far from the generated foot.
    step_frames: frames of the step between two plants of one span (>= 1).
    blend_frames: frames over which the foot is eased from a plant to the generated foot (and back).
    clearance: a foot that moves within this height of the ground outside its plants is lifted to it (0: feet are
      only kept out of the ground).
    up_axis: the vertical axis of the positions.
    """

    height: float = 6.0
    speed: float = 6.0
    replant_distance: float = 15.0
    step_frames: int = 4
    blend_frames: int = 8
    clearance: float = 10.0
    up_axis: int = 1

    def __post_init__(self):
        if not (self.height > 0 and self.speed > 0 and self.replant_distance > 0):
            raise ValueError(f"foot lock: height ({self.height}), speed ({self.speed}) and replant_distance "
                             f"({self.replant_distance}) must be > 0")
        if self.step_frames < 1 or self.blend_frames < 0 or not self.clearance >= 0:
            raise ValueError(f"foot lock: step_frames ({self.step_frames}) must be >= 1, blend_frames "
                             f"({self.blend_frames}) and clearance ({self.clearance}) >= 0")
        if self.up_axis not in (0, 1, 2):
            raise ValueError(f"foot lock: up_axis must be 0, 1 or 2, got {self.up_axis}")


DEFAULT_CONFIG = FootLockConfig()


def stance_score(contact, height, speed, stance_height, stance_speed):
    """How much a foot looks planted, in [0, 1]; (T,) each.

    contact: the predicted contact probability; height: the foot above the ground (cm); speed: its horizontal speed
    (cm/frame). min(contact / CONTACT_FULL, 1) x (1 - height / stance_height)+ x (1 - speed / stance_speed)+ (the
    settings ``height`` and ``speed``): 0 wherever the model predicts no contact."""
    c = jnp.clip(contact / CONTACT_FULL, 0.0, 1.0)
    h = jnp.clip(1.0 - height / stance_height, 0.0, 1.0)
    v = jnp.clip(1.0 - speed / stance_speed, 0.0, 1.0)
    return c * h * v


def _horizontal_speed(x, up_axis: int):
    """(T, ...) speed per frame (cm/frame) of positions (T, ..., 3) in the horizontal plane (central differences,
    one-sided at the ends)."""
    flat = x.at[..., up_axis].set(0.0)
    padded = jnp.concatenate([2 * flat[:1] - flat[1:2], flat, 2 * flat[-1:] - flat[-2:-1]], axis=0)
    return jnp.sqrt(jnp.sum((padded[2:] - padded[:-2]) ** 2, axis=-1) + 1e-12) * 0.5


def _posed(rotations, root_positions, offsets, legs: tuple, parents: tuple, up: int):
    """FK of one transition: (global rotations (T, J, 4), positions (T, J, 3), grounds: (ankle ground, toe ground))."""
    local_positions = jnp.broadcast_to(offsets, rotations.shape[:-1] + (3,)).at[:, 0].set(root_positions)
    g_rot, g_pos = forward_kinematics(rotations, local_positions, parents)
    keyframes = jnp.stack([g_pos[0, :, up], g_pos[-1, :, up]])
    grounds = tuple(keyframes[:, jnp.asarray([leg[part] for leg in legs])].min() for part in (2, 3))  # ankles, toes
    return g_rot, g_pos, grounds


def _leg_score(g_pos, contacts, leg: tuple, grounds: tuple, settings: dict, up: int):
    """(T,) one leg's stance score: the larger predicted contact of its ankle and toe, its lower joint's height
    above that joint's ground, and the mean horizontal speed of the two."""
    _, _, ankle, toe, c_ankle, c_toe = leg
    height = jnp.minimum(g_pos[:, ankle, up] - grounds[0], g_pos[:, toe, up] - grounds[1])
    speed = 0.5 * (_horizontal_speed(g_pos[:, ankle], up) + _horizontal_speed(g_pos[:, toe], up))
    return stance_score(jnp.maximum(contacts[:, c_ankle], contacts[:, c_toe]), height, speed, settings["height"],
                        settings["speed"])


def _lock_leg(rotations, posed: tuple, offsets, leg: tuple, parents: tuple, score, settings: dict, up: int):
    """One leg of :func:`_lock_one`: ({hip, knee, ankle: (T, 4) new local rotation}, active (T,) bool: the frames
    whose leg moves, {"planted", "changed", "lifted": (T,) bool}). score: (T,) the leg's stance score."""
    g_rot, g_pos, grounds = posed
    hip, knee, ankle, toe = leg[:4]
    num_frames = rotations.shape[0]
    keyframe = jnp.zeros(num_frames, bool).at[0].set(True).at[-1].set(True)
    spans = drop_short_spans(bridge_gaps(hysteresis(score, ENTER, LEAVE), BRIDGE_FRAMES), MIN_FRAMES)
    upper, lower = jnp.linalg.norm(offsets[knee]), jnp.linalg.norm(offsets[ankle])
    plants = drop_short_spans(plant_runs(spans, g_pos[:, ankle], g_pos[:, hip], upper + lower,
                                         settings["replant_distance"], settings["step_frames"], up), MIN_FRAMES)
    target, target_rotation = plant_targets(plants, g_pos[:, ankle], g_rot[:, ankle], offsets[toe], grounds, up)
    kept = plants & (jnp.linalg.norm(target - g_pos[:, ankle], axis=-1) <= RELEASE_SPEED * release_room(plants))
    anchor = kept | keyframe
    offset, turn, arc = eased_plants(anchor, keyframe & ~kept, target, target_rotation, g_pos[:, ankle],
                                     g_rot[:, ankle], settings["blend_frames"], LIFT_POWER, up)
    offset = offset.at[:, up].add(jnp.minimum(STEP_LIFT * arc, MAX_STEP_HEIGHT))
    new_ankle = g_pos[:, ankle] + offset
    new_toe = new_ankle + R.quat_rotate(turn, g_pos[:, toe] - g_pos[:, ankle])
    height = jnp.minimum(new_ankle[:, up] - grounds[0], new_toe[:, up] - grounds[1])
    moving = jnp.maximum(_horizontal_speed(new_ankle, up), _horizontal_speed(new_toe, up))
    lift = clearance_lift(height, moving, anchor, keyframe, settings["clearance"], spans)
    jump_bound, knee_bound = guard_bounds(g_pos, (leg,))  # what the guard will allow, so it rarely cuts
    offset = limit_correction_speed(offset.at[:, up].add(lift), g_pos[:, ankle], anchor, CORRECTION_STEP, jump_bound)
    goal = limit_knee_speed(g_pos[:, hip], g_pos[:, ankle] + offset, g_pos[:, ankle], upper, lower, anchor, KNEE_STEP,
                            knee_bound)
    active = ~keyframe & (jnp.any(goal != g_pos[:, ankle], axis=-1) | (turn[:, 0] < 1.0))
    local = leg_rotations(rotations, g_rot, g_pos, leg, parents, goal, turn, upper, lower)
    stats = {"planted": kept & ~keyframe, "changed": active, "lifted": active & (lift > 0.01)}
    return local, active, stats


def _scores_one(rotations, root_positions, contacts, offsets, settings: dict, legs: tuple, parents: tuple, up: int):
    """Stance scores of one transition: (score (T, legs), ankle positions (T, legs, 3))."""
    _, g_pos, grounds = _posed(rotations, root_positions, offsets, legs, parents, up)
    return (jnp.stack([_leg_score(g_pos, contacts, leg, grounds, settings, up) for leg in legs], -1),
            jnp.stack([g_pos[:, leg[2]] for leg in legs], -2))


def _lock_one(rotations, root_positions, contacts, offsets, settings: dict, score, legs: tuple, parents: tuple,
              up: int):
    """The pass on one transition: rotations (T, J, 4), root (T, 3), contacts (T, C), offsets (J, 3), the legs'
    stance scores (T, legs)."""
    posed = _posed(rotations, root_positions, offsets, legs, parents, up)
    new_rotations = rotations
    stats = {key: [] for key in ("planted", "changed", "lifted")}
    for k, leg in enumerate(legs):
        local, active, leg_stats = _lock_leg(rotations, posed, offsets, leg, parents, score[:, k], settings, up)
        for joint, q in local.items():
            new_rotations = new_rotations.at[:, joint].set(jnp.where(active[:, None], q, rotations[:, joint]))
        for key, value in leg_stats.items():
            stats[key].append(value)
    new_rotations = guard_legs(new_rotations, rotations, posed[:2], offsets, legs, parents)
    changed = jnp.stack([jnp.any(new_rotations[:, jnp.asarray(leg[:3])] != rotations[:, jnp.asarray(leg[:3])],
                                 axis=(-2, -1)) for leg in legs], -1)
    stats = {key: jnp.stack(values, -1) & changed for key, values in stats.items()}
    return {"rotations": new_rotations, "root_positions": root_positions, **stats}


def lock_feet(rotations, root_positions, contacts, skeleton: Skeleton, offsets=None, feet=None,
              config: FootLockConfig = DEFAULT_CONFIG, sample_axis: int | None = None) -> dict:
    """Foot locking over a batch of transitions (jit-compiled once per shape and skeleton: the settings are
    traced, so other settings compile nothing new; callable inside jit and vmap).

    rotations: (..., T, J, 4) local rotations of transitions whose first and last frames are the keyframes;
    root_positions: (..., T, 3); contacts: (..., T, C) predicted contact probabilities, one channel per joint of
    ``feet`` (the keyframes' rows: their contact labels); skeleton: its parents; offsets: (..., J, 3) bone offsets
    (default: the skeleton's); feet: the contact joints (ankle, toe, ...) in channel order (default: LAFAN1's
    names); config: :class:`FootLockConfig`; sample_axis: the batch axis of rotations that holds the samples of
    one keyframe pair (e.g. 1 for (B, S, T, J, 4)): samples whose feet stay within :data:`SHARE_DISTANCE` share
    their stance spans; None: each transition decides its own.
    Returns {"rotations" (..., T, J, 4), "root_positions" (..., T, 3) (unchanged), "planted" (..., T, legs) frames
    held at a plant, "changed" (..., T, legs) frames whose leg moved, "lifted" (..., T, legs) frames whose foot was
    lifted (onto the ground or clear of it) by more than 0.01 cm}. Unchanged frames, keyframes among them, are the
    inputs exactly.
    """
    legs = leg_chains(skeleton, feet)
    if offsets is None:
        offsets = skeleton.offsets
    offsets = jnp.broadcast_to(jnp.asarray(offsets, rotations.dtype), rotations.shape[:-3] + (skeleton.num_joints, 3))
    settings = {field.name: jnp.asarray(getattr(config, field.name), jnp.int32 if field.type == "int" else
                                        rotations.dtype)
                for field in dataclasses.fields(config) if field.name != "up_axis"}
    return _lock_feet(rotations, root_positions, jnp.asarray(contacts, rotations.dtype), offsets, settings,
                      legs=legs, parents=tuple(skeleton.parents), up=config.up_axis, sample_axis=sample_axis)


@functools.partial(jax.jit, static_argnames=("legs", "parents", "up", "sample_axis"))
def _lock_feet(rotations, root_positions, contacts, offsets, settings: dict, legs: tuple, parents: tuple, up: int,
               sample_axis: int | None):
    """:func:`lock_feet` past its argument handling: settings {field: traced scalar} of the config."""
    batch = rotations.shape[:-3]
    flat = lambda x, k: x.reshape((-1,) + x.shape[x.ndim - k:])  # noqa: E731
    unflat = lambda x: x.reshape(batch + x.shape[1:])  # noqa: E731
    inputs = (flat(rotations, 3), flat(root_positions, 2), flat(contacts, 2), flat(offsets, 2))
    statics = {"legs": legs, "parents": parents, "up": up}
    score, ankles = jax.vmap(functools.partial(_scores_one, settings=settings, **statics))(*inputs)
    if sample_axis is not None:
        axis = sample_axis % len(batch)
        score, ankles = (jnp.moveaxis(unflat(x), axis, 0) for x in (score, ankles))
        share = jax.vmap(shared_scores, in_axes=(-1, -2, None), out_axes=-1)  # over legs
        for _ in range(len(batch) - 1):  # over the other batch axes
            share = jax.vmap(share, in_axes=(1, 1, None), out_axes=1)
        score = flat(jnp.moveaxis(share(score, ankles, SHARE_DISTANCE), 0, axis), 2)
    lock = functools.partial(_lock_one, settings=settings, **statics)
    out = jax.vmap(lambda r, p, c, o, s: lock(r, p, c, o, score=s))(*inputs, score)
    return jax.tree.map(unflat, out)


def lock_transitions(rotations, positions, contacts, skeleton: Skeleton, feet=None,
                     config: FootLockConfig = DEFAULT_CONFIG, sample_axis: int | None = None):
    """:func:`lock_feet` on float64 numpy transitions: local rotations (..., T, J, 4), local positions (..., T, J, 3)
    (root position and bone offsets), contacts (..., T, C). Computed in float32; every leg joint rotation the pass
    does not change keeps its float64 input exactly.
    Returns (rotations (..., T, J, 4), positions (..., T, J, 3) (the input), stats {"planted", "changed", "lifted":
    (..., T, legs) bool})."""
    rotations = np.asarray(rotations, np.float64)
    positions = np.asarray(positions, np.float64)
    as32 = lambda x: jnp.asarray(x, jnp.float32)  # noqa: E731
    out = lock_feet(as32(rotations), as32(positions[..., 0, :]), as32(contacts), skeleton,
                    offsets=as32(positions[..., 0, :, :]), feet=feet, config=config, sample_axis=sample_axis)
    changed = np.asarray(out["changed"])
    new = np.asarray(out["rotations"], np.float64)
    result = rotations.copy()
    for k, (hip, knee, ankle, _, _, _) in enumerate(leg_chains(skeleton, feet)):
        mask = changed[..., k, None]
        for joint in (hip, knee, ankle):
            result[..., joint, :] = np.where(mask, new[..., joint, :], rotations[..., joint, :])
    stats = {key: np.asarray(out[key]) for key in ("planted", "changed", "lifted")}
    return result, positions, stats
