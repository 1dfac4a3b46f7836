"""Where and when a foot stands (:mod:`stitchjax.sample.footlock`): stance spans, plants, the easing between them
and the lifts off the ground.

Masks are (T,) bool over a transition's frames (start keyframe, generated frames, target keyframe); a span or a
plant is a run of True. :func:`hysteresis`, :func:`bridge_gaps` and :func:`drop_short_spans` make the stance spans
from a score, :func:`plant_runs` cuts them into plants with steps between, :func:`plant_targets` says where each
plant holds the foot, :func:`eased_plants` eases the foot between plants and the generated foot, and
:func:`clearance_lift` lifts a foot that is below the ground or skims it between plants. Heights and distances are
in the data's units (cm), speeds in cm per frame.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from stitchjax import rotations as R
from stitchjax.sample.footlock.legs import same_hemisphere, tent_max

__all__ = ["hysteresis", "span_ids", "drop_short_spans", "bridge_gaps", "plant_runs", "plant_targets",
           "release_room", "shared_scores", "eased_plants", "clearance_lift"]

CLEARANCE_SPEED = 2.0  # cm/frame: a foot slower than half this is at rest (no clearance lift), from this on it moves
LIFT_FRAMES = 2  # a lift reaches this many frames either side of where it is needed, so it starts before the foot moves
KEY_FRAMES = 8  # next to a keyframe the clearance falls over this many frames (+ 1) ...
KEY_CLEARANCE = 3.0  # ... to this height (cm), so the frames next to a keyframe stay near it
MAX_LIFT = 30.0  # cm: a foot deeper than this belongs to a pose (kneeling, lying) that no lift of the foot mends


def hysteresis(score, enter: float, leave: float):
    """(T,) bool: on from a frame with score > enter until the first frame with score < leave; score (T,)."""
    def step(on, s):
        on = jnp.where(on, s >= leave, s > enter)
        return on, on
    return jax.lax.scan(step, jnp.asarray(False), score)[1]


def span_ids(mask):
    """(T,) int: 1, 2, ... numbering the runs of True in ``mask``, 0 outside them."""
    start = mask & ~jnp.concatenate([jnp.zeros((1,), bool), mask[:-1]])
    return jnp.where(mask, jnp.cumsum(start), 0)


def _span_bounds(mask):
    """(ids (T,) of :func:`span_ids`, first (T,), last (T,)): each frame's run and that run's first and last frame
    (outside runs: the first and last frame outside any)."""
    n = mask.shape[0]
    t = jnp.arange(n)
    ids = span_ids(mask)
    first = jax.ops.segment_min(t, ids, num_segments=n + 1)[ids]
    last = jax.ops.segment_max(t, ids, num_segments=n + 1)[ids]
    return ids, first, last


def drop_short_spans(mask, min_frames: int):
    """(T,) bool: ``mask`` without its runs shorter than ``min_frames``."""
    ids = span_ids(mask)
    n = mask.shape[0]
    lengths = jax.ops.segment_sum(mask.astype(jnp.int32), ids, num_segments=n + 1)
    return mask & (lengths[ids] >= min_frames)


def bridge_gaps(mask, max_gap: int):
    """(T,) bool: ``mask`` with its gaps of at most ``max_gap`` frames between two runs filled."""
    if max_gap <= 0:
        return mask
    n = mask.shape[0]
    _, first, last = _span_bounds(~mask)
    inner = (first > 0) & (last < n - 1) & (last - first + 1 <= max_gap)
    return mask | (~mask & inner)


def plant_runs(spans, ankle, hip, reach, distance: float, step_frames: int, up_axis: int = 1):
    """(T,) bool: the stance ``spans`` cut into plants, with a step between two plants of one span.

    ankle, hip: (T, 3) the generated ankle and hip; reach: the leg's length. A plant begins at a span frame and
    lasts while the generated ankle stays within ``distance`` (horizontally) of where it began and that place
    within ``reach`` of the hip; the next ``step_frames`` (>= 1) frames are the step, left out, and the next plant
    begins at the generated ankle there (at the first frame where that is within reach). So a foot that skates or is carried out of reach takes short steps
    between plants instead of being held far from where it is."""
    def step(carry, x):
        start, running, skip = carry
        on, p, h = x
        start = jnp.where(running, start, p)  # where the plant is, or would begin here
        holds = (jnp.sum((p - start).at[up_axis].set(0.0) ** 2) <= distance**2) & (jnp.sum((start - h) ** 2) <= reach**2)
        cut = on & running & ~holds
        keep = on & (skip == 0) & holds
        skip = jnp.where(cut, step_frames - 1, jnp.where(on, jnp.maximum(skip - 1, 0), 0))
        return (start, keep, skip), keep

    init = (jnp.zeros(3, ankle.dtype), jnp.asarray(False), jnp.asarray(0))
    return jax.lax.scan(step, init, (spans, ankle, hip))[1]


def plant_targets(plants, ankle, foot_rotation, toe_offset, grounds: tuple, up_axis: int = 1):
    """Where each plant holds the foot: (ankle positions (T, 3), foot rotations (T, 4)); outside plants the
    generated foot.

    plants: (T,) bool; ankle: (T, 3) the generated ankle; foot_rotation: (T, 4) its global rotation; toe_offset:
    (3,) the toe's offset from the ankle; grounds: (ankle ground, toe ground), the heights of the keyframes'
    ground for each joint. A plant touching a keyframe holds the keyframe's foot (one over both keyframes goes
    linearly from the start keyframe's foot to the target keyframe's); any other holds the generated foot's mean
    place and orientation over the plant, moved up or down so that it stands on the ground: its lower joint,
    ankle or toe, exactly at that joint's ground."""
    n = plants.shape[0]
    ids, first, last = _span_bounds(plants)
    count = jnp.maximum(jax.ops.segment_sum(plants.astype(ankle.dtype), ids, num_segments=n + 1), 1.0)
    mean = jax.ops.segment_sum(jnp.where(plants[:, None], ankle, 0.0), ids, num_segments=n + 1) / count[:, None]
    aligned = same_hemisphere(foot_rotation, foot_rotation[first])
    turn = R.quat_normalize(jax.ops.segment_sum(jnp.where(plants[:, None], aligned, 0.0), ids, num_segments=n + 1))
    position, rotation = mean[ids], turn[ids]
    toe = position + R.quat_rotate(rotation, jnp.broadcast_to(toe_offset, position.shape))
    above = jnp.minimum(position[:, up_axis] - grounds[0], toe[:, up_axis] - grounds[1])
    position = position.at[:, up_axis].add(-above)
    at_start, at_end = plants & (first == 0), plants & (last == n - 1)
    u = (jnp.arange(n) / max(n - 1, 1))[:, None]
    last_rotation = same_hemisphere(foot_rotation[-1], foot_rotation[0])
    weight = jnp.where((at_start & at_end)[:, None], u, at_end[:, None].astype(u.dtype))  # the target keyframe's share
    key_position = (1.0 - weight) * ankle[0] + weight * ankle[-1]
    key_rotation = R.quat_normalize((1.0 - weight) * foot_rotation[0] + weight * last_rotation)
    on_key = (at_start | at_end)[:, None]
    position = jnp.where(on_key, key_position, position)
    rotation = jnp.where(on_key, key_rotation, rotation)
    return jnp.where(plants[:, None], position, ankle), jnp.where(plants[:, None], rotation, foot_rotation)


