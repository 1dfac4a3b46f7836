"""The two directions' sequences into one transition (paper section 3.1): the linear stitch blend over the
2k overlapping frames, the keyframes pinned exactly, and the FK positions of every sequence.

Sequences include their keyframe at entry 0: fwd_all[t] = frame t, bwd_all[r] = frame L + 1 - r (the
backward one in reversed time). The frame conventions are :mod:`stitchjax.model.rollout`'s.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp

from stitchjax.data import features as F
from stitchjax.model import networks
from stitchjax import rotations as R
from stitchjax import skeleton as skel

__all__ = ["stitched_result", "stitch"]


_FRAME_KEYS = ("rotations", "root", "velocity", "contacts")  # what a generator frame dict holds


def stitched_result(seq, plan, split, start, target, offsets, spec, t_out: int) -> dict:
    """``rollout.rollout``'s result from its scan's outputs ``seq`` and ``plan`` (``rollout.aligning_step``):
    both directions' sequences stitched into t_out frames, the keyframes pinned, FK positions
    (:func:`_with_positions`). split: (h, k, n_forward, n_backward) of ``rollout.schedule``."""
    # Sequences including their keyframe at entry 0: fwd_all[t] = frame t, bwd_all[r] = frame L + 1 - r.
    fwd_all = _stack_first(plan["start"], {key_: seq["forward"][key_] for key_ in _FRAME_KEYS})
    bwd_all = (_stack_first(plan["target"], {key_: seq["backward"][key_] for key_ in _FRAME_KEYS})
               if spec.bidirectional else fwd_all)
    length, (h, k, _, _) = plan["length"], split
    rot, root, contacts = stitch(fwd_all, bwd_all, length, h, k, t_out, spec.bidirectional)
    stitched = _pin_keyframes({"rotations": rot, "root_positions": root, "contacts": contacts}, start, target,
                              length, t_out)
    return _with_positions(stitched, fwd_all, bwd_all, seq, offsets, spec, length, split)


def stitch(fwd_all, bwd_all, length, h, k, num_frames: int, bidirectional: bool = True):
    """Linear stitch blend of the two sequences into ``num_frames`` frames (paper section 3.1).

    fwd_all / bwd_all: frame dicts with a leading axis, fwd_all[t] = frame t, bwd_all[r] = frame L + 1 - r.
    On the 2k overlapping frames h - k + 1 .. h + k the backward weight rises linearly (j + 1) / (2k + 1);
    before them the forward frames, after them the backward ones. Rotations by sign-aligned normalised
    lerp (the lighter-weighted sequence joins the other's hemisphere, so frames outside the overlap stay
    exact), root positions and contacts linearly. Returns (rotations (T, J, 4), root (T, 3), contacts (T, C)).
    """
    t = jnp.arange(num_frames, dtype=jnp.int32)
    from_fwd = _take(fwd_all, t)
    from_bwd = _take(bwd_all, length + 1 - t)
    dtype = from_fwd["root"].dtype
    if bidirectional:
        w = jnp.clip((t - (h - k)).astype(dtype) / (2 * k + 1).astype(dtype), 0.0, 1.0)
    else:
        w = jnp.zeros((num_frames,), dtype)
    q_f, q_b = from_fwd["rotations"], from_bwd["rotations"]
    sign = jnp.where(jnp.sum(q_f * q_b, axis=-1, keepdims=True) < 0, -1.0, 1.0).astype(dtype)
    w3 = w[:, None, None]
    q_f = jnp.where(w3 >= 0.5, sign * q_f, q_f)
    q_b = jnp.where(w3 < 0.5, sign * q_b, q_b)
    rot = R.quat_normalize((1 - w3) * q_f + w3 * q_b)
    root = (1 - w)[:, None] * from_fwd["root"] + w[:, None] * from_bwd["root"]
    contacts = (1 - w)[:, None] * from_fwd["contacts"] + w[:, None] * from_bwd["contacts"]
    return rot, root, contacts


def _pin_keyframes(stitched: dict, start: dict, target: dict, length, t_out: int) -> dict:
    """Frame 0 set to the start keyframe and frames L + 1 .. t_out - 1 to the target, exactly."""
    t = jnp.arange(t_out, dtype=jnp.int32)
    is_start, is_target = (t == 0), (t >= length + 1)

    def pin(x, first, last):
        shape = (t_out,) + (1,) * (x.ndim - 1)
        return jnp.where(is_start.reshape(shape), first[None], jnp.where(is_target.reshape(shape), last[None], x))

    return {"rotations": pin(stitched["rotations"], start["rotations"], target["rotations"]),
            "root_positions": pin(stitched["root_positions"], start["root_position"], target["root_position"]),
            "contacts": pin(stitched["contacts"], start["contacts"], target["contacts"])}


def _with_positions(stitched: dict, fwd_all: dict, bwd_all: dict, seq: dict, offsets, spec, length,
                    split: tuple) -> dict:
    """The rollout's result (see ``rollout.rollout``): FK positions of the forward, backward and stitched
    sequences in one call, the per-direction outputs and the overlap. split = (h, k, n_forward, n_backward)."""
    m = spec
    h, k, n_fwd, n_bwd = split
    n = fwd_all["rotations"].shape[0] - 1
    t_out = stitched["rotations"].shape[0]
    dtype = stitched["rotations"].dtype
    all_rot = jnp.concatenate([fwd_all["rotations"], bwd_all["rotations"], stitched["rotations"]], axis=0)
    all_root = jnp.concatenate([fwd_all["root"], bwd_all["root"], stitched["root_positions"]], axis=0)
    _, all_pos = skel.forward_kinematics(all_rot, F.local_positions(offsets.astype(dtype), all_root),
                                         tuple(spec.parents))
    pos_fwd, pos_bwd, pos_stitched = all_pos[:n + 1], all_pos[n + 1:2 * (n + 1)], all_pos[2 * (n + 1):]
    steps = jnp.arange(n, dtype=jnp.int32)

    def direction(seq_dir, positions, count):
        d = {"rotations": seq_dir["rotations"], "root_positions": seq_dir["root"],
             "velocities": seq_dir["velocity"], "contacts": seq_dir["contacts"],
             "global_positions": positions[1:], "mask": steps < count}
        d.update({key_: seq_dir[key_] for key_ in networks.GAUSSIAN_KEYS})
        return d

    result = {**stitched, "global_positions": pos_stitched,
              "mask": jnp.arange(t_out, dtype=jnp.int32) <= length + 1,
              "forward": direction(seq["forward"], pos_fwd, n_fwd)}
    size = 2 * max(m.stitch_buffer, 1)
    j = jnp.arange(size, dtype=jnp.int32)
    frames = h - k + 1 + j
    if m.bidirectional:
        result["backward"] = direction(seq["backward"], pos_bwd, n_bwd)
        overlap_mask = j < 2 * k
    else:
        overlap_mask = jnp.zeros((size,), bool)
    result["overlap"] = {
        "forward_positions": jnp.take(pos_fwd, frames, axis=0, mode="clip"),
        "backward_positions": jnp.take(pos_bwd, length + 1 - frames, axis=0, mode="clip"),
        "mask": overlap_mask,
    }
    return result


def _take(tree, index):
    return jax.tree.map(lambda x: jnp.take(x, index, axis=0, mode="clip"), tree)


def _stack_first(first, rest):
    return jax.tree.map(lambda a, b: jnp.concatenate([a[None], b], axis=0), first, rest)
