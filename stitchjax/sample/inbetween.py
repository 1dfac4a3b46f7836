"""Sampling with a trained model: two keyframes in, N diverse transitions out (latent-pair search included).

    model = trained_model.load_model("runs/quickstart")         # a training run (or a checkpoint folder)
    motion = bvh.load("obstacles1_subject5.bvh")
    samples = inbetween(model, motion[100], motion[140], length=39, num_samples=8, seed=0)
    # -> 8 Motions of 41 frames: motion[100], 39 generated frames, motion[140] (same skeleton and fps)

Whole takes from any file (units, up axis, frame rate, placement) are ``stitchjax.sample.takes``; the model as an
evaluation method is ``stitchjax.eval.evaluate.model_method``; rollouts with given latent noise are
``stitchjax.sample.latent``.

Pipeline of one request (all samples of all requests in ONE jitted, vmapped rollout):

1. Keyframes into the model's frame, as the training windows were made (``windows.center_and_face``):
   the root's x and z are centred on the midpoint of the two keyframes' roots (training centres a
   window on its mean root x/z; the midpoint is the mean of a straight path) and the whole pair is
   turned about +Y so the *start* keyframe faces +X (training faces +X at frame 9, the last context
   frame of the benchmark, which is the start keyframe in the evaluation protocol). Only the root's
   local transform changes.
2. ``rollout.rollout`` vmapped over windows x samples, compiled once per (length, candidates) and
   cached; transition length L is static here (``max_length = L``), so nothing past L is computed.
3. Latent-pair search (``search=M``): M x N latent pairs per window are rolled out together and the N
   with the lowest stitching loss (mean L1 distance between the forward and backward generators' FK
   joint positions over the overlapping frames) are kept, in increasing order of that loss.
4. Back to the input's frame (inverse turn, then the centre added back), sign-continuous quaternions,
   and the two keyframes overwritten with the input's own local transforms, so the first and last
   frames equal the keyframes exactly (bit for bit in local transforms, hence in global positions).

Units: positions in the input's units (LAFAN1: cm); ``stitch_loss`` in the same units.
Foot contacts of the keyframes (part of the model's character state) are measured like the training
labels (squared displacement to a neighbouring frame < ``windows.CONTACT_THRESHOLD``) when the request
carries a neighbouring frame, else guessed from the feet's heights (see :func:`keyframe_contacts`).
"""
from __future__ import annotations

import functools
import warnings
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from stitchjax.model import losses
from stitchjax.model import rollout as rollout_lib
from stitchjax.model.noise import NoiseSpec
from stitchjax import rotations as R
from stitchjax import skeleton as skeleton_lib
from stitchjax.data.bvh import Motion
from stitchjax.sample import footlock
from stitchjax.skeleton import forward_kinematics
from stitchjax.sample.sampling import Sampling
from stitchjax.sample.trained_model import InbetweenError, Model, model_or_pretrained
from stitchjax.data.windows import CONTACT_THRESHOLD, center_and_face, facing_rotation, foot_contacts

__all__ = [
    "InbetweenError", "Keyframes", "Sampling", "inbetween", "resolve_sampling", "sample_transitions",
    "transitions_in_frame", "keyframe_contacts", "stitch_losses", "check_length",
]

CONTACT_HEIGHT = 4.0  # file units (cm): single-frame contact guess, see keyframe_contacts


# ------------------------------------------------------------------------------------ model-frame core


def stitch_losses(result: dict) -> jax.Array:
    """Stitching loss (``losses.stitching_loss``) per rollout: mean over the overlapping frames of the mean
    absolute difference (over joints and x, y, z) between the forward and backward FK positions; (...,),
    file units. 0 when the transition is too short to overlap (L < 2) or the model is forward-only."""
    overlap = result["overlap"]
    return losses.stitching_loss(overlap["forward_positions"], overlap["backward_positions"], overlap["mask"],
                                 reduction="mean", per_motion=True)


