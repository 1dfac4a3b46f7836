"""In-betweening with a trained model: two keyframes in, N diverse transitions out.

    model = load_model("runs/quickstart")                       # a training run (or a checkpoint folder)
    motion = bvh.load("obstacles1_subject5.bvh")
    samples = inbetween(model, motion[100], motion[140], length=39, num_samples=8, seed=0)
    # -> 8 Motions of 41 frames: motion[100], 39 generated frames, motion[140] (same skeleton and fps)
    clips = inbetween_clip(model, motion, 100, 140, num_samples=8)   # whole takes, frames 101..139 replaced

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

import dataclasses
import functools
import logging
import os
import pathlib
import warnings
from typing import Any, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from stitchjax import bvh_folder, conform, losses
from stitchjax import rotations as R
from stitchjax.bvh import Motion
from stitchjax.skeleton import LAFAN1_FEET, forward_kinematics
from stitchjax.windows import CONTACT_THRESHOLD, center_and_face, facing_rotation, foot_contacts

__all__ = [
    "InbetweenError", "Model", "load_model", "random_model", "with_matmul_dtype", "inbetween", "inbetween_clip",
    "sample_transitions", "transitions_in_frame", "keyframe_contacts", "model_method",
    "evaluation_method", "stitch_losses", "noise_shape", "window_keyframes", "rollout_details",
    "inbetween_takes", "conform_take", "check_length", "to_model_frame", "from_model_frame",
]

CONTACT_HEIGHT = 4.0  # file units (cm): single-frame contact guess, see keyframe_contacts


class InbetweenError(ValueError):
    """A request the model cannot serve (bad length, skeleton mismatch, frames out of range, ...)."""


# ---------------------------------------------------------------------------------------------- model


@dataclasses.dataclass(frozen=True, eq=False)
class Model:
    """A trained (or freshly initialised) in-betweening model, ready for inference.

    Attributes:
      config: the experiment ``Config`` it was trained with (static, hashable).
      params: {"forward", "backward"} generator params (discriminators are not needed).
      phase_params: the frozen phase network's params (or None without phase modulation).
      joint_names: joint names of the training skeleton (checked against requests), or None.
      feet: joint indices of the contact channels (LAFAN1: LeftFoot, LeftToe, RightFoot, RightToe).
      stats: training statistics as numpy arrays ("mean", "std" (J*3,), "offsets" (J, 3)), may be {}.
      source: where it came from ("<workdir> step <n>" or "random init (seed s)").
      up_axis: (3,) the training files' up axis (takes are turned from it to +Y for the model, and back).
      forward_axis: (3,) the root's local forward axis the training windows were faced by (LAFAN1: +Y).
      unit_scale: centimetres per unit of the training files (takes are scaled by it, and back).
    The last three come from the checkpoint (``extras["skeleton"]``, :func:`stitchjax.bvh_folder.skeleton_facts`).
    """

    config: Any
    params: dict
    phase_params: Any
    joint_names: tuple | None
    feet: tuple
    stats: dict
    source: str
    up_axis: tuple = (0.0, 1.0, 0.0)
    forward_axis: tuple = (0.0, 1.0, 0.0)
    unit_scale: float = 1.0

    @property
    def parents(self) -> tuple:
        return tuple(int(p) for p in self.config.data.parents)

    @property
    def num_joints(self) -> int:
        return len(self.parents)

    @property
    def feet_names(self) -> tuple | None:
        """Names of the contact joints (None when the joint names are unknown)."""
        return None if self.joint_names is None else tuple(self.joint_names[j] for j in self.feet)

    @property
    def trained_max_length(self) -> int:
        """Longest transition seen in training (longer ones work but are extrapolation)."""
        return int(self.config.train.max_length)

    def __repr__(self):
        return f"Model({self.config.name!r}, {self.num_joints} joints, {self.source})"


def _default_facts(config) -> dict:
    """The skeleton facts of a checkpoint saved without them (before they were saved): those of its
    dataset (LAFAN1 / H36M), or for a BVH folder what its config declares (joint names unknown)."""
    data = config.data
    facts = bvh_folder.skeleton_facts(None, data)
    if facts is not None and len(facts["joint_names"]) == len(data.parents):
        return facts
    return {"joint_names": None, "feet": list(LAFAN1_FEET), "up_axis": getattr(data, "up_axis", "") or "+y",
            "forward_axis": getattr(data, "forward_axis", "") or "+y",
            "unit_scale": float(getattr(data, "unit_scale", 0.0)) or 1.0}


def _facts_fields(config, facts: dict | None) -> dict:
    """Model fields (joint_names, feet, up_axis, forward_axis, unit_scale) from saved facts, else defaults."""
    defaults = _default_facts(config)
    facts = {**defaults, **{k: v for k, v in (facts or {}).items() if v not in (None, "", [])}}
    names = tuple(facts["joint_names"]) if facts["joint_names"] else None
    feet = tuple(int(j) for j in facts["feet"])
    if names is not None and facts.get("feet_names") and [names[j] for j in feet] != list(facts["feet_names"]):
        raise InbetweenError(f"checkpoint skeleton facts disagree: feet {feet} are {[names[j] for j in feet]}, "
                             f"saved as {list(facts['feet_names'])}; retrain or fix extras/skeleton")
    try:
        up, forward = conform.parse_axis(facts["up_axis"]), conform.parse_axis(facts["forward_axis"])
    except conform.ConformError as error:
        raise InbetweenError(f"checkpoint skeleton facts: {error}") from None
    return {"joint_names": names, "feet": feet, "up_axis": tuple(float(x) for x in up),
            "forward_axis": tuple(float(x) for x in forward), "unit_scale": float(facts["unit_scale"])}


def _resolve_checkpoint(path) -> tuple[pathlib.Path, int | None]:
    """(training workdir, step or None) from a workdir, its checkpoints/ folder or one step folder."""
    path = pathlib.Path(os.fspath(path)).expanduser().resolve()
    if not path.exists():
        raise FileNotFoundError(f"checkpoint {path} does not exist: pass a training run folder "
                                f"(bin/train --workdir DIR) or one of its checkpoints/<step> folders")
    if (path / "checkpoints").is_dir():
        return path, None
    if path.name == "checkpoints":
        return path.parent, None
    if path.name.isdigit() and path.parent.name == "checkpoints":
        return path.parent.parent, int(path.name)
    raise FileNotFoundError(f"{path} holds no checkpoints (expected {path / 'checkpoints'}/<step>/): pass "
                            f"the folder given to bin/train --workdir")


def _readable_config(workdir, step):
    """The saved config JSON of checkpoint ``step``, or (step None) of the newest one whose config reads."""
    from stitchjax import checkpoints

    if step is not None:
        return checkpoints.read_config_json(workdir, step)
    steps = checkpoints.saved_steps(workdir)
    for candidate in reversed(steps[1:]):
        try:
            return checkpoints.read_config_json(workdir, candidate)
        except (OSError, ValueError):
            continue
    return checkpoints.read_config_json(workdir, steps[0] if steps else None)


def load_model(checkpoint, step: int | None = None) -> Model:
    """Load a model from a training run folder (its latest checkpoint, or ``step``).

    ``checkpoint`` may be the run folder (``bin/train --workdir``), its ``checkpoints/`` folder or one
    ``checkpoints/<step>`` folder. The config saved beside the state says how to build the networks.
    Raises FileNotFoundError (``checkpoints.CheckpointError``) when there is no checkpoint.
    """
    from stitchjax import checkpoints
    from stitchjax import config as config_lib
    from stitchjax import train

    workdir, folder_step = _resolve_checkpoint(checkpoint)
    step = folder_step if step is None else int(step)
    absl_logger = logging.getLogger("absl")
    level = absl_logger.level
    absl_logger.setLevel(logging.ERROR)  # orbax warns that a read-only directory is read only
    try:
        config = config_lib.from_dict(_readable_config(workdir, step))
        manager = checkpoints.open_manager(workdir, read_only=True)
        try:
            abstract = train.abstract_train_state(config)
            if step is None:  # the newest checkpoint that restores, naming any broken one on stderr
                state, _, extras, step = checkpoints.restore_newest_good(manager, abstract)
            else:
                try:
                    state, _, extras = checkpoints.restore(manager, abstract, step)
                except Exception as error:  # orbax / TensorStore: many types for a broken folder
                    raise checkpoints.CheckpointError(
                        f"checkpoint {checkpoints.checkpoint_dir(workdir) / str(step)} cannot be restored "
                        f"({checkpoints._short(error)}); pass the run folder to use the newest one that "
                        f"restores (steps saved: {checkpoints.saved_steps(workdir)})") from None
        finally:
            manager.close()
    finally:
        absl_logger.setLevel(level)
    stats = {k: np.asarray(v, np.float64) for k, v in (extras.get("stats") or {}).items()}
    fields = _facts_fields(config, extras.get("skeleton"))
    params = {"forward": state.params["forward"], "backward": state.params["backward"]}
    phase_params = state.phase_params if config.model.phase_modulation else None
    return Model(config, params, phase_params, stats=stats, source=f"{workdir} step {int(step)}", **fields)


def random_model(config, seed: int = 0, joint_names: Sequence[str] | None = None) -> Model:
    """A freshly initialised model (untrained): for timing, tests and shape checks."""
    from stitchjax import networks, phase, features

    key = jax.random.PRNGKey(seed)
    params = jax.jit(lambda k: networks.init_params(config, k))(key)
    phase_params = None
    if config.model.phase_modulation:
        phase_params = phase.init_phase_params(jax.random.fold_in(key, 1), features.state_dim(config), config)
    fields = _facts_fields(config, None)
    if joint_names is not None:
        fields["joint_names"] = tuple(joint_names)
    return Model(config, {"forward": params["forward"], "backward": params["backward"]}, phase_params,
                 stats={}, source=f"random init (seed {seed})", **fields)


def with_matmul_dtype(model: Model, dtype: str) -> Model:
    """The same model computing its matmuls on ``dtype`` operands ("float32" or "bfloat16", float32
    accumulation either way; see ``networks.matmul``). Parameters are unchanged, so a float32-trained
    model can sample in bfloat16: ~1.8x faster on CPUs with AMX / AVX512-BF16 (benchmarks/README.md); with
    the same seed, joint positions move by ~0.2 cm on average (up to ~1 cm mid-transition)."""
    from stitchjax import config as config_lib

    try:
        config = config_lib.apply_overrides(model.config, [f"model.matmul_dtype={dtype}"])
    except config_lib.ConfigError as err:
        raise InbetweenError(str(err)) from None
    return dataclasses.replace(model, config=config)


# ------------------------------------------------------------------------------------ model-frame core


def stitch_losses(result: dict) -> jax.Array:
    """Stitching loss (``losses.stitching_loss``) per rollout: mean over the overlapping frames of the mean
    absolute difference (over joints and x, y, z) between the forward and backward FK positions; (...,),
    file units. 0 when the transition is too short to overlap (L < 2) or the model is forward-only."""
    overlap = result["overlap"]
    return losses.stitching_loss(overlap["forward_positions"], overlap["backward_positions"], overlap["mask"],
                                 reduction="mean", per_motion=True)


@functools.lru_cache(maxsize=32)
def _compiled_sampler(config, length: int, num_candidates: int, noise_scale: float = 1.0):
    """jit of (params, phase_params, start, target, offsets, key) -> model-frame transitions.

    z is drawn from the prior p (the ground truth is never an input); noise_scale multiplies its noise.

    start / target: dicts of (B, ...) keyframes as ``rollout.rollout`` wants them; offsets (B, J, 3).
    Every window gets ``num_candidates`` rollouts (keys: split(key, B), then split(window key,
    num_candidates)), so the first candidates do not depend on how many are drawn. Compiled once per
    (config, length, num_candidates) and batch size; the latent-pair search picks among the candidates
    outside, so plain sampling and search share compilations.
    """
    from stitchjax import rollout as rollout_lib

    def one(params, phase_params, start, target, offsets, key):
        out = rollout_lib.rollout(params, phase_params, start, target, offsets, key, config, length, length,
                                  noise_scale=noise_scale)
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


def _check_request(model: Model, length: int, num_samples: int, search: int, warn: bool = False):
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
                       seed=0, search: int = 0, noise_scale: float = 1.0) -> dict:
    """Transitions in the model's frame for B keyframe pairs (no alignment, no keyframe overwrite).

    start, target: {"rotations" (B, J, 4), "root_position" (B, 3), "contacts" (B, C)}, already centred
      and facing-aligned; offsets: (B, J, 3) bone offsets (root row ignored).
    Returns numpy float32 {"rotations" (B, S, L+2, J, 4), "root_positions" (B, S, L+2, 3), "contacts"
      (B, S, L+2, C), "global_positions" (B, S, L+2, J, 3), "stitch_loss" (B, S)}, S = num_samples.
    With ``search=M`` the M x S candidates of a window are drawn with the same keys as plain sampling
    of M x S samples, and the S with the lowest stitching loss are returned in increasing order.
    noise_scale: factor on the latent noise (0: every sample is the same, the prior's mean path).
    """
    _check_request(model, length, num_samples, search, warn=True)
    if not np.isfinite(noise_scale) or noise_scale < 0:
        raise InbetweenError(f"noise_scale must be a finite number >= 0, got {noise_scale}")
    candidates = num_samples * max(int(search), 1)
    fn = _compiled_sampler(model.config, int(length), int(candidates), float(noise_scale))
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


def _alignment(start_rotations, start_positions, target_rotations, target_positions, parents,
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


def _check_skeleton(model: Model, skeleton):
    if tuple(skeleton.parents) != model.parents:
        raise InbetweenError(
            f"skeleton mismatch: the motion has {skeleton.num_joints} joints with parents "
            f"{tuple(skeleton.parents)}, the model ({model.source}) was trained on {model.num_joints} joints "
            f"with parents {model.parents}; retarget the motion to the training skeleton")
    if model.joint_names is not None and tuple(skeleton.names) != tuple(model.joint_names):
        diff = [f"{i}: {a!r} vs {b!r}" for i, (a, b) in enumerate(zip(skeleton.names, model.joint_names)) if a != b]
        raise InbetweenError(f"skeleton mismatch: joint names differ from the model's ({'; '.join(diff[:4])}"
                             f"{' ...' if len(diff) > 4 else ''}); rename or reorder the joints")


def transitions_in_frame(model: Model, start_rotations, start_positions, start_contacts, target_rotations,
                         target_positions, target_contacts, length: int, num_samples: int, seed=0,
                         search: int = 0, noise_scale: float = 1.0):
    """Transitions between B keyframe pairs given in any world frame, returned in that frame.

    Keyframes: local rotations (B, J, 4), local positions (B, J, 3) (root = world position, others
    = bone offsets), contacts (B, C). Returns (rotations (B, S, L+2, J, 4), positions (B, S, L+2, J, 3),
    stitch_loss (B, S)) float64: frame 0 and L+1 are the input keyframes exactly; non-root local
    positions are the start keyframe's bone offsets.
    """
    sr, sp = np.asarray(start_rotations, np.float64), np.asarray(start_positions, np.float64)
    tr, tp = np.asarray(target_rotations, np.float64), np.asarray(target_positions, np.float64)
    parents = model.parents
    if sr.ndim != 3 or sr.shape[1:] != (len(parents), 4) or sp.shape != sr.shape[:2] + (3,) \
            or tr.shape != sr.shape or tp.shape != sp.shape:
        raise InbetweenError(f"keyframes must be rotations (B, {len(parents)}, 4) and positions (B, "
                             f"{len(parents)}, 3); got {sr.shape}, {sp.shape}, {tr.shape}, {tp.shape}")
    aligned_rot, aligned_pos, turn, centre = _alignment(sr, sp, tr, tp, parents, model.forward_axis)
    start = {"rotations": aligned_rot[:, 0], "root_position": aligned_pos[:, 0, 0],
             "contacts": np.asarray(start_contacts, np.float64)}
    target = {"rotations": aligned_rot[:, 1], "root_position": aligned_pos[:, 1, 0],
              "contacts": np.asarray(target_contacts, np.float64)}
    out = sample_transitions(model, start, target, sp, length, num_samples, seed, search, noise_scale)

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
    return rotations, positions, out["stitch_loss"].astype(np.float64)


# ------------------------------------------------------------------------------------------ Motion API


def _keyframe(motion: Motion, which: str):
    if not isinstance(motion, Motion):
        raise InbetweenError(f"{which} must be a stitchjax.bvh.Motion (e.g. motion[frame]), got "
                             f"{type(motion).__name__}")
    if motion.num_frames < 1:
        raise InbetweenError(f"{which} has no frames")


def inbetween(model: Model, start: Motion, target: Motion, length: int, num_samples: int = 1, seed=0,
              search: int = 0, start_contacts=None, target_contacts=None, allow_extrapolation: bool = False) -> list:
    """Generate ``num_samples`` transitions of ``length`` frames from ``start`` to ``target``.

    start: Motion whose LAST frame is the start keyframe (earlier frames, if any, are context: the one
      before the keyframe measures its foot contacts). target: Motion whose FIRST frame is the target
      keyframe (a following frame, if any, measures its contacts). Both on the model's skeleton.
    length: generated frames L >= 1. seed: int or jax PRNG key. search: 0 = plain sampling; M >= 1 =
      try M latent pairs per wanted sample and keep the num_samples with the lowest stitching loss.
    start_contacts / target_contacts: (C,) foot contacts to use instead of measuring them.
    allow_extrapolation: a length beyond ``model.trained_max_length`` is an InbetweenError unless True.
    The keyframes must be on the model's skeleton, frame rate and units (see :func:`inbetween_takes`,
    which brings takes from anywhere onto them).
    Returns a list of ``num_samples`` Motions of L + 2 frames (start keyframe, L generated frames,
    target keyframe; same skeleton, fps and channel layout as ``start``), in sampling order, or in
    increasing stitching loss with ``search``. Each carries no extra attributes; use
    :func:`transitions_in_frame` for the stitching losses.
    """
    _keyframe(start, "start")
    _keyframe(target, "target")
    _check_skeleton(model, start.skeleton)
    _check_skeleton(model, target.skeleton)
    _check_request(model, length, num_samples, search)
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
        model, start.rotations[-1:], start.positions[-1:], np.asarray(start_contacts)[None],
        target.rotations[:1], target.positions[:1], np.asarray(target_contacts)[None], length, num_samples,
        seed, search)
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


def to_model_frame(model: Model, motion: Motion, scale: float = 1.0) -> Motion:
    """A take in the training files' units and up axis -> the model's (cm, +Y up): positions times
    ``scale * model.unit_scale``, then the world turned so that ``model.up_axis`` becomes +Y. LAFAN1 /
    H36M models (cm, +Y up) with ``scale`` 1: returned unchanged."""
    factor = float(scale) * float(model.unit_scale)
    motion = conform.rescale(motion, factor) if factor != 1.0 else motion
    return conform.to_y_up(motion, model.up_axis)


def from_model_frame(model: Model, motion: Motion, scale: float = 1.0) -> Motion:
    """Inverse of :func:`to_model_frame` (to float64 rounding): +Y up back to ``model.up_axis``, then
    positions divided by ``scale * model.unit_scale``."""
    motion = conform.from_y_up(motion, model.up_axis)
    factor = float(scale) * float(model.unit_scale)
    return conform.rescale(motion, 1.0 / factor) if factor != 1.0 else motion


def conform_take(model: Model, motion: Motion, what: str = "the take", scale: float = 1.0) -> Motion:
    """A take on the model's terms: in its units and up axis (:func:`to_model_frame`: positions times
    ``scale * model.unit_scale``, turned to +Y up), joints mapped by name onto the model's skeleton (extra
    joints folded away, missing ones refused), and its bone lengths checked against the model's training
    skeleton (``stats["offsets"]``) — another scale is refused with the measured ratio and the fix. The
    frame rate is left alone (see :func:`stitchjax.conform.resample`, anchored at a keyframe)."""
    if not isinstance(motion, Motion):
        raise InbetweenError(f"{what} must be a stitchjax.bvh.Motion, got {type(motion).__name__}")
    try:
        motion = to_model_frame(model, motion, scale)
        if model.joint_names is not None and (tuple(motion.skeleton.names) != tuple(model.joint_names)
                                              or tuple(motion.skeleton.parents) != model.parents):
            motion = conform.map_joints(motion, model.joint_names, model.parents, what)
        reference = model.stats.get("offsets") if model.stats else None
        if reference is not None and np.shape(reference) == (model.num_joints, 3):
            conform.check_scale(motion.skeleton.offsets, reference, what, "the model's training skeleton",
                                "bin/inbetween --scale {factor} (Python: scale={factor})")
    except conform.ConformError as error:
        raise InbetweenError(str(error)) from None
    _check_skeleton(model, motion.skeleton)
    return motion


def _neighbour_contacts(model: Model, motion: Motion, frame: int, prefer: int):
    """Contacts of keyframe ``frame`` measured against frame ``frame + prefer`` (or the other side)."""
    total = motion.num_frames
    other = frame + prefer if 0 <= frame + prefer < total else (frame - prefer if 0 <= frame - prefer < total else None)
    frames = [frame] if other is None else [frame, other]
    _, gpos = forward_kinematics(motion.rotations[frames], motion.positions[frames], motion.skeleton.parents)
    return keyframe_contacts(gpos[0], model.feet, None if other is None else gpos[1])


def _check_frame(motion: Motion, frame, name: str):
    total = motion.num_frames
    if int(frame) != frame or not 0 <= frame < total:
        raise InbetweenError(f"{name} {frame} is out of range: the motion has {total} frames (0..{total - 1})")


OUTPUTS = ("transition", "appended", "clip")


def inbetween_takes(model: Model, start_take: Motion, start_frame: int, target_take: Motion, target_frame: int,
                    length: int | None = None, num_samples: int = 1, seed=0, search: int = 0, *,
                    offset=(0.0, 0.0, 0.0), turn_degrees: float = 0.0, output: str = "appended",
                    scale: float = 1.0, allow_extrapolation: bool = False) -> list:
    """Transitions from frame ``start_frame`` of one take to frame ``target_frame`` of another (or the same).

    Both takes are brought onto the model's terms first (:func:`conform_take`: the training files' units and
    up axis to cm and +Y up, joints by name, units checked; ``scale`` multiplies their positions) and
    resampled to the model's frame rate, anchored at the keyframe so the keyframes are kept exactly. The
    target take is then placed: turned by ``turn_degrees`` about the up axis through its keyframe's root
    and moved by ``offset`` (x, y, z; in the takes' own units and axes, before ``scale``). The result is
    brought back to the takes' units and up axis (:func:`from_model_frame`; exact for cm, +Y-up models,
    else to float64 rounding).
    length: generated frames (default: the keyframes' distance in time minus one frame, when both come
      from one take; required otherwise).
    output: "transition" = the start keyframe, L generated frames, the placed target keyframe (L + 2 frames);
      "appended" = the start take's frames 0..start_frame, the L generated frames and the target keyframe;
      "clip" = "appended" followed by the rest of the (placed) target take.
    Returns ``num_samples`` Motions at the model's frame rate on the model's skeleton (the takes' own
    skeleton and channel layout when their joints already match), positions in the takes' units and axes.
    """
    if output not in OUTPUTS:
        raise InbetweenError(f"output {output!r}: use one of {', '.join(OUTPUTS)}")
    if not np.isfinite(scale) or scale <= 0:
        raise InbetweenError(f"scale must be a positive number, got {scale}")
    for what, take in (("start take", start_take), ("target take", target_take)):
        if not isinstance(take, Motion):
            raise InbetweenError(f"{what} must be a stitchjax.bvh.Motion, got {type(take).__name__}")
    _check_frame(start_take, start_frame, "start frame")
    _check_frame(target_take, target_frame, "target frame")
    same = target_take is start_take
    if length is None:
        if not same:
            raise InbetweenError("give the transition length (frames to generate) when the target keyframe "
                                 "comes from another take")
        if target_frame <= start_frame:
            raise InbetweenError(f"end frame {target_frame} must come after start frame {start_frame}")
        gap = (target_frame - start_frame) * float(model.config.data.fps) / float(start_take.fps)
        length = int(round(gap)) - 1
        if length < 1:
            raise InbetweenError(f"frames {start_frame} and {target_frame} are adjacent: nothing to generate; "
                                 f"give a length >= 1 or keyframes further apart")
    _check_request(model, length, num_samples, search)
    check_length(model, length, allow_extrapolation)
    fps = float(model.config.data.fps)
    start_take = conform_take(model, start_take, "the start take", scale)
    target_take = start_take if same else conform_take(model, target_take, "the target take", scale)
    try:
        start_take, a = conform.resample(start_take, fps, int(start_frame))
        target_take, b = conform.resample(target_take, fps, int(target_frame))
        offset = np.asarray(offset, np.float64)
        if offset.shape != (3,):
            raise conform.ConformError(f"offset must be 3 numbers (x, y, z), got shape {offset.shape}")
        if np.any(offset != 0) or turn_degrees:
            shift = R.quat_rotate(conform.up_turn(model.up_axis), offset)  # the takes' axes -> +Y up
            target_take = conform.place(target_take, shift * scale * model.unit_scale, turn_degrees, pivot=b)
    except conform.ConformError as error:
        raise InbetweenError(str(error)) from None
    start_contacts = _neighbour_contacts(model, start_take, a, -1)
    target_contacts = _neighbour_contacts(model, target_take, b, +1)
    samples = inbetween(model, start_take[a], target_take[b], length, num_samples, seed, search,
                        start_contacts, target_contacts, allow_extrapolation=True)
    out = []
    for s in samples:
        if output == "transition":
            motion = s
        else:
            tail = slice(b, b + 1) if output == "appended" else slice(b, None)
            motion = start_take.with_frames(
                np.concatenate([start_take.rotations[:a], s.rotations[:-1], target_take.rotations[tail]]),
                np.concatenate([start_take.positions[:a], s.positions[:-1], target_take.positions[tail]]))
        out.append(from_model_frame(model, motion, scale))
    return out


def inbetween_clip(model: Model, motion: Motion, start_frame: int, end_frame: int, length: int | None = None,
                   num_samples: int = 1, seed=0, search: int = 0, allow_extrapolation: bool = False) -> list:
    """Replace the frames between two keyframes of a take by generated transitions.

    Keyframes: ``motion`` frames ``start_frame`` (A) and ``end_frame`` (B), A < B. length: generated
    frames (default B - A - 1, the frames replaced). Returns ``num_samples`` Motions: frames 0..A of
    ``motion``, L generated frames, frames B..end of ``motion`` (T - (B - A - 1) + L frames).
    Contacts of the keyframes: measured against frame A - 1 and B + 1 (the frames being replaced are
    never looked at), or the other side at the ends of the take.
    A take at another frame rate is resampled to the model's (the keyframes kept exactly; the result is at
    the model's rate and the default length counts the model's frames between the keyframes); joints are
    mapped by name and the units checked as in :func:`inbetween_takes`. A length beyond the model's
    training lengths is refused unless ``allow_extrapolation``.
    """
    if not isinstance(motion, Motion):
        raise InbetweenError(f"expected a stitchjax.bvh.Motion, got {type(motion).__name__}")
    _check_frame(motion, start_frame, "start frame")
    _check_frame(motion, end_frame, "end frame")
    if end_frame <= start_frame:
        raise InbetweenError(f"end frame {end_frame} must come after start frame {start_frame}")
    return inbetween_takes(model, motion, start_frame, motion, end_frame, length, num_samples, seed, search,
                           output="clip", allow_extrapolation=allow_extrapolation)


# ------------------------------------------------------------------------------------------ evaluation


def model_method(model, search: int = 0, noise_scale: float = 1.0):
    """The model as a ``stitchjax.evaluate`` method:
    ``method(windows, start, length, num_samples, seed) -> (rotations (S, B, L, J, 4), positions (S, B, L, J, 3))``.

    model: a :class:`Model` or a checkpoint path (loaded once). The method uses frames ``start`` and
    ``start + length + 1`` of each window and their foot-contact labels from ``windows.contacts``
    (the keyframes' character state, as in training); it returns the L generated frames only.
    search: latent pairs per sample (0: none); noise_scale: factor on the latent noise.
    """
    if not isinstance(model, Model):
        model = load_model(model)

    def method(windows, start, length, num_samples, seed):
        _check_skeleton(model, windows.skeleton)
        target = start + length + 1
        if not 0 <= start < target < windows.rotations.shape[1]:
            raise InbetweenError(f"keyframes {start} and {target} are outside windows of "
                                 f"{windows.rotations.shape[1]} frames")
        rot, pos = np.asarray(windows.rotations), np.asarray(windows.positions)
        contacts = np.asarray(windows.contacts)
        rotations, positions, _ = transitions_in_frame(
            model, rot[:, start], pos[:, start], contacts[:, start], rot[:, target], pos[:, target],
            contacts[:, target], length, num_samples, seed, search, noise_scale)
        # (B, S, L+2, ...) -> generated frames, samples first: (S, B, L, ...)
        return (np.swapaxes(rotations[:, :, 1:-1], 0, 1), np.swapaxes(positions[:, :, 1:-1], 0, 1))

    method.model = model
    return method


def evaluation_method(checkpoint, search: int = 0, noise_scale: float = 1.0):
    """What ``bin/evaluate model --checkpoint DIR`` calls: :func:`model_method` of the checkpoint
    (``checkpoint`` may also be a loaded :class:`Model`)."""
    model = checkpoint if isinstance(checkpoint, Model) else load_model(checkpoint)
    return model_method(model, search=search, noise_scale=noise_scale)


# ----------------------------------------------------------------------------- latent-space exploration


def noise_shape(model: Model, length: int) -> tuple:
    """Shape (n, 2, latent_dim) of the standard-normal noise one rollout of ``length`` frames draws:
    n scan steps, [forward, backward] generator, latent size."""
    from stitchjax import rollout as rollout_lib

    return (rollout_lib.num_steps(model.config, int(length)), 2, int(model.config.model.latent_dim))


def _rollout_with_noise(params, phase_params, start, target, offsets, noise, config, length):
    """``rollout.rollout`` with its latent noise (n, 2, latent) given instead of drawn from a key."""
    from stitchjax import rollout as rollout_lib

    return rollout_lib.rollout(params, phase_params, start, target, offsets, jax.random.PRNGKey(0), config,
                               length, length, noise=noise)


@functools.lru_cache(maxsize=16)
def _compiled_details(config, length: int):
    def one(params, phase_params, start, target, offsets, noise):
        out = _rollout_with_noise(params, phase_params, start, target, offsets, noise, config, length)
        out["stitch_loss"] = stitch_losses(out)
        return out

    per_window = jax.vmap(one, in_axes=(None, None, None, None, None, 0))  # samples
    return jax.jit(jax.vmap(per_window, in_axes=(None, None, 0, 0, 0, 0)))  # windows


def window_keyframes(model: Model, windows, start: int, length: int) -> tuple:
    """Keyframes of B windows in the model's frame: (start, target, offsets) as ``sample_transitions``
    takes them; target = frame start + length + 1; contacts from ``windows.contacts``."""
    _check_skeleton(model, windows.skeleton)
    target = start + length + 1
    if not 0 <= start < target < windows.rotations.shape[1]:
        raise InbetweenError(f"keyframes {start} and {target} are outside windows of {windows.rotations.shape[1]} frames")
    rot, pos = np.asarray(windows.rotations, np.float64), np.asarray(windows.positions, np.float64)
    aligned_rot, aligned_pos, _, _ = _alignment(rot[:, start], pos[:, start], rot[:, target], pos[:, target],
                                                model.parents, model.forward_axis)
    contacts = np.asarray(windows.contacts, np.float64)
    start_kf = {"rotations": aligned_rot[:, 0], "root_position": aligned_pos[:, 0, 0], "contacts": contacts[:, start]}
    target_kf = {"rotations": aligned_rot[:, 1], "root_position": aligned_pos[:, 1, 0],
                 "contacts": contacts[:, target]}
    return start_kf, target_kf, pos[:, start]


def rollout_details(model: Model, start: dict, target: dict, offsets, length: int, noise) -> dict:
    """Full rollouts (model frame) of B keyframe pairs with given latent noise, for exploring the latent space.

    start, target, offsets: as from :func:`window_keyframes` (leading B); noise: (B, S, n, 2, latent)
    standard-normal draws (``noise_shape``), e.g. interpolations between two draws. Returns numpy
    ``rollout.rollout`` dicts with leading (B, S): the stitched motion, the forward and backward
    generators' per-step outputs including their Gaussians ("mu", "mu_target", "mu_blend", ...) and
    "stitch_loss" (B, S). Compiled once per (length, B, S).
    """
    _check_request(model, length, 1, 0, warn=True)
    noise = jnp.asarray(noise, jnp.float32)
    expected = noise_shape(model, length)
    if noise.ndim != 5 or noise.shape[2:] != expected:
        raise InbetweenError(f"noise must be (B, S) + {expected} for length {length}, got {noise.shape}")
    as32 = functools.partial(jnp.asarray, dtype=jnp.float32)
    out = _compiled_details(model.config, int(length))(
        model.params, model.phase_params, jax.tree.map(as32, start), jax.tree.map(as32, target), as32(offsets), noise)
    return jax.tree.map(np.asarray, out)