def release_room(mask):
    """(T,) frames a plant frame has for easing its correction out before a keyframe it does not hold: to the
    nearer keyframe for a plant touching neither, to the last frame for one at the start keyframe, to the first
    for one at the target keyframe; unlimited (T) for a plant over both keyframes and outside plants."""
    n = mask.shape[0]
    t = jnp.arange(n)
    _, first, last = _span_bounds(mask)
    room = jnp.where(last == n - 1, t, jnp.where(first == 0, n - 1 - t, jnp.minimum(t, n - 1 - t)))
    return jnp.where(mask & ~((first == 0) & (last == n - 1)), room, n)


def shared_scores(score, ankle, distance: float):
    """(S, T) stance scores shared by samples whose feet stay close.

    score: (S, T) one leg's stance scores of S samples of one keyframe pair; ankle: (S, T, 3) its ankle. Two
    samples are linked when their ankles' root-mean-square distance over the frames is at most ``distance``
    (cm); each sample takes the mean score of all samples linked to it, directly or through others, so a group
    of nearly equal samples gets one set of spans."""
    num = score.shape[0]
    gap = jnp.sqrt(jnp.mean(jnp.sum((ankle[:, None] - ankle[None]) ** 2, axis=-1), axis=-1))  # (S, S)
    link = (gap <= distance).astype(score.dtype)
    for _ in range(max(num - 1, 1).bit_length()):  # transitive closure: paths of up to 2^k links
        link = jnp.minimum(link @ link, 1.0)
    return (link / jnp.sum(link, axis=-1, keepdims=True)) @ score


