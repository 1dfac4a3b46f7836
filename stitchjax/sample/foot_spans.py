"""The spans of foot locking (:mod:`stitchjax.sample.footlock`): runs of frames where a foot stands, and its plants.

A span is a run of True in a (T,) bool mask over a transition's frames (start keyframe, generated frames,
target keyframe). :func:`hysteresis` switches spans on and off from a stance score, :func:`bridge_gaps` and
:func:`drop_short_spans` clean them up, :func:`span_targets` says where each span plants the foot, and
:func:`release_room` and :func:`reachable_spans` say which of its frames can be held.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from stitchjax import rotations as R
from stitchjax.sample.leg_ik import same_hemisphere

__all__ = ["hysteresis", "span_ids", "drop_short_spans", "bridge_gaps", "split_drifting_spans", "span_targets",
           "release_room", "reachable_spans", "shared_scores"]


def hysteresis(score, enter: float, leave: float, stay_score=None):
    """(T,) bool: on from a frame with score > enter until the first frame with stay_score < leave
    (stay_score: (T,), default ``score``)."""
    stay_score = score if stay_score is None else stay_score

    def step(on, x):
        s, stay = x
        on = jnp.where(on, stay >= leave, s > enter)
        return on, on
    return jax.lax.scan(step, jnp.asarray(False), (score, stay_score))[1]


def span_ids(mask):
    """(T,) int: 1, 2, ... numbering the runs of True in ``mask``, 0 outside them."""
    start = mask & ~jnp.concatenate([jnp.zeros((1,), bool), mask[:-1]])
    return jnp.where(mask, jnp.cumsum(start), 0)


def _span_bounds(mask):
    """(ids (T,) of :func:`span_ids`, first (T,), last (T,)): each frame's span and that span's first and last
    frame (outside spans: the first and last frame outside any)."""
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


def split_drifting_spans(mask, position, distance: float, gap: int, up_axis: int = 1):
    """(T,) bool: ``mask`` with each span cut into runs over which the foot stays within ``distance`` (cm,
    horizontally) of where the run began, ``gap`` frames left out between two runs (the step from the one
    plant to the next; at least 1), so a foot that skates through a long span takes steps instead of being
    held far from where it is. position: (T, 3) the generated foot. ``distance`` <= 0: ``mask`` unchanged."""
    if distance <= 0:
        return mask

    def step(carry, x):
        start, running, skip = carry
        on, p = x
        away = jnp.sum((p - start).at[up_axis].set(0.0) ** 2) > distance**2
        cut = on & running & away & (skip == 0)
        keep = on & (skip == 0) & ~cut
        start = jnp.where(keep & ~running, p, start)
        running = keep
        skip = jnp.where(cut, gap - 1, jnp.where(on, jnp.maximum(skip - 1, 0), 0))
        return (start, running, skip), keep

    init = (jnp.zeros(3, position.dtype), jnp.asarray(False), jnp.asarray(0))
    return jax.lax.scan(step, init, (mask, position))[1]


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
    ids, first, last = _span_bounds(mask)
    at_end = mask & (last == n - 1)
    at_both = at_end & (first == 0)
    u = (t / max(n - 1, 1))[:, None]
    start = first
    first = jnp.where(first == 0, 0, first + jnp.round(max(plant_at, 0.0) * (last - first)).astype(first.dtype))
    position = ankle[first]
    if plant_at < 0:  # the generated foot's mean place and orientation over the span
        count = jnp.maximum(jax.ops.segment_sum(mask.astype(ankle.dtype), ids, num_segments=n + 1), 1.0)
        mean = jax.ops.segment_sum(jnp.where(mask[:, None], ankle, 0.0), ids, num_segments=n + 1) / count[:, None]
        aligned = same_hemisphere(foot_rotation, foot_rotation[start])
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
    last_rotation = same_hemisphere(foot_rotation[-1], foot_rotation[0])
    both = R.quat_normalize((1.0 - u) * foot_rotation[0] + u * last_rotation)
    rotation = jnp.where(at_both[:, None], both, rotation)
    position = jnp.where(mask[:, None], position, ankle)
    rotation = jnp.where(mask[:, None], rotation, foot_rotation)
    return position, rotation


def release_room(mask):
    """(T,) frames a span frame has for easing its correction in or out next to a keyframe it is not planted
    at: to the nearer keyframe for a span touching neither (its plant is its own), to the last frame for one
    planted at the start keyframe, to the first for one planted at the target keyframe; unlimited (T) for a
    span over both keyframes and outside spans."""
    n = mask.shape[0]
    t = jnp.arange(n)
    _, first, last = _span_bounds(mask)
    room = jnp.where(last == n - 1, t, jnp.where(first == 0, n - 1 - t, jnp.minimum(t, n - 1 - t)))
    return jnp.where(mask & ~((first == 0) & (last == n - 1)), room, n)


def reachable_spans(mask, reachable):
    """(T,) bool: the span frames kept: a span is cut at its first unreachable frame (the rest let go);
    a span touching the last frame is cut from that end instead (its plant is the target keyframe's)."""
    n = mask.shape[0]
    _, first, last = _span_bounds(mask)
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
    _, first, last = _span_bounds(~mask)
    inner = (first > 0) & (last < n - 1) & (last - first + 1 <= max_gap)
    return mask | (~mask & inner)


def shared_scores(score, stay, ankle, distance: float):
    """Stance scores shared by samples whose feet stay close: (score (S, T), stay (S, T)).

    score, stay: (S, T) one leg's stance scores of S samples of one keyframe pair; ankle: (S, T, 3) its
    ankle. Two samples are linked when their ankles' root-mean-square distance over the frames is at most
    ``distance`` (cm); each sample takes the mean scores of all samples linked to it, directly or through
    others, so a group of nearly equal samples gets one set of spans."""
    num = score.shape[0]
    gap = jnp.sqrt(jnp.mean(jnp.sum((ankle[:, None] - ankle[None]) ** 2, axis=-1), axis=-1))  # (S, S)
    link = (gap <= distance).astype(score.dtype)
    for _ in range(max(num - 1, 1).bit_length()):  # transitive closure: paths of up to 2^k links
        link = jnp.minimum(link @ link, 1.0)
    weight = link / jnp.sum(link, axis=-1, keepdims=True)
    return weight @ score, weight @ stay
