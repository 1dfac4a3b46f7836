"""Foot locking: planted feet stay where they were put, solved on the legs with two-bone IK.

A post-process over generated transitions (start keyframe, L generated frames, target keyframe):

1. **Stance score** per leg and frame (:func:`stance_score`): the model's predicted contact times how close
   the generated foot is to the ground and how slowly it moves (the model's contact outputs alone hardly
   separate stance from swing, its feet rarely stop).
2. **Spans** (:func:`hysteresis`, :func:`bridge_gaps`, :func:`drop_short_spans`): the score switches a
   span on above ``enter`` and off below ``leave``; gaps of up to ``bridge_frames`` frames between spans are
   filled and spans shorter than ``min_frames`` are dropped, so a flicker neither ends a span nor makes one.
3. **Plant** (:func:`span_targets`): each span holds the foot (ankle position and foot orientation, so the
   toe too) at one place: by default the generated foot's mean place over the span (``plant_at``), or the
   keyframe's foot where the span touches a keyframe (a span touching both goes from the one to the other).
   A plant is never below the ground level of the keyframes' feet (the lowest ankle of both keyframes).
4. **Out of reach** (:func:`reachable_spans`): from the first frame where the planted ankle is farther from
   the hip than the leg is long, the foot is let go for the rest of its span (counted as let-go frames).
   A span's frames where the generated foot is more than ``leash`` cm from its plant, or where the
   correction could no longer be eased out at ``release_speed`` cm/frame before the keyframe it is not
   planted at (:func:`release_room`), are not held: the foot is eased to and from the plant there.
5. **Blend** (:func:`eased_plants`): over up to ``blend_frames`` frames after a span (and before the next)
   the foot is eased (smoothstep) from its plant to the generated foot, so it leaves a plant and lands on
   one at rest; both keyframes take no correction. A foot eased across is lifted on a small arc
   (``step_lift`` of the distance, at most ``max_step_height``).
6. **Clearance** (:func:`clearance_lift`): outside plants, a foot that still moves (``clearance_speed``)
   within ``clearance`` cm of the ground where the model predicts contact is lifted to that height, eased
   in and out: it steps instead of skating. The same rule as the foot-slide metric's (a foot low enough to
   count as on the ground must not move) decides both the plants and the lifts.
7. **Leg solve** (:func:`two_bone_ik`): hip, knee and ankle turned so the ankle reaches its target; bones keep
   their lengths exactly (only rotations change), the knee stays in the plane of the generated pose (pole
   vector, biased over the toes by ``pole_hint`` so a straight leg bends the right way), and the reach is
   softened near full extension (``soft_reach``), so a leg is straightened, never stretched, and never
   snaps straight.

Frames that no span, blend or lift touches, both keyframes among them, are returned bit for bit as given.
The root, the upper body and every joint's offset are unchanged; only the hip, knee and ankle rotations of
each leg move. Positions in the data's units (LAFAN1: cm; the thresholds are in cm and cm/frame), +Y up by
default (``FootLockConfig.up_axis``).

    out = lock_feet(rotations, root_positions, contacts, skeleton)     # any leading batch shape, jit-able
    out["rotations"], out["root_positions"], out["let_go"], out["planted"], out["lifted"]
"""
from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np

from stitchjax import rotations as R
from stitchjax.skeleton import Skeleton, forward_kinematics

__all__ = ["FootLockConfig", "DEFAULT_CONFIG", "leg_chains", "stance_score", "hysteresis", "drop_short_spans",
           "span_targets", "release_room", "reachable_spans", "bridge_gaps", "blended_corrections", "eased_plants",
           "clearance_lift", "soft_reach", "two_bone_ik", "lock_feet",
           "lock_transitions"]