@functools.lru_cache(maxsize=32)
def _compiled_sampler(spec, length: int, num_candidates: int, noise_scale: float = 1.0,
                      noise_correlation: float = 0.0, noise_ramp_steps: int = 0):
    """jit of (params, phase_params, start, target, offsets, key) -> model-frame transitions.

    spec: the model's ``rollout.RolloutSpec``. z is drawn from the prior p (the ground truth is never an
    input); noise_scale multiplies its noise, noise_correlation correlates it over frames
    (``noise.correlated_noise``), noise_ramp_steps ramps it up from each keyframe (``noise.noise_ramp``).

    start / target: dicts of (B, ...) keyframes as ``rollout.rollout`` wants them; offsets (B, J, 3).
    Every window gets ``num_candidates`` rollouts (keys: split(key, B), then split(window key,
    num_candidates)), so the first candidates do not depend on how many are drawn. Compiled once per
    (spec, length, num_candidates) and batch size; the latent-pair search picks among the candidates
    outside, so plain sampling and search share compilations.
    """
    def one(params, phase_params, start, target, offsets, key):
        out = rollout_lib.rollout(params, phase_params, (start, target, offsets), key, spec, length, length,
                                  NoiseSpec(noise_scale, noise_correlation, noise_ramp_steps))
        return {"rotations": out["rotations"], "root_positions": out["root_positions"],
                "contacts": out["contacts"], "global_positions": out["global_positions"],
                "stitch_loss": stitch_losses(out)}

    def window(params, phase_params, start, target, offsets, key):
        keys = jax.random.split(key, num_candidates)
        return jax.vmap(one, in_axes=(None, None, None, None, None, 0))(
            params, phase_params, start, target, offsets, keys)

    def batch(params, phase_params, start, target, offsets, key):
        keys = jax.random.split(key, offsets.shape[0])
        return jax.vmap(window, in_axes=(None, None, 0, 0, 0, 0))(params, phase_params, start, target, offsets,
                                                                   keys)

    return jax.jit(batch)


def _as_key(seed):
    if isinstance(seed, (int, np.integer)):
        return jax.random.PRNGKey(int(seed))
    return seed


def check_request(model: Model, length: int, num_samples: int, search: int, warn: bool = False):
    if int(length) != length or length < 1:
        raise InbetweenError(f"transition length must be a whole number of frames >= 1, got {length}")
    if int(num_samples) != num_samples or num_samples < 1:
        raise InbetweenError(f"num_samples must be >= 1, got {num_samples}")
    if int(search) != search or search < 0:
        raise InbetweenError(f"search must be 0 (no search) or the number of latent pairs tried per "
                             f"sample (>= 1), got {search}")
    if warn and length > model.trained_max_length:
        warnings.warn(f"transition length {length} is longer than the {model.trained_max_length} frames "
                      f"the model was trained on: the result is extrapolation", stacklevel=3)


def sample_transitions(model: Model, start: dict, target: dict, offsets, length: int, num_samples: int,
                       seed=0, sampling: Sampling | None = None) -> dict:
    """Transitions in the model's frame for B keyframe pairs (no alignment, no keyframe overwrite).

    start, target: {"rotations" (B, J, 4), "root_position" (B, 3), "contacts" (B, C)}, already centred
      and facing-aligned; offsets: (B, J, 3) bone offsets (root row ignored).
    Returns numpy float32 {"rotations" (B, S, L+2, J, 4), "root_positions" (B, S, L+2, 3), "contacts"
      (B, S, L+2, C), "global_positions" (B, S, L+2, J, 3), "stitch_loss" (B, S)}, S = num_samples.
    sampling: the noise and the search (default :meth:`Sampling.paper`; its foot locking is not applied here).
    With ``search=M`` the M x S candidates of a window are drawn with the same keys as plain sampling
    of M x S samples, and the S with the lowest stitching loss are returned in increasing order.
    """
    sampling = Sampling.paper() if sampling is None else sampling
    check_request(model, length, num_samples, sampling.search, warn=True)
    candidates = num_samples * max(sampling.search, 1)
    fn = _compiled_sampler(model.rollout_spec, int(length), int(candidates), sampling.noise_scale,
                           sampling.noise_correlation, sampling.noise_ramp_steps)
    as32 = functools.partial(jnp.asarray, dtype=jnp.float32)
    out = fn(model.params, model.phase_params, jax.tree.map(as32, start), jax.tree.map(as32, target),
             as32(offsets), _as_key(seed))
    out = jax.tree.map(np.asarray, out)
    if candidates > num_samples:  # latent-pair search: the lowest stitching losses, increasing
        best = np.argsort(out["stitch_loss"], axis=1, kind="stable")[:, :num_samples]  # (B, S)
        out = {k: np.take_along_axis(v, best.reshape(best.shape + (1,) * (v.ndim - 2)), axis=1)
               for k, v in out.items()}
    return out


