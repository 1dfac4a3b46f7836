"""Foot locking: planted feet stay where they were put, solved on the legs with two-bone IK.

A post-process over generated transitions (start keyframe, L generated frames, target keyframe):

1. **Stance score** per leg and frame (:func:`stance_score`): the model's predicted contact times how close the
   generated foot is to the ground and how slowly it moves (the model's contact outputs alone hardly separate
   stance from swing, its feet rarely stop).
2. **Spans** (:mod:`stitchjax.sample.foot_spans`: ``hysteresis``, ``bridge_gaps``, ``drop_short_spans``): the
   score switches a span on above ``enter`` and off below ``leave``; gaps of up to ``bridge_frames`` frames
   between spans are filled and spans shorter than ``min_frames`` are dropped, so a flicker neither ends a span
   nor makes one. With ``replant_distance``, a span whose foot skates that far is cut into several plants
   (``foot_spans.split_drifting_spans``). Samples of one keyframe pair whose feet stay within
   ``share_distance`` cm of each other take their spans from their mean score (``foot_spans.shared_scores``,
   when ``lock_feet`` is given the sample axis): samples that hardly differ plant the same frames, so the pass
   adds no spread between them.
3. **Plant** (``foot_spans.span_targets``): each span holds the foot (ankle position and foot orientation, so
   the toe too) at one place: by default the generated foot's mean place over the span (``plant_at``), or the
   keyframe's foot where the span touches a keyframe (a span touching both goes from the one to the other). A
   plant is never below the ground level of the keyframes' feet (the lowest ankle of both keyframes).
4. **Out of reach** (``foot_spans.reachable_spans``): from the first frame where the planted ankle is farther
   from the hip than the leg is long, the foot is let go for the rest of its span (counted as let-go frames). A
   span's frames where the generated foot is more than ``leash`` cm from its plant, or where the correction
   could no longer be eased out at ``release_speed`` cm/frame before the keyframe it is not planted at
   (``foot_spans.release_room``), are not held: the foot is eased to and from the plant there.
5. **Blend** (:mod:`stitchjax.sample.foot_easing`): over up to ``blend_frames`` frames after a span (and before
   the next) the foot is eased (smoothstep) from its plant to the generated foot, so it leaves a plant and lands
   on one at rest; both keyframes take no correction. A foot eased across is lifted on a small arc
   (``step_lift`` of the distance, at most ``max_step_height``).
6. **Clearance** (``foot_easing.clearance_lift``): outside plants, a foot that still moves (``clearance_speed``)
   within ``clearance`` cm of the ground is lifted to that height (only where the model predicts contact, with
   ``clearance_contact``), eased in and out: it steps instead of skating. With ``lift_from_below`` a foot
   below the ground is lifted the whole way (and out of the ground where it does not move), by at most
   ``max_lift``; next to a keyframe the clearance falls to ``key_clearance`` over ``clearance_key_frames``
   frames. The same rule as the foot-slide metric's (a foot low enough to count as on the ground must not
   move) decides both the plants and the lifts. ``replant_distance`` is off by default: it lost on the
   validation split (results/2026-12-06_footlock_v5).
7. **Leg solve** (:mod:`stitchjax.sample.leg_ik`): hip, knee and ankle turned so the ankle reaches its target;
   bones keep their lengths exactly (only rotations change), the knee stays in the plane of the generated pose
   (pole vector, biased over the toes by ``pole_hint`` so a straight leg bends the right way), and the reach is
   softened near full extension (``soft_reach``), so a leg is straightened, never stretched, and never snaps
   straight. Between plants the ankle's correction changes no faster than the generated foot's spare speed
   and the solved knee angle no faster than the generated knee's plus ``knee_step`` degrees per frame
   (:mod:`stitchjax.sample.foot_speed`): easing to a plant adds no joint jump.
8. **Jump guard** (``foot_speed.guard_joint_jumps``, ``jump_guard`` rounds): where a leg joint still moves
   farther in one frame than any joint of the generated transition (and than ``jump_floor`` cm), the leg's
   correction is cut there, gradually, so the pass never makes a fast transition's fastest motion faster.
   With the guard on (results/2026-12-06_footlock_v6) the correction's speed limit of step 7 is looser
   (``correction_step`` 6 cm/frame): feet reach their plants and lifts sooner, and the guard catches the rare
   step that then outruns the transition.

Frames that no span, blend or lift touches, both keyframes among them, are returned bit for bit as given.
The root, the upper body and every joint's offset are unchanged; only the hip, knee and ankle rotations of
each leg move. Positions in the data's units (LAFAN1: cm; the thresholds are in cm and cm/frame), +Y up by
default (``FootLockConfig.up_axis``).

    out = lock_feet(rotations, root_positions, contacts, skeleton, sample_axis=1)   # (B, S, T, ...); jit-able
    out["rotations"], out["root_positions"], out["let_go"], out["planted"], out["lifted"]
"""
from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np

