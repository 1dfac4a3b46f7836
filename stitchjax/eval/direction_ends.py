"""Where each generator ends before stitching: the figures behind the paper's case for its bidirectional scheme
(section 5.3, Table 4: "w/o BS" leaves the generated motion off the target frame) and behind its seam.

For each window and sample, on the model's own rollout (z from the prior, as at inference, the paper's
sampling), mean per-joint distances between global joint positions, in metres:

- ``target_step``: from the transition's last generated frame L to the target keyframe L + 1 (the ground
  truth has one too: its own last step). A forward-only model's forward generator makes frame L after L steps
  from the start keyframe and must land it next to the target; a step far larger than the ground truth's is a
  pop at the target, what the bidirectional scheme removes by generating frame L from the target itself.
- ``forward_end_gap``: the forward generator's last generated frame against the frame it has to join: the
  target keyframe for a forward-only model (then the same as ``target_step``: nothing is stitched); for a
  bidirectional model the backward generator's frame at the same time (frame h + k), before the stitch
  blends the two.
- ``backward_end_gap``: the backward generator's last generated frame (h - k + 1) against the forward
  generator's frame at that time; None for a forward-only model.
- ``seam_gap``: the two generators' distance averaged over the 2k frames the stitch blends (the quantity the
  stitching loss, Eq. 3, pulls down, here as a Euclidean distance); None for a forward-only model.

Frames as in :mod:`stitchjax.model.rollout`: 0 the start keyframe, 1..L generated, L + 1 the target keyframe,
h = L // 2, k = min(K, h) with K = ``model.stitch_buffer``. The keyframes are brought into the model's frame as
sampling does (:func:`stitchjax.data.windows.center_and_face` on the pair, faced at the start keyframe); every
figure is a distance between two frames of the same rollout, so it does not depend on that frame.
"""
from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from stitchjax.data.windows import center_and_face
from stitchjax.eval import metrics
from stitchjax.eval.evaluate import START_FRAME
from stitchjax.model import rollout as rollout_lib
from stitchjax.skeleton import forward_kinematics

__all__ = ["GAP_KEYS", "end_gaps", "evaluate_direction_ends"]

GAP_KEYS = ("target_step", "forward_end_gap", "backward_end_gap", "seam_gap")


def _joint_distance(a, b):
    """Mean over joints of the Euclidean distance between positions (..., J, 3) -> (...)."""
    return jnp.mean(jnp.linalg.norm(a - b, axis=-1), axis=-1)