# ----------------------------------------------------------------------------- alignment and contacts


def align_keyframes(start_rotations, start_positions, target_rotations, target_positions, parents,
               forward_axis=(0.0, 1.0, 0.0)):
    """Keyframes (B, J, *) in the model's frame plus the (turn (B, 4), centre (B, 3)) that undo it.
    The start keyframe's root is faced along +X by its local ``forward_axis`` (the model's, as in training)."""
    rot = np.stack([start_rotations, target_rotations], axis=1)  # (B, 2, J, 4): a 2-frame window
    pos = np.stack([start_positions, target_positions], axis=1)
    aligned_rot, aligned_pos = center_and_face(rot, pos, parents, frame=0, forward_axis=forward_axis)
    turn = facing_rotation(np.asarray(start_rotations)[:, 0], forward_axis)  # the turn center_and_face applied
    centre = 0.5 * (pos[:, 0, 0] + pos[:, 1, 0])
    centre[:, 1] = 0.0
    return aligned_rot, aligned_pos, turn, centre


def keyframe_contacts(global_positions, feet, neighbour=None, threshold: float = CONTACT_THRESHOLD,
                      up_axis: int = 1):
    """Foot contacts (C,) of one keyframe, float 0./1.

    global_positions: (J, 3) the keyframe's FK positions; neighbour: (J, 3) an adjacent frame's, when
    known: then as the training labels (``windows.foot_contacts``): squared displacement < threshold.
    Without a neighbour: a foot joint counts as in contact when it is within CONTACT_HEIGHT (4 cm)
    of the lowest foot joint of the frame (a guess: it cannot tell a standing foot from a sliding one).
    """
    p = np.asarray(global_positions, np.float64)
    if neighbour is not None:
        pair = np.stack([p, np.asarray(neighbour, np.float64)])
        return foot_contacts(pair, feet, threshold)[0]
    heights = p[list(feet), up_axis]
    return (heights - heights.min() < CONTACT_HEIGHT).astype(np.float64)


def check_skeleton(model: Model, skeleton):
    if tuple(skeleton.parents) != model.parents:
        raise InbetweenError(
            f"skeleton mismatch: the motion has {skeleton.num_joints} joints with parents "
            f"{tuple(skeleton.parents)}, the model ({model.source}) was trained on {model.num_joints} joints "
            f"with parents {model.parents}; retarget the motion to the training skeleton")
    if model.joint_names is not None and tuple(skeleton.names) != tuple(model.joint_names):
        diff = [f"{i}: {a!r} vs {b!r}" for i, (a, b) in enumerate(zip(skeleton.names, model.joint_names)) if a != b]
        raise InbetweenError(f"skeleton mismatch: joint names differ from the model's ({'; '.join(diff[:4])}"
                             f"{' ...' if len(diff) > 4 else ''}); rename or reorder the joints")


class Keyframes(NamedTuple):
    """B keyframes in any world frame: local rotations (B, J, 4), local positions (B, J, 3) (root = world
    position, others = bone offsets) and foot contacts (B, C)."""

    rotations: np.ndarray
    positions: np.ndarray
    contacts: np.ndarray