from stitchjax import rotations as R
from stitchjax.sample.foot_easing import blended_corrections, clearance_lift, eased_plants
from stitchjax.sample.foot_speed import guard_joint_jumps, limit_correction_speed, limit_knee_speed
from stitchjax.sample.foot_spans import (bridge_gaps, drop_short_spans, hysteresis, reachable_spans, release_room,
                                         shared_scores, span_targets, split_drifting_spans)
from stitchjax.sample.leg_ik import SOFT_REACH, leg_chains, leg_rotations
from stitchjax.skeleton import Skeleton, forward_kinematics

__all__ = ["FootLockConfig", "DEFAULT_CONFIG", "stance_score", "lock_feet", "lock_transitions"]


@dataclasses.dataclass(frozen=True)
class FootLockConfig:
    """Settings of the pass (hashable: a static argument of jit). Lengths in the data's units (cm).

    contact_full: a predicted contact probability at or above this counts fully; below it scales the score.
    height: the height factor of the score falls from 1 on the ground to 0 at this height (cm).
    speed: the speed factor falls from 1 at rest to 0 at this horizontal foot speed (cm/frame).
    enter, leave: hysteresis thresholds of the score (enter > leave).
    min_frames: spans shorter than this are dropped.
    blend_frames: frames over which a correction is eased out after a span (and in before one).
    soft_reach: fraction of the leg's length from which the IK reach is softened (< 1).
    leash: span frames where the generated ankle is this far (cm, horizontally) from the plant are not
      held, so that no release has to make up more than this.
    plant_at: where along a span its plant is taken, when it touches no keyframe (0: its first frame; < 0:
      the generated foot's mean position and orientation over the span, the smallest correction).
    release_speed: span frames whose correction could not be eased in or out next to a keyframe the span is
      not planted at, at this many cm per frame, are not held (so no correction is squeezed into the
      frames next to a keyframe).
    hold_while_low: a span, once on, lasts while the score without its speed factor stays >= leave (the
      generated foot's speed does not matter while it is held; it ends when the foot lifts).
    lift_power: the vertical part of a correction is eased with the blend weight to this power, so a foot
      leaving a plant follows the generated foot up sooner than across.
    step_lift: a foot eased from or to a plant is lifted on an arc of this fraction of the horizontal
      distance it makes up (0: slides back along the ground), at most ``max_step_height`` cm: a step.
    bridge_frames: gaps of at most this many frames between two spans are filled (a flicker of the score
      ends no span).
    ease_to_plant: ease the foot between its plant and the generated foot's current place (position and
      orientation), so a foot leaves a plant and lands on one at rest; False: ease the correction of the
      span's last frame away (the foot leaves at the generated foot's speed).
    clearance: a foot that moves (faster than ``clearance_speed`` cm/frame) within this height (cm) of the
      ground outside spans is lifted to it: it steps instead of skating (0: off). The lift is eased in and
      out over ``clearance_frames`` frames.
    clearance_contact: lift only where the model predicts contact (False: any foot that moves low).
    lift_from_below: a foot below the ground is lifted to ``clearance`` above it like any other (False: by at
      most ``clearance``), and lifted at least to the ground where it does not move; by at most ``max_lift``
      cm either way (a foot deeper than that belongs to a pose, kneeling or lying, that no lift mends).
    replant_distance: a span is cut where its foot has drifted this far (cm, horizontally) from where the
      current plant began, and planted anew after ``replant_gap`` (>= 1) frames: a foot that skates through a
      long span takes short steps between plants instead of being held far from the generated foot and let
      go (``foot_spans.split_drifting_spans``; 0: off).
    clearance_key_frames, key_clearance: next to a keyframe the clearance falls to ``key_clearance`` cm
      over this many frames (+ 1), so the frames next to a keyframe stay near it (0: off; the lift is eased
      to 0 next to a keyframe as next to a plant either way).
    pole_hint: the ankle-to-toe vector times this is added to the knee's pole (``leg_ik.two_bone_ik``), so a
      nearly straight leg bends its knee over the toes, as legs do, instead of where rounding points (0: off).
    correction_step: the ankle's correction may change by at most max(V - s, correction_step) cm per frame,
      where s is the generated ankle's step that frame and V its largest step in the transition
      (``foot_speed.limit_correction_speed``): a corrected foot moves no faster than the generated foot's own
      top speed (plus this), so easing to a plant never whips the leg (< 0: no limit).
    knee_step: the solved knee angle may change per frame by at most the generated knee's change plus this
      many degrees (``foot_speed.limit_knee_speed``; planted frames and keyframes exact): near full extension
      a small change of reach is a large change of angle, so a leg is never snapped straight or bent (< 0: no
      limit).
    share_distance: samples of one keyframe pair whose ankles stay this close (cm, root mean square over the
      frames; linked through each other) take their spans from their mean stance score
      (``foot_spans.shared_scores``; only where ``lock_feet`` is told the sample axis). Samples that hardly
      differ then plant the same frames, so the pass adds no spread between them (0: each its own spans).
    jump_guard, jump_floor: rounds of ``foot_speed.guard_joint_jumps``: where a leg joint of the result moves
      farther in one frame than any joint of the generated transition and than ``jump_floor`` cm, the leg's
      correction is halved there, up to this many times (0: off), so the pass does not make a fast
      transition's fastest motion faster (slower steps are the speed limits' business).
    up_axis: the vertical axis of the positions.
    """

    contact_full: float = 0.1
    height: float = 6.0
    speed: float = 6.0
    enter: float = 0.5
    leave: float = 0.1
    min_frames: int = 3
    blend_frames: int = 8
    soft_reach: float = SOFT_REACH  # two_bone_ik's default too
    leash: float = 10.0
    plant_at: float = -1.0
    release_speed: float = 0.5
    hold_while_low: bool = False
    lift_power: float = 3.0
    step_lift: float = 0.2
    max_step_height: float = 3.0
    bridge_frames: int = 2
    ease_to_plant: bool = True
    clearance: float = 10.0
    clearance_speed: float = 2.0
    clearance_contact: bool = False
    clearance_frames: int = 2
    lift_from_below: bool = True
    max_lift: float = 30.0
    replant_distance: float = 0.0
    replant_gap: int = 2
    clearance_key_frames: int = 8
    key_clearance: float = 3.0
    pole_hint: float = 0.3
    correction_step: float = 6.0
    knee_step: float = 6.0
    share_distance: float = 5.0
    jump_guard: int = 8
    jump_floor: float = 10.0
    up_axis: int = 1

    def __post_init__(self):
        if not 0.0 <= self.leave <= self.enter:
            raise ValueError(f"foot lock: need 0 <= leave ({self.leave}) <= enter ({self.enter})")
        if self.min_frames < 1 or self.blend_frames < 0:
            raise ValueError("foot lock: min_frames must be >= 1 and blend_frames >= 0")
        if not 0.0 < self.soft_reach < 1.0:
            raise ValueError(f"foot lock: soft_reach must be in (0, 1), got {self.soft_reach}")
        if self.contact_full <= 0 or self.height <= 0 or self.speed <= 0:
            raise ValueError("foot lock: contact_full, height and speed must be > 0")
        if (self.bridge_frames < 0 or self.clearance < 0 or self.clearance_speed <= 0 or self.clearance_frames < 0
                or self.clearance_key_frames < 0 or self.key_clearance < 0 or self.max_lift < 0
                or self.replant_gap < 1):
            raise ValueError("foot lock: bridge_frames, clearance, clearance_frames, clearance_key_frames, "
                             "key_clearance, max_lift must be >= 0, clearance_speed > 0, replant_gap >= 1")
        if self.jump_guard < 0 or self.jump_floor < 0 or self.share_distance < 0:
            raise ValueError(f"foot lock: jump_guard ({self.jump_guard}), jump_floor ({self.jump_floor}) and "
                             f"share_distance ({self.share_distance}) must be >= 0")