FOOT_NAMES = ("LeftFoot", "LeftToe", "RightFoot", "RightToe")


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
      ground while the model predicts contact, outside spans, is lifted to it: it steps instead of
      skating (0: off). The lift is eased in and out over ``clearance_frames`` frames.
    pole_hint: the ankle-to-toe vector times this is added to the knee's pole (:func:`two_bone_ik`), so a
      nearly straight leg bends its knee over the toes, as legs do, instead of where rounding points (0: off).
    up_axis: the vertical axis of the positions.
    """

    contact_full: float = 0.1
    height: float = 6.0
    speed: float = 6.0
    enter: float = 0.5
    leave: float = 0.1
    min_frames: int = 3
    blend_frames: int = 8
    soft_reach: float = 0.97
    leash: float = 25.0
    plant_at: float = -1.0
    release_speed: float = 2.0
    hold_while_low: bool = False
    lift_power: float = 3.0
    step_lift: float = 0.2
    max_step_height: float = 3.0
    bridge_frames: int = 2
    ease_to_plant: bool = True
    clearance: float = 5.0
    clearance_speed: float = 2.0
    clearance_frames: int = 2
    pole_hint: float = 0.3
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
        if self.bridge_frames < 0 or self.clearance < 0 or self.clearance_speed <= 0 or self.clearance_frames < 0:
            raise ValueError("foot lock: bridge_frames, clearance, clearance_frames must be >= 0, "
                             "clearance_speed > 0")


DEFAULT_CONFIG = FootLockConfig()


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


# ------------------------------------------------------------------------------------------------ spans


def stance_score(contact, height, speed, config: FootLockConfig = DEFAULT_CONFIG):
    """How much a foot looks planted, in [0, 1]; (T,) each.

    contact: the predicted contact probability; height: the foot above the ground (cm); speed: its
    horizontal speed (cm/frame). min(contact / contact_full, 1) x (1 - height / height)+ x (1 - speed / speed)+:
    0 wherever the model predicts no contact."""
    c = jnp.clip(contact / config.contact_full, 0.0, 1.0)
    h = jnp.clip(1.0 - height / config.height, 0.0, 1.0)
    v = jnp.clip(1.0 - speed / config.speed, 0.0, 1.0)
    return c * h * v


def hysteresis(score, enter: float, leave: float, stay_score=None):
    """(T,) bool: on from a frame with score > enter until the first frame with stay_score < leave
    (stay_score: (T,), default ``score``)."""
    stay_score = score if stay_score is None else stay_score

    def step(on, x):
        s, stay = x
        on = jnp.where(on, stay >= leave, s > enter)
        return on, on
    return jax.lax.scan(step, jnp.asarray(False), (score, stay_score))[1]


def _span_ids(mask):
    """(T,) int: 1, 2, ... numbering the runs of True in ``mask``, 0 outside them."""
    start = mask & ~jnp.concatenate([jnp.zeros((1,), bool), mask[:-1]])
    return jnp.where(mask, jnp.cumsum(start), 0)


def drop_short_spans(mask, min_frames: int):
    """(T,) bool: ``mask`` without its runs shorter than ``min_frames``."""
    ids = _span_ids(mask)
    n = mask.shape[0]
    lengths = jax.ops.segment_sum(mask.astype(jnp.int32), ids, num_segments=n + 1)
    return mask & (lengths[ids] >= min_frames)


def span_targets(mask, ankle, foot_rotation, floor, up_axis: int = 1, plant_at: float = 0.0):
    """Where each span plants the foot: (target ankle positions (T, 3), target foot rotations (T, 4)).

    mask: (T,) bool spans; ankle: (T, 3) the generated ankle; foot_rotation: (T, 4) its global rotation;
    floor: the lowest height a planted ankle may have (the keyframes' ground level). A span plants at its
    first frame (see ``plant_at``), or at the last frame (the target keyframe) when it touches it; a span over
    both keyframes goes linearly from the start keyframe's foot to the target keyframe's. Outside spans the
    targets are the generated foot.
    plant_at: where along a span that touches no keyframe its plant is taken (0: its first frame, 0.5: its
    middle frame, < 0: the generated foot's mean position and orientation over the span)."""
    n = mask.shape[0]
    t = jnp.arange(n)
    ids = _span_ids(mask)
    first = jax.ops.segment_min(t, ids, num_segments=n + 1)[ids]
    last = jax.ops.segment_max(t, ids, num_segments=n + 1)[ids]
    at_end = mask & (last == n - 1)
    at_both = at_end & (first == 0)
    u = (t / max(n - 1, 1))[:, None]
    start = first
    first = jnp.where(first == 0, 0, first + jnp.round(max(plant_at, 0.0) * (last - first)).astype(first.dtype))
    position = ankle[first]
    if plant_at < 0:  # the generated foot's mean place and orientation over the span
        count = jnp.maximum(jax.ops.segment_sum(mask.astype(ankle.dtype), ids, num_segments=n + 1), 1.0)
        mean = jax.ops.segment_sum(jnp.where(mask[:, None], ankle, 0.0), ids, num_segments=n + 1) / count[:, None]
        aligned = _aligned(foot_rotation, foot_rotation[start])
        q_mean = jax.ops.segment_sum(jnp.where(mask[:, None], aligned, 0.0), ids, num_segments=n + 1)
        at_start = start == 0
        position = jnp.where(at_start[:, None], ankle[0], mean[ids])
        foot_rotation_plant = jnp.where(at_start[:, None], foot_rotation[0], R.quat_normalize(q_mean[ids]))
    else:
        foot_rotation_plant = foot_rotation[first]
    position = jnp.where(at_end[:, None], ankle[-1], position)
    position = jnp.where(at_both[:, None], (1.0 - u) * ankle[0] + u * ankle[-1], position)
    position = position.at[:, up_axis].max(floor)
    rotation = jnp.where(at_end[:, None], foot_rotation[-1], foot_rotation_plant)
    both = R.quat_normalize((1.0 - u) * foot_rotation[0] + u * _aligned(foot_rotation[-1], foot_rotation[0]))
    rotation = jnp.where(at_both[:, None], both, rotation)
    position = jnp.where(mask[:, None], position, ankle)
    rotation = jnp.where(mask[:, None], rotation, foot_rotation)
    return position, rotation


def _aligned(q, reference):
    """q with the sign that puts it in the hemisphere of ``reference``."""
    return jnp.where(jnp.sum(q * reference, axis=-1, keepdims=True) < 0, -q, q)


def release_room(mask):
    """(T,) frames a span frame has for easing its correction in or out next to a keyframe it is not planted
    at: to the nearer keyframe for a span touching neither (its plant is its own), to the last frame for one
    planted at the start keyframe, to the first for one planted at the target keyframe; unlimited (T) for a
    span over both keyframes and outside spans."""
    n = mask.shape[0]
    t = jnp.arange(n)
    ids = _span_ids(mask)
    first = jax.ops.segment_min(t, ids, num_segments=n + 1)[ids]
    last = jax.ops.segment_max(t, ids, num_segments=n + 1)[ids]
    room = jnp.where(last == n - 1, t, jnp.where(first == 0, n - 1 - t, jnp.minimum(t, n - 1 - t)))
    return jnp.where(mask & ~((first == 0) & (last == n - 1)), room, n)


def reachable_spans(mask, reachable):
    """(T,) bool: the span frames kept: a span is cut at its first unreachable frame (the rest let go);
    a span touching the last frame is cut from that end instead (its plant is the target keyframe's)."""
    n = mask.shape[0]
    ids = _span_ids(mask)
    last = jax.ops.segment_max(jnp.arange(n), ids, num_segments=n + 1)[ids]
    first = jax.ops.segment_min(jnp.arange(n), ids, num_segments=n + 1)[ids]
    at_end = mask & (last == n - 1) & (first > 0)

    def run(m, r):
        def step(alive, x):
            m_t, r_t, start_t = x
            alive = m_t & r_t & (alive | start_t)
            return alive, alive
        start = m & ~jnp.concatenate([jnp.zeros((1,), bool), m[:-1]])
        return jax.lax.scan(step, jnp.asarray(False), (m, r, start))[1]

    forward = run(mask & ~at_end, reachable)
    backward = run((mask & at_end)[::-1], reachable[::-1])[::-1]
    return forward | backward


def bridge_gaps(mask, max_gap: int):
    """(T,) bool: ``mask`` with its gaps of at most ``max_gap`` frames between two runs filled."""
    if max_gap <= 0:
        return mask
    n = mask.shape[0]
    t = jnp.arange(n)
    ids = _span_ids(~mask)
    first = jax.ops.segment_min(t, ids, num_segments=n + 1)[ids]
    last = jax.ops.segment_max(t, ids, num_segments=n + 1)[ids]
    inner = (first > 0) & (last < n - 1) & (last - first + 1 <= max_gap)
    return mask | (~mask & inner)


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
    foot = R.quat_normalize(w_prev[:, None] * _aligned(q_prev, foot_rotation)
                            + w_next[:, None] * _aligned(q_next, foot_rotation) + rest * foot_rotation)
    weight = jnp.maximum(w_prev, w_next)
    turn = jnp.where((weight > 0)[:, None], R.quat_mul(foot, R.quat_conjugate(foot_rotation)), identity)
    return offset, turn, weight, arc


def clearance_lift(height, speed, contact, anchor, clearance: float, clearance_speed: float, frames: int):
    """(T,) how far (cm) to lift a foot that moves low outside its plants, so that it steps clear.

    height: (T,) the foot's lowest joint above the ground (cm) after the plants' corrections; speed: (T,)
    its horizontal speed (cm/frame); contact: (T,) in [0, 1] the contact factor (0: the model predicts no
    contact, no lift); anchor: (T,) bool planted frames and keyframes (no lift). The need at a frame is
    (clearance - height)+ x ramp(speed) (0 below half ``clearance_speed``, 1 from it) x contact; the lift
    is the largest need within ``frames`` frames, tapered linearly with the distance, and eased to 0 over
    ``frames`` + 1 frames next to an anchor, so it starts before the foot moves and never jumps."""
    ramp = jnp.clip(2.0 * speed / clearance_speed - 1.0, 0.0, 1.0)
    need = jnp.clip(clearance - height, 0.0, clearance) * ramp * contact
    need = jnp.where(anchor, 0.0, need)
    n = need.shape[0]
    lift = need
    for k in range(1, frames + 1):
        taper = 1.0 - k / (frames + 1.0)
        padded = jnp.pad(need, (k, k))
        lift = jnp.maximum(lift, taper * jnp.maximum(padded[:n], padded[2 * k:]))
    since, until = _frames_from(anchor)
    near = jnp.minimum(since, until).astype(need.dtype)
    return lift * _smoothstep(near / (frames + 1.0))


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
    turn = _aligned(turn, identity)

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


# ---------------------------------------------------------------------------------------------- the leg


def soft_reach(distance, length, soft: float):
    """Reach distance (...) eased below the leg's full ``length``: unchanged up to soft x length, then
    approaching length exponentially (smooth, always < length)."""
    knee = soft * length
    span = (1.0 - soft) * length
    eased = knee + span * (1.0 - jnp.exp(-(distance - knee) / span))
    return jnp.where(distance > knee, eased, distance)


def two_bone_ik(hip, knee, ankle, target, upper, lower, soft: float = DEFAULT_CONFIG.soft_reach, hint=None):
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


def _lock_one(rotations, root_positions, contacts, offsets, legs: tuple, parents: tuple, config: FootLockConfig):
    """The pass on one transition: rotations (T, J, 4), root (T, 3), contacts (T, C), offsets (J, 3)."""
    up = config.up_axis
    num_frames = rotations.shape[0]
    local_positions = jnp.broadcast_to(offsets, rotations.shape[:-1] + (3,)).at[:, 0].set(root_positions)
    g_rot, g_pos = forward_kinematics(rotations, local_positions, parents)
    heights = g_pos[..., up]
    ankles = [leg[2] for leg in legs]
    toes = [leg[3] for leg in legs]
    ankle_ground = _floor(heights, jnp.asarray(ankles))
    toe_ground = _floor(heights, jnp.asarray(toes))
    keyframe = jnp.zeros(num_frames, bool).at[0].set(True).at[-1].set(True)

    new_rotations = rotations
    planted, let_go, touched, lifted = [], [], [], []
    for hip, knee, ankle, toe, c_ankle, c_toe in legs:
        height = jnp.minimum(heights[:, ankle] - ankle_ground, heights[:, toe] - toe_ground)
        speed = 0.5 * (_horizontal_speed(g_pos[:, ankle], up) + _horizontal_speed(g_pos[:, toe], up))
        contact = jnp.maximum(contacts[:, c_ankle], contacts[:, c_toe])
        score = stance_score(contact, height, speed, config)
        stay = stance_score(contact, height, jnp.zeros_like(speed), config) if config.hold_while_low else score
        spans = hysteresis(score, config.enter, config.leave, stay)
        spans = drop_short_spans(bridge_gaps(spans, config.bridge_frames), config.min_frames)
        target, target_rotation = span_targets(spans, g_pos[:, ankle], g_rot[:, ankle], ankle_ground, up,
                                               config.plant_at)
        upper = jnp.linalg.norm(offsets[knee])
        lower = jnp.linalg.norm(offsets[ankle])
        reachable = jnp.linalg.norm(target - g_pos[:, hip], axis=-1) <= upper + lower
        away = (target - g_pos[:, ankle]).at[:, up].set(0.0)
        near = jnp.sum(away**2, axis=-1) <= config.leash**2
        room = jnp.linalg.norm(target - g_pos[:, ankle], axis=-1) <= config.release_speed * release_room(spans)
        kept = reachable_spans(spans & near & room, reachable)
        anchor = kept | keyframe
        if config.ease_to_plant:
            offset, turn, weight, arc = eased_plants(anchor, keyframe & ~kept, target, target_rotation,
                                                     g_pos[:, ankle], g_rot[:, ankle], config.blend_frames,
                                                     config.lift_power, up)
        else:
            offset = jnp.where((kept & ~keyframe)[:, None], target - g_pos[:, ankle], 0.0)
            turn = R.quat_mul(target_rotation, R.quat_conjugate(g_rot[:, ankle]))
            turn = jnp.where((kept & ~keyframe)[:, None], turn, jnp.asarray([1.0, 0.0, 0.0, 0.0], turn.dtype))
            offset, turn, weight, arc = blended_corrections(anchor, offset, turn, config.blend_frames,
                                                            config.lift_power, up)
        offset = offset.at[:, up].add(jnp.minimum(config.step_lift * arc, config.max_step_height))
        if config.clearance > 0:
            new_ankle = g_pos[:, ankle] + offset
            new_toe = new_ankle + R.quat_rotate(turn, g_pos[:, toe] - g_pos[:, ankle])
            low = jnp.minimum(new_ankle[:, up] - ankle_ground, new_toe[:, up] - toe_ground)
            moving = jnp.maximum(_horizontal_speed(new_ankle, up), _horizontal_speed(new_toe, up))
            lift = clearance_lift(low, moving, jnp.clip(contact / config.contact_full, 0.0, 1.0), anchor,
                                  config.clearance, config.clearance_speed, config.clearance_frames)
            offset = offset.at[:, up].add(lift)
        else:
            lift = jnp.zeros(num_frames, offset.dtype)
        active = ~keyframe & (jnp.any(offset != 0, axis=-1) | (turn[:, 0] < 1.0))
        if not config.ease_to_plant and config.clearance <= 0:
            active = active & (weight > 0)

        hip_turn, knee_turn, _, _, _ = two_bone_ik(g_pos[:, hip], g_pos[:, knee], g_pos[:, ankle],
                                                   g_pos[:, ankle] + offset, upper, lower, config.soft_reach,
                                                   config.pole_hint * (g_pos[:, toe] - g_pos[:, ankle])
                                                   if config.pole_hint > 0 else None)
        hip_global = R.quat_mul(hip_turn, g_rot[:, hip])
        knee_global = R.quat_mul(knee_turn, R.quat_mul(hip_turn, g_rot[:, knee]))
        foot_global = R.quat_mul(turn, g_rot[:, ankle])
        parent_of_hip = g_rot[:, parents[hip]]
        local = {hip: R.quat_mul(R.quat_conjugate(parent_of_hip), hip_global),
                 knee: R.quat_mul(R.quat_conjugate(hip_global), knee_global),
                 ankle: R.quat_mul(R.quat_conjugate(knee_global), foot_global)}
        for joint, q in local.items():
            q = _aligned(R.quat_normalize(q), rotations[:, joint])
            new_rotations = new_rotations.at[:, joint].set(jnp.where(active[:, None], q, rotations[:, joint]))
        planted.append(kept & ~keyframe)
        let_go.append(spans & ~reachable_spans(spans, reachable))
        touched.append(active)
        lifted.append(active & (lift > 0.01))
    return {"rotations": new_rotations, "root_positions": root_positions,
            "planted": jnp.stack(planted, -1), "let_go": jnp.stack(let_go, -1), "changed": jnp.stack(touched, -1),
            "lifted": jnp.stack(lifted, -1)}


@functools.partial(jax.jit, static_argnames=("skeleton", "feet", "config"))
def lock_feet(rotations, root_positions, contacts, skeleton: Skeleton, offsets=None, feet=None,
              config: FootLockConfig = DEFAULT_CONFIG) -> dict:
    """Foot locking over a batch of transitions (jit-compiled; vmap-able).

    rotations: (..., T, J, 4) local rotations of transitions whose first and last frames are the keyframes;
    root_positions: (..., T, 3); contacts: (..., T, C) predicted contact probabilities, one channel per
    joint of ``feet`` (the keyframes' rows: their contact labels); skeleton: its parents (static);
    offsets: (..., J, 3) bone offsets (default: the skeleton's); feet: the contact joints (ankle, toe, ...)
    in channel order (default: LAFAN1's names); config: :class:`FootLockConfig`.
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
    flat = lambda x, k: x.reshape((-1,) + x.shape[x.ndim - k:])  # noqa: E731
    out = jax.vmap(functools.partial(_lock_one, legs=legs, parents=skeleton.parents, config=config))(
        flat(rotations, 3), flat(root_positions, 2), flat(jnp.asarray(contacts, rotations.dtype), 2),
        flat(offsets, 2))
    return jax.tree.map(lambda x: x.reshape(batch + x.shape[1:]), out)


def lock_transitions(rotations, positions, contacts, skeleton: Skeleton, feet=None,
                     config: FootLockConfig = DEFAULT_CONFIG):
    """:func:`lock_feet` on float64 numpy transitions: local rotations (..., T, J, 4), local positions
    (..., T, J, 3) (root position and bone offsets), contacts (..., T, C). Computed in float32; every leg
    joint rotation the pass does not change keeps its float64 input exactly.
    Returns (rotations (..., T, J, 4), positions (..., T, J, 3) (the input), stats {"planted", "let_go",
    "changed", "lifted": (..., T, legs) bool})."""
    rotations = np.asarray(rotations, np.float64)
    positions = np.asarray(positions, np.float64)
    as32 = lambda x: jnp.asarray(x, jnp.float32)  # noqa: E731
    out = lock_feet(as32(rotations), as32(positions[..., 0, :]), as32(contacts), skeleton,
                    offsets=as32(positions[..., 0, :, :]), feet=feet, config=config)
    changed = np.asarray(out["changed"])
    new = np.asarray(out["rotations"], np.float64)
    result = rotations.copy()
    for k, (hip, knee, ankle, _, _, _) in enumerate(leg_chains(skeleton, feet)):
        mask = changed[..., k, None]
        for joint in (hip, knee, ankle):
            result[..., joint, :] = np.where(mask, new[..., joint, :], rotations[..., joint, :])
    stats = {key: np.asarray(out[key]) for key in ("planted", "let_go", "changed", "lifted")}
    return result, positions, stats