def transitions_in_frame(model: Model, start: Keyframes, target: Keyframes, length: int, num_samples: int, seed=0,
                         sampling: Sampling | None = None, foot_lock_counts: dict | None = None):
    """Transitions between B keyframe pairs given in any world frame, returned in that frame.

    start, target: :class:`Keyframes` (or (rotations, positions, contacts) tuples). Returns (rotations
    (B, S, L+2, J, 4), positions (B, S, L+2, J, 3), stitch_loss (B, S)) float64: frame 0 and L+1 are the
    input keyframes exactly; non-root local positions are the start keyframe's bone offsets.
    sampling: noise, search and foot locking (default :meth:`Sampling.paper`: no foot locking, the transitions
    as the model made them); with foot locking the feet are planted with the predicted contacts
    (:func:`stitchjax.sample.footlock.lock_feet`, in the input's frame, +Y up).
    foot_lock_counts: a dict to which the pass adds "leg_frames", "planted", "changed" and "lifted" counts.
    """
    sampling = Sampling.paper() if sampling is None else sampling
    start, target = Keyframes(*start), Keyframes(*target)
    sr, sp = np.asarray(start.rotations, np.float64), np.asarray(start.positions, np.float64)
    tr, tp = np.asarray(target.rotations, np.float64), np.asarray(target.positions, np.float64)
    parents = model.parents
    if sr.ndim != 3 or sr.shape[1:] != (len(parents), 4) or sp.shape != sr.shape[:2] + (3,) \
            or tr.shape != sr.shape or tp.shape != sp.shape:
        raise InbetweenError(f"keyframes must be rotations (B, {len(parents)}, 4) and positions (B, "
                             f"{len(parents)}, 3); got {sr.shape}, {sp.shape}, {tr.shape}, {tp.shape}")
    aligned_rot, aligned_pos, turn, centre = align_keyframes(sr, sp, tr, tp, parents, model.forward_axis)
    start_state = {"rotations": aligned_rot[:, 0], "root_position": aligned_pos[:, 0, 0],
                   "contacts": np.asarray(start.contacts, np.float64)}
    target_state = {"rotations": aligned_rot[:, 1], "root_position": aligned_pos[:, 1, 0],
                    "contacts": np.asarray(target.contacts, np.float64)}
    out = sample_transitions(model, start_state, target_state, sp, length, num_samples, seed, sampling)

    rotations = out["rotations"].astype(np.float64)  # (B, S, T, J, 4)
    roots = out["root_positions"].astype(np.float64)  # (B, S, T, 3)
    back = R.quat_conjugate(turn)[:, None, None, :]  # (B, 1, 1, 4)
    rotations[..., 0, :] = R.quat_mul(np.broadcast_to(back, rotations[..., 0, :].shape), rotations[..., 0, :])
    roots = R.quat_rotate(np.broadcast_to(back, roots.shape[:-1] + (4,)), roots) + centre[:, None, None, :]
    rotations = R.quat_normalize(rotations)
    rotations[:, :, 0] = sr[:, None]
    rotations = R.quat_continuity(rotations, axis=2)
    rotations[:, :, 0] = sr[:, None]
    rotations[:, :, -1] = tr[:, None]
    positions = np.broadcast_to(sp[:, None, None], rotations.shape[:-1] + (3,)).copy()
    positions[..., 0, :] = roots
    positions[:, :, 0] = sp[:, None]
    positions[:, :, -1] = tp[:, None]
    if sampling.locks_feet:
        rotations = _locked(model, rotations, positions, out["contacts"], sampling.foot_lock_config,
                            foot_lock_counts)
    return rotations, positions, out["stitch_loss"].astype(np.float64)


def _locked(model: Model, rotations, positions, contacts, lock: footlock.FootLockConfig, counts: dict | None):
    """``footlock.lock_transitions`` of (B, S, T, ...) transitions on the model's skeleton with ``lock``; the
    counts of planted, changed and lifted leg-frames (generated frames only) added to ``counts``."""
    names = model.joint_names or tuple(f"joint{j}" for j in range(model.num_joints))
    # the structure only (a static argument of the jitted pass): each transition's own offsets are passed
    skeleton = skeleton_lib.Skeleton(names, model.parents, np.zeros((model.num_joints, 3)))
    locked, _, stats = footlock.lock_transitions(rotations, positions, contacts, skeleton, model.feet, lock,
                                                 sample_axis=1)
    if counts is not None:
        inner = stats["planted"][..., 1:-1, :]
        counts["leg_frames"] = counts.get("leg_frames", 0) + int(inner.size)
        for key in ("planted", "changed", "lifted"):
            counts[key] = counts.get(key, 0) + int(stats[key][..., 1:-1, :].sum())
    return locked


# ------------------------------------------------------------------------------------------ Motion API


def _keyframe(motion: Motion, which: str):
    if not isinstance(motion, Motion):
        raise InbetweenError(f"{which} must be a stitchjax.data.bvh.Motion (e.g. motion[frame]), got "
                             f"{type(motion).__name__}")
    if motion.num_frames < 1:
        raise InbetweenError(f"{which} has no frames")


def resolve_sampling(model: Model, sampling: Sampling | None = None, **overrides) -> Sampling:
    """``sampling`` (default ``model.sampling``, the model's default) with ``overrides`` (Sampling field ->
    value; None keeps the field): the keyword form of the public sampling functions."""
    return (model.sampling if sampling is None else sampling).replace(**overrides)