DEFAULT_CONFIG = FootLockConfig()


# ------------------------------------------------------------------------------------------ the score


def stance_score(contact, height, speed, config: FootLockConfig = DEFAULT_CONFIG):
    """How much a foot looks planted, in [0, 1]; (T,) each.

    contact: the predicted contact probability; height: the foot above the ground (cm); speed: its
    horizontal speed (cm/frame). min(contact / contact_full, 1) x (1 - height / height)+ x (1 - speed / speed)+:
    0 wherever the model predicts no contact."""
    c = jnp.clip(contact / config.contact_full, 0.0, 1.0)
    h = jnp.clip(1.0 - height / config.height, 0.0, 1.0)
    v = jnp.clip(1.0 - speed / config.speed, 0.0, 1.0)
    return c * h * v


# ----------------------------------------------------------------------------------------- the whole pass


def _horizontal_speed(x, up_axis: int):
    """(T, ...) speed per frame (cm/frame) of positions (T, ..., 3) in the horizontal plane (central
    differences, one-sided at the ends)."""
    flat = x.at[..., up_axis].set(0.0)
    padded = jnp.concatenate([2 * flat[:1] - flat[1:2], flat, 2 * flat[-1:] - flat[-2:-1]], axis=0)
    return jnp.sqrt(jnp.sum((padded[2:] - padded[:-2]) ** 2, axis=-1) + 1e-12) * 0.5