def end_gaps(result: dict, length: int, spec) -> dict:
    """The gaps (:data:`GAP_KEYS`, data units) of one ``rollout.rollout`` result of a transition of ``length``
    (static, >= 2 for a bidirectional model) generated frames; ``spec``: the rollout's ``RolloutSpec``.
    A forward-only model's "backward_end_gap" and "seam_gap" are absent."""
    positions = result["global_positions"]  # (T, J, 3), frame t at row t
    gaps = {"target_step": _joint_distance(positions[length], positions[length + 1])}
    if not spec.bidirectional:
        last = result["forward"]["global_positions"][length - 1]  # row i = frame i + 1
        gaps["forward_end_gap"] = _joint_distance(last, positions[length + 1])
        return gaps
    k = min(spec.stitch_buffer, length // 2)
    if k < 1:
        raise ValueError(f"a bidirectional model's generators meet only from L = 2 frames on, got L = {length}")
    overlap = result["overlap"]  # row j = frame h - k + 1 + j, both directions
    per_frame = _joint_distance(overlap["forward_positions"][:2 * k], overlap["backward_positions"][:2 * k])
    gaps["forward_end_gap"] = per_frame[2 * k - 1]  # frame h + k: the forward generator's last
    gaps["backward_end_gap"] = per_frame[0]  # frame h - k + 1: the backward generator's last
    gaps["seam_gap"] = jnp.mean(per_frame)
    return gaps


@functools.lru_cache(maxsize=16)
def _compiled_gaps(spec, length: int, num_samples: int):
    """jit of (params, phase_params, start, target, offsets, key) -> {gap: (B, S)} for B keyframe pairs in the
    model's frame (``rollout.rollout``'s dicts with a leading B axis, offsets (B, J, 3)); keys as sampling draws
    them (split(key, B), then split(window key, S))."""
    def one(params, phase_params, start, target, offsets, key):
        result = rollout_lib.rollout(params, phase_params, (start, target, offsets), key, spec, length, length)
        return end_gaps(result, length, spec)

    def window(params, phase_params, start, target, offsets, key):
        keys = jax.random.split(key, num_samples)
        return jax.vmap(one, in_axes=(None, None, None, None, None, 0))(params, phase_params, start, target,
                                                                        offsets, keys)

    def batch(params, phase_params, start, target, offsets, key):
        keys = jax.random.split(key, offsets.shape[0])
        return jax.vmap(window, in_axes=(None, None, 0, 0, 0, 0))(params, phase_params, start, target, offsets,
                                                                   keys)

    return jax.jit(batch)


def _keyframes(model, windows, chunk: slice, start: int, target: int) -> tuple:
    """(start, target, offsets) of the windows of ``chunk`` in the model's frame, as ``rollout.rollout`` takes
    them (float32)."""
    rotations = np.asarray(windows.rotations, np.float64)[chunk]
    positions = np.asarray(windows.positions, np.float64)[chunk]
    contacts = np.asarray(windows.contacts, np.float64)[chunk]
    pair_r = np.stack([rotations[:, start], rotations[:, target]], axis=1)  # (b, 2, J, 4)
    pair_p = np.stack([positions[:, start], positions[:, target]], axis=1)
    aligned_r, aligned_p = center_and_face(pair_r, pair_p, model.parents, frame=0, forward_axis=model.forward_axis)

    def keyframe(i, frame):
        return {"rotations": jnp.asarray(aligned_r[:, i], jnp.float32),
                "root_position": jnp.asarray(aligned_p[:, i, 0], jnp.float32),
                "contacts": jnp.asarray(contacts[:, frame], jnp.float32)}

    return keyframe(0, start), keyframe(1, target), jnp.asarray(positions[:, start], jnp.float32)


def evaluate_direction_ends(model, windows, lengths, samples: int = 10, start: int = START_FRAME, seed: int = 0,
                            batch_size: int = 256, metres_per_unit: float = metrics.LAFAN1_METRES_PER_UNIT) -> dict:
    """The gaps of :func:`end_gaps` of a trained model on evaluation windows, averaged over windows and samples.

    model: a ``trained_model.Model``; windows: (N, T, J, ...) windows (``data.windows.Windows``), scored as the
    protocol does: start keyframe ``start``, target keyframe start + L + 1. samples: rollouts per window (the
    paper's sampling). Returns {"n_windows", "samples", "lengths": {"L": {"model": {gap: metres, or None when
    the model has no backward generator}, "ground_truth": {"target_step": metres}}}, "units"}.
    """
    num_windows, num_frames = np.shape(windows.rotations)[:2]
    if tuple(windows.skeleton.parents) != model.parents:
        raise ValueError(f"the windows' skeleton ({windows.skeleton.num_joints} joints) is not the model's "
                         f"({model.num_joints} joints): evaluate a model on its own dataset")
    _, truth = forward_kinematics(np.asarray(windows.rotations, np.float64), np.asarray(windows.positions, np.float64),
                                  model.parents)
    chunks = [slice(i, min(i + batch_size, num_windows)) for i in range(0, num_windows, batch_size)]
    results = {}
    for length in lengths:
        target = start + length + 1
        if target >= num_frames:
            raise ValueError(f"transition length {length} from frame {start} needs windows of at least {target + 1} "
                             f"frames; these have {num_frames}")
        compiled = _compiled_gaps(model.rollout_spec, int(length), int(samples))
        sums = dict.fromkeys(GAP_KEYS, 0.0)
        present = set()
        for index, chunk in enumerate(chunks):
            start_kf, target_kf, offsets = _keyframes(model, windows, chunk, start, target)
            key = jax.random.PRNGKey(int(seed) * 1_000_003 + int(length) * 10_007 + index)
            gaps = jax.device_get(compiled(model.params, model.phase_params, start_kf, target_kf, offsets, key))
            for name, value in gaps.items():  # (b, S): the windows' sums of their mean over samples
                sums[name] += float(np.mean(np.asarray(value, np.float64), axis=1).sum())
                present.add(name)
        model_entry = {name: (sums[name] / num_windows * metres_per_unit if name in present else None)
                       for name in GAP_KEYS}
        truth_step = np.linalg.norm(truth[:, target - 1] - truth[:, target], axis=-1).mean(axis=-1)
        results[str(length)] = {"model": model_entry,
                                "ground_truth": {"target_step": float(truth_step.mean()) * metres_per_unit}}
    return {"n_windows": int(num_windows), "samples": int(samples), "lengths": results,
            "units": {name: "m (mean per-joint distance)" for name in GAP_KEYS}}