def inbetween(model: Model, start: Motion, target: Motion, length: int, num_samples: int = 1, seed=0, *,
              sampling: Sampling | None = None, start_contacts=None, target_contacts=None,
              allow_extrapolation: bool = False, **overrides) -> list:
    """Generate ``num_samples`` transitions of ``length`` frames from ``start`` to ``target``.

    model: a :class:`Model`, or None for the release model (``stitchjax.pretrained()``).
    start: Motion whose LAST frame is the start keyframe (earlier frames, if any, are context: the one
      before the keyframe measures its foot contacts). target: Motion whose FIRST frame is the target
      keyframe (a following frame, if any, measures its contacts). Both on the model's skeleton.
    length: generated frames L >= 1. seed: int or jax PRNG key.
    sampling: a :class:`Sampling` (noise, latent-pair search, foot locking); default ``model.sampling``, the
      model's default (the release model's noise is chosen on the validation split to spread the samples
      visibly; a training run's is the paper's, ``model.paper_sampling``; feet locked).
    overrides: Sampling fields given as keywords on top of it (None keeps the field): noise_scale (factor on
      the latent noise; 0: one motion, the prior's mean), noise_correlation (from one frame to the next, in
      [0, 1]; ``noise.correlated_noise``), noise_ramp_steps (frames over which the noise rises from 0 next to
      the keyframes; ``noise.noise_ramp``), search (0 = plain sampling; M >= 1 = try M latent pairs per wanted
      sample and keep the num_samples with the lowest stitching loss), foot_lock (plant the feet where the model
      predicts contact, on the keyframes' ground, :mod:`stitchjax.sample.footlock`: True, False for the
      transitions as the model made them, or a ``FootLockConfig``; the keyframes stay exact either way).
    start_contacts / target_contacts: (C,) foot contacts to use instead of measuring them.
    allow_extrapolation: a length beyond ``model.trained_max_length`` is an InbetweenError unless True.
    The keyframes must be on the model's skeleton, frame rate and units (see
    :func:`stitchjax.sample.takes.inbetween_takes`, which brings takes from anywhere onto them).
    Returns a list of ``num_samples`` Motions of L + 2 frames (start keyframe, L generated frames,
    target keyframe; same skeleton, fps and channel layout as ``start``), in sampling order, or in
    increasing stitching loss with ``search``. Each carries no extra attributes; use
    :func:`transitions_in_frame` for the stitching losses.
    """
    model = model_or_pretrained(model)
    sampling = resolve_sampling(model, sampling, **overrides)
    _keyframe(start, "start")
    _keyframe(target, "target")
    check_skeleton(model, start.skeleton)
    check_skeleton(model, target.skeleton)
    check_request(model, length, num_samples, sampling.search)
    check_length(model, length, allow_extrapolation)
    parents = model.parents
    start_global = forward_kinematics(start.rotations[-2:], start.positions[-2:], parents)[1]
    target_global = forward_kinematics(target.rotations[:2], target.positions[:2], parents)[1]
    if start_contacts is None:
        start_contacts = keyframe_contacts(start_global[-1], model.feet,
                                           start_global[-2] if start.num_frames > 1 else None)
    if target_contacts is None:
        target_contacts = keyframe_contacts(target_global[0], model.feet,
                                            target_global[1] if target.num_frames > 1 else None)
    rotations, positions, _ = transitions_in_frame(
        model, Keyframes(start.rotations[-1:], start.positions[-1:], np.asarray(start_contacts)[None]),
        Keyframes(target.rotations[:1], target.positions[:1], np.asarray(target_contacts)[None]), length,
        num_samples, seed, sampling)
    return [start.with_frames(rotations[0, s], positions[0, s]) for s in range(num_samples)]


def check_length(model: Model, length: int, allow_extrapolation: bool = False) -> None:
    """Refuse a transition longer than the model was trained on (``Model.trained_max_length``), naming both
    lengths, unless ``allow_extrapolation`` (then ``sample_transitions`` still warns)."""
    if not allow_extrapolation and int(length) > model.trained_max_length:
        raise InbetweenError(
            f"transition length {int(length)} is longer than the {model.trained_max_length} frames the model was "
            f"trained on (train.max_length): past that the motion is extrapolated and drifts; ask for at most "
            f"{model.trained_max_length} frames (keyframes closer together, or --length), or allow it with "
            f"allow_extrapolation=True (bin/inbetween --allow-extrapolation)")