def _floor(heights, joints):
    """The ground level of the keyframes for these joints: their lowest height at the first and last frame."""
    return jnp.min(jnp.stack([heights[0], heights[-1]])[:, joints])


def _leg_score(g_pos, heights, contacts, leg: tuple, grounds: tuple, config: FootLockConfig):
    """One leg's stance score (T,) (step 1 of the module docstring), the score that keeps a span on (T,) and
    the leg's contact (T,): the larger predicted contact of its ankle and toe. g_pos: (T, J, 3) global
    positions; heights: (T, J) their heights; grounds: (ankle ground, toe ground), the keyframes' ground levels."""
    _, _, ankle, toe, c_ankle, c_toe = leg
    up = config.up_axis
    ankle_ground, toe_ground = grounds
    height = jnp.minimum(heights[:, ankle] - ankle_ground, heights[:, toe] - toe_ground)
    speed = 0.5 * (_horizontal_speed(g_pos[:, ankle], up) + _horizontal_speed(g_pos[:, toe], up))
    contact = jnp.maximum(contacts[:, c_ankle], contacts[:, c_toe])
    score = stance_score(contact, height, speed, config)
    stay = stance_score(contact, height, jnp.zeros_like(speed), config) if config.hold_while_low else score
    return score, stay, contact


def _leg_spans(score, stay, config: FootLockConfig):
    """(T,) bool stance spans of one leg from its scores (step 2)."""
    spans = hysteresis(score, config.enter, config.leave, stay)
    return drop_short_spans(bridge_gaps(spans, config.bridge_frames), config.min_frames)


def _held_frames(spans, target, hip_position, ankle_position, leg_length, config: FootLockConfig):
    """(kept (T,) bool: the span frames held at their plant (step 4), reachable (T,) bool: the plant
    ``target`` (T, 3) within ``leg_length`` of the hip)."""
    reachable = jnp.linalg.norm(target - hip_position, axis=-1) <= leg_length
    away = (target - ankle_position).at[:, config.up_axis].set(0.0)
    near = jnp.sum(away**2, axis=-1) <= config.leash**2
    room = jnp.linalg.norm(target - ankle_position, axis=-1) <= config.release_speed * release_room(spans)
    return reachable_spans(spans & near & room, reachable), reachable