def _frames_from(anchor):
    """(T,) frames since the last anchor and (T,) frames to the next one (0 at anchors; T where none)."""
    n = anchor.shape[0]

    def step(d, a):
        d = jnp.where(a, 0, d + 1)
        return d, d
    since = jax.lax.scan(step, jnp.asarray(n), anchor)[1]
    until = jax.lax.scan(step, jnp.asarray(n), anchor[::-1])[1][::-1]
    return since, until


def _smoothstep(x):
    x = jnp.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def eased_plants(anchor, free, target, target_rotation, ankle, foot_rotation, blend_frames: int,
                 lift_power: float = 1.0, up_axis: int = 1):
    """Ankle corrections that ease the foot between its plants and the generated foot.

    anchor: (T,) bool (the held plant frames and both keyframes); free: (T,) bool anchors that hold nothing
    (keyframes outside plants: no correction there); target: (T, 3) the plant of each anchor; target_rotation:
    (T, 4) its foot rotation; ankle: (T, 3) the generated ankle; foot_rotation: (T, 4) its global rotation.
    Between two anchors dp frames after the one and dn before the next, each side's plant has the weight
    w = smoothstep(1 - d / min(blend_frames + 1, dp + dn)) (the two sum to at most 1, exactly 1 where the gap is
    at most ``blend_frames`` + 1: a step from plant to plant), and the foot is put at w_prev plant_prev + w_next
    plant_next + the rest of the generated foot (vertically with the weights to the power ``lift_power``): it
    leaves a plant and lands on one at rest, and follows the generated foot in between. Returns (offset (T, 3) to
    add to the ankle, turn (T, 4) the foot's correcting rotation (identity where no plant weighs), arc (T,):
    4 w (1 - w) x the horizontal distance from each side's plant, summed, 0 at anchors: the height of a step)."""
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
    return offset, turn, arc


def clearance_lift(height, speed, anchor, keyframe, clearance: float, stance=None):
    """(T,) how far (cm) to lift a foot outside its plants: onto the ground, and clear of it where it moves.

    height: (T,) the foot's lower joint above its ground (cm) after the plants' corrections (< 0: below it);
    speed: (T,) its horizontal speed (cm/frame); anchor: (T,) bool plant frames and keyframes (no lift there);
    keyframe: (T,) bool; stance: (T,) bool or None, frames of stance spans (a step between two plants there is
    lifted by its own arc, not to the clearance). A foot below the ground is lifted onto it, moving or not. Outside
    ``stance`` a foot that moves (ramping in from half :data:`CLEARANCE_SPEED` to it) is lifted towards
    ``clearance`` above the ground, by at most ``clearance`` (0: feet are only kept out of the ground); next to a
    keyframe that clearance falls to :data:`KEY_CLEARANCE` over :data:`KEY_FRAMES` + 1 frames. This lift reaches
    :data:`LIFT_FRAMES` frames either side, tapered, and is eased to 0 next to an anchor, so it starts before the
    foot moves and never jumps. No lift exceeds :data:`MAX_LIFT`."""
    ramp = jnp.clip(2.0 * speed / CLEARANCE_SPEED - 1.0, 0.0, 1.0)
    if stance is not None:
        ramp = jnp.where(stance, 0.0, ramp)
    since, until = _frames_from(keyframe)
    near_key = _smoothstep(jnp.minimum(since, until).astype(height.dtype) / (KEY_FRAMES + 1.0))
    target = near_key * clearance + (1.0 - near_key) * jnp.minimum(clearance, KEY_CLEARANCE)
    moving = tent_max(jnp.where(anchor, 0.0, jnp.clip(target - height, 0.0, target) * ramp), LIFT_FRAMES)
    since, until = _frames_from(anchor)
    moving = moving * _smoothstep(jnp.minimum(since, until).astype(height.dtype) / (LIFT_FRAMES + 1.0))
    return jnp.minimum(jnp.maximum(moving, jnp.where(anchor, 0.0, -height)), MAX_LIFT)