def _plant_corrections(anchor, keyframe, kept, target, target_rotation, ankle_position, ankle_rotation,
                       config: FootLockConfig):
    """(offset (T, 3) of the ankle, turn (T, 4) of the foot, weight (T,)): the plants eased in and out
    (step 5), a foot eased across lifted on its arc."""
    up = config.up_axis
    if config.ease_to_plant:
        offset, turn, weight, arc = eased_plants(anchor, keyframe & ~kept, target, target_rotation, ankle_position,
                                                 ankle_rotation, config.blend_frames, config.lift_power, up)
    else:
        offset = jnp.where((kept & ~keyframe)[:, None], target - ankle_position, 0.0)
        turn = R.quat_mul(target_rotation, R.quat_conjugate(ankle_rotation))
        turn = jnp.where((kept & ~keyframe)[:, None], turn, jnp.asarray([1.0, 0.0, 0.0, 0.0], turn.dtype))
        offset, turn, weight, arc = blended_corrections(anchor, offset, turn, config.blend_frames,
                                                        config.lift_power, up)
    offset = offset.at[:, up].add(jnp.minimum(config.step_lift * arc, config.max_step_height))
    return offset, turn, weight


def _with_clearance(offset, turn, ankle_position, toe_position, contact, anchor, keyframe, grounds: tuple,
                    config: FootLockConfig):
    """(offset with the clearance lift added (step 6), lift (T,) in cm)."""
    up = config.up_axis
    if config.clearance <= 0:
        return offset, jnp.zeros(offset.shape[0], offset.dtype)
    ankle_ground, toe_ground = grounds
    new_ankle = ankle_position + offset
    new_toe = new_ankle + R.quat_rotate(turn, toe_position - ankle_position)
    low = jnp.minimum(new_ankle[:, up] - ankle_ground, new_toe[:, up] - toe_ground)
    moving = jnp.maximum(_horizontal_speed(new_ankle, up), _horizontal_speed(new_toe, up))
    contact_factor = jnp.clip(contact / config.contact_full, 0.0, 1.0) if config.clearance_contact else 1.0
    lift = clearance_lift(low, moving, jnp.broadcast_to(contact_factor, low.shape), anchor,
                          config.clearance, config.clearance_speed, config.clearance_frames,
                          config.lift_from_below, keyframe, config.clearance_key_frames, config.key_clearance,
                          config.max_lift)
    return offset.at[:, up].add(lift), lift


def _lock_leg(rotations, g_rot, g_pos, heights, contacts, offsets, leg: tuple, parents: tuple, grounds: tuple,
              keyframe, score, stay, config: FootLockConfig):
    """One leg of :func:`_lock_one`: ({hip, knee, ankle: (T, 4) new local rotation}, active (T,) bool: the
    frames whose leg moves, {"planted", "let_go", "changed", "lifted": (T,) bool}). score, stay: (T,) the
    leg's stance scores (:func:`_leg_score`, or shared across samples)."""
    hip, knee, ankle, toe = leg[:4]
    contact = _leg_score(g_pos, heights, contacts, leg, grounds, config)[2]
    spans = _leg_spans(score, stay, config)
    if config.replant_distance > 0:
        spans = drop_short_spans(split_drifting_spans(spans, g_pos[:, ankle], config.replant_distance,
                                                      config.replant_gap, config.up_axis), config.min_frames)
    target, target_rotation = span_targets(spans, g_pos[:, ankle], g_rot[:, ankle], grounds[0], config.up_axis,
                                           config.plant_at)
    upper = jnp.linalg.norm(offsets[knee])
    lower = jnp.linalg.norm(offsets[ankle])
    kept, reachable = _held_frames(spans, target, g_pos[:, hip], g_pos[:, ankle], upper + lower, config)
    anchor = kept | keyframe
    offset, turn, weight = _plant_corrections(anchor, keyframe, kept, target, target_rotation, g_pos[:, ankle],
                                              g_rot[:, ankle], config)
    offset, lift = _with_clearance(offset, turn, g_pos[:, ankle], g_pos[:, toe], contact, anchor, keyframe,
                                   grounds, config)
    if config.correction_step >= 0:
        offset = limit_correction_speed(offset, g_pos[:, ankle], anchor, config.correction_step)
    active = ~keyframe & (jnp.any(offset != 0, axis=-1) | (turn[:, 0] < 1.0))
    if not config.ease_to_plant and config.clearance <= 0:
        active = active & (weight > 0)
    goal = g_pos[:, ankle] + offset
    if config.knee_step >= 0:
        goal = limit_knee_speed(g_pos[:, hip], goal, g_pos[:, ankle], upper, lower, anchor, config.soft_reach,
                                config.knee_step)
        active = active | (~keyframe & jnp.any(goal != g_pos[:, ankle] + offset, axis=-1))
    local = leg_rotations(rotations, g_rot, g_pos, leg, parents, goal, turn, upper, lower, config.soft_reach,
                          config.pole_hint)
    stats = {"planted": kept & ~keyframe, "let_go": spans & ~reachable_spans(spans, reachable), "changed": active,
             "lifted": active & (lift > 0.01)}
    return local, active, stats


def _posed(rotations, root_positions, offsets, legs: tuple, parents: tuple, config: FootLockConfig):
    """FK of one transition: (global rotations (T, J, 4), positions (T, J, 3), heights (T, J), grounds:
    (ankle ground, toe ground) of the keyframes)."""
    local_positions = jnp.broadcast_to(offsets, rotations.shape[:-1] + (3,)).at[:, 0].set(root_positions)
    g_rot, g_pos = forward_kinematics(rotations, local_positions, parents)
    heights = g_pos[..., config.up_axis]
    grounds = (_floor(heights, jnp.asarray([leg[2] for leg in legs])),
               _floor(heights, jnp.asarray([leg[3] for leg in legs])))
    return g_rot, g_pos, heights, grounds


def _scores_one(rotations, root_positions, contacts, offsets, legs: tuple, parents: tuple, config: FootLockConfig):
    """Stance scores of one transition: (score (T, legs), stay (T, legs), ankle positions (T, legs, 3))."""
    _, g_pos, heights, grounds = _posed(rotations, root_positions, offsets, legs, parents, config)
    parts = [_leg_score(g_pos, heights, contacts, leg, grounds, config)[:2] for leg in legs]
    return (jnp.stack([p[0] for p in parts], -1), jnp.stack([p[1] for p in parts], -1),
            jnp.stack([g_pos[:, leg[2]] for leg in legs], -2))


def _lock_one(rotations, root_positions, contacts, offsets, score, stay, legs: tuple, parents: tuple,
              config: FootLockConfig):
    """The pass on one transition: rotations (T, J, 4), root (T, 3), contacts (T, C), offsets (J, 3), the
    legs' stance scores score, stay (T, legs)."""
    num_frames = rotations.shape[0]
    g_rot, g_pos, heights, grounds = _posed(rotations, root_positions, offsets, legs, parents, config)
    keyframe = jnp.zeros(num_frames, bool).at[0].set(True).at[-1].set(True)
    new_rotations = rotations
    stats = {key: [] for key in ("planted", "let_go", "changed", "lifted")}
    for k, leg in enumerate(legs):
        local, active, leg_stats = _lock_leg(rotations, g_rot, g_pos, heights, contacts, offsets, leg, parents,
                                             grounds, keyframe, score[:, k], stay[:, k], config)
        for joint, q in local.items():
            new_rotations = new_rotations.at[:, joint].set(jnp.where(active[:, None], q, rotations[:, joint]))
        for key, value in leg_stats.items():
            stats[key].append(value)
    if config.jump_guard > 0:
        new_rotations = guard_joint_jumps(new_rotations, rotations, (g_rot, g_pos), offsets, legs, parents,
                                          config.jump_guard, config.jump_floor)
    return {"rotations": new_rotations, "root_positions": root_positions,
            **{key: jnp.stack(values, -1) for key, values in stats.items()}}


@functools.partial(jax.jit, static_argnames=("skeleton", "feet", "config", "sample_axis"))
def lock_feet(rotations, root_positions, contacts, skeleton: Skeleton, offsets=None, feet=None,
              config: FootLockConfig = DEFAULT_CONFIG, sample_axis: int | None = None) -> dict:
    """Foot locking over a batch of transitions (jit-compiled; vmap-able).

    rotations: (..., T, J, 4) local rotations of transitions whose first and last frames are the keyframes;
    root_positions: (..., T, 3); contacts: (..., T, C) predicted contact probabilities, one channel per
    joint of ``feet`` (the keyframes' rows: their contact labels); skeleton: its parents (static);
    offsets: (..., J, 3) bone offsets (default: the skeleton's); feet: the contact joints (ankle, toe, ...)
    in channel order (default: LAFAN1's names); config: :class:`FootLockConfig`; sample_axis: the batch axis
    of rotations that holds the samples of one keyframe pair (e.g. 1 for (B, S, T, J, 4)): samples whose
    feet stay within ``config.share_distance`` share their stance spans (``foot_spans.shared_scores``);
    None: each transition decides its own.
    Returns {"rotations" (..., T, J, 4), "root_positions" (..., T, 3) (unchanged), "planted" (..., T, legs)
    frames held by a span, "let_go" (..., T, legs) span frames let go because out of reach, "changed"
    (..., T, legs) frames whose leg moved, "lifted" (..., T, legs) frames whose foot was lifted clear
    (``clearance``) by more than 0.01 cm}. Unchanged frames, keyframes among them, are the inputs exactly.
    """
    legs = leg_chains(skeleton, feet)
    batch = rotations.shape[:-3]
    if offsets is None:
        offsets = jnp.asarray(skeleton.offsets, rotations.dtype)
    offsets = jnp.broadcast_to(jnp.asarray(offsets, rotations.dtype), batch + (skeleton.num_joints, 3))
    contacts = jnp.asarray(contacts, rotations.dtype)
    flat = lambda x, k: x.reshape((-1,) + x.shape[x.ndim - k:])  # noqa: E731
    unflat = lambda x: x.reshape(batch + x.shape[1:])  # noqa: E731
    inputs = (flat(rotations, 3), flat(root_positions, 2), flat(contacts, 2), flat(offsets, 2))
    statics = {"legs": legs, "parents": skeleton.parents, "config": config}
    score, stay, ankles = jax.vmap(functools.partial(_scores_one, **statics))(*inputs)
    if sample_axis is not None and config.share_distance > 0:
        axis = sample_axis % len(batch)
        score, stay, ankles = (jnp.moveaxis(unflat(x), axis, 0) for x in (score, stay, ankles))
        share = jax.vmap(shared_scores, in_axes=(-1, -1, -2, None), out_axes=-1)  # over legs
        for _ in range(len(batch) - 1):  # over the other batch axes
            share = jax.vmap(share, in_axes=(1, 1, 1, None), out_axes=1)
        score, stay = share(score, stay, ankles, config.share_distance)
        score, stay = (flat(jnp.moveaxis(x, 0, axis), 2) for x in (score, stay))
    out = jax.vmap(functools.partial(_lock_one, **statics))(*inputs, score, stay)
    return jax.tree.map(unflat, out)


def lock_transitions(rotations, positions, contacts, skeleton: Skeleton, feet=None,
                     config: FootLockConfig = DEFAULT_CONFIG, sample_axis: int | None = None):
    """:func:`lock_feet` on float64 numpy transitions: local rotations (..., T, J, 4), local positions
    (..., T, J, 3) (root position and bone offsets), contacts (..., T, C). Computed in float32; every leg
    joint rotation the pass does not change keeps its float64 input exactly.
    Returns (rotations (..., T, J, 4), positions (..., T, J, 3) (the input), stats {"planted", "let_go",
    "changed", "lifted": (..., T, legs) bool})."""
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
    stats = {key: np.asarray(out[key]) for key in ("planted", "let_go", "changed", "lifted")}
    return result, positions, stats
