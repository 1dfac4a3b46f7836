"""Network features: the per-frame character state, offsets, and the training dataset arrays.

Character state of one frame (size S = J*4 + 3 + C; LAFAN1: 22*4 + 3 + 4 = 95)::

    [ local quaternions (J*4, w x y z per joint) | root velocity (3) | foot contacts (C) ]

Root velocity of frame t is ``(p_t - p_{t-1}) /`` :data:`VELOCITY_SCALE` with p the root position in
centimetres (every dataset loads in cm: scaled units are 10 cm/frame = 3 m/s at 30 fps: ~0.5 walking, ~2
sprinting). The velocity of the first frame of a sequence (and of both keyframes in the rollout, which only
sees two poses) is 0. Offset features (the offset encoder's input, size J*4 + 3): target minus current local
quaternions and target minus current global root position divided by :data:`POSITION_SCALE` (cm -> m).

Everything here works on numpy (data pipeline) and jax.numpy (model) arrays alike.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from stitchjax.data import phase
from stitchjax import rotations as R
from stitchjax import skeleton as skel

__all__ = [
    "POSITION_SCALE", "VELOCITY_SCALE", "NUM_CONTACTS",
    "state_dim", "state_vector", "split_state", "root_velocities", "offset_features",
    "local_positions", "integrate_root", "prepare_dataset", "dataset_states", "phase_training_arrays",
    "reverse_time", "DatasetError",
    "root_speed_percentiles", "RANDOM_START_KEYS", "cut_windows", "random_start_batch",
]


POSITION_SCALE = 100.0  # centimetres per model unit: positions enter the losses and offsets in metres, O(1)
VELOCITY_SCALE = 10.0  # cm/frame per state unit of root velocity: ~0.5 walking, ~2 sprinting
NUM_CONTACTS = 4  # contact channels of the state: left foot, left toe, right foot, right toe


class DatasetError(ValueError):
    """Windows / stats / config do not fit together; the message says what to change."""


def state_dim(num_joints: int, num_contacts: int = NUM_CONTACTS) -> int:
    """S = J*4 + 3 + C of J joints and C contact channels."""
    return int(num_joints) * 4 + 3 + int(num_contacts)


def state_vector(rotations, root_velocity, contacts):
    """(..., J, 4) local quats, (..., 3) scaled root velocity, (..., C) contacts -> (..., J*4 + 3 + C)."""
    xp = R.array_module(rotations, root_velocity, contacts)
    flat = rotations.reshape(rotations.shape[:-2] + (rotations.shape[-2] * 4,))
    return xp.concatenate([flat, root_velocity, contacts], axis=-1)


def split_state(state, num_joints: int):
    """Inverse of :func:`state_vector`: (..., S) -> (rotations (..., J, 4), velocity (..., 3), contacts (..., C))."""
    n = num_joints * 4
    rotations = state[..., :n].reshape(state.shape[:-1] + (num_joints, 4))
    return rotations, state[..., n:n + 3], state[..., n + 3:]


def root_velocities(root_positions, velocity_scale: float):
    """Scaled root velocity of every frame: (..., T, 3) positions -> (..., T, 3); frame 0 gets 0."""
    xp = R.array_module(root_positions)
    diff = root_positions[..., 1:, :] - root_positions[..., :-1, :]
    first = xp.zeros_like(root_positions[..., :1, :])
    return xp.concatenate([first, diff], axis=-2) / velocity_scale


def offset_features(rotations, root_position, target_rotations, target_root_position, position_scale: float):
    """Offset encoder input (..., J*4 + 3): target - current local quats, target - current root / scale."""
    xp = R.array_module(rotations, root_position, target_rotations, target_root_position)
    dq = target_rotations - rotations
    dq = dq.reshape(dq.shape[:-2] + (dq.shape[-2] * 4,))
    return xp.concatenate([dq, (target_root_position - root_position) / position_scale], axis=-1)


def local_positions(offsets, root_positions):
    """FK local positions: bone offsets (..., J, 3) with the root row replaced by root_positions (..., 3).

    Broadcasts: offsets (J, 3) with root_positions (T, 3) gives (T, J, 3).
    """
    xp = R.array_module(offsets, root_positions)
    shape = np.broadcast_shapes(offsets.shape[:-2], root_positions.shape[:-1])
    offsets = xp.broadcast_to(offsets, shape + offsets.shape[-2:])
    root = xp.broadcast_to(root_positions[..., None, :], shape + (1, 3))
    return xp.concatenate([root.astype(offsets.dtype), offsets[..., 1:, :]], axis=-2)


def integrate_root(start_position, velocities, velocity_scale: float):
    """Root positions (..., T, 3) from a start position (..., 3) and scaled velocities (..., T, 3) of
    frames 1..T (p_t = p_{t-1} + v_t * scale)."""
    xp = R.array_module(start_position, velocities)
    return start_position[..., None, :] + xp.cumsum(velocities, axis=-2) * velocity_scale


def prepare_dataset(windows, stats, data, phase_labels=None) -> dict:
    """Training arrays from a :class:`stitchjax.data.windows.Windows` batch (float32 numpy, leading (N, T)).

    Returns:
      "rotations" (N, T, J, 4) local quats; "root_positions" (N, T, 3) file units;
      "contacts" (N, T, C); "global_positions" (N, T, J, 3) FK positions, file units;
      "phase" (N, T, 2C) phase labels (``phase.phase_labels`` per window unless given);
      "offsets" (N, 1, J, 3) bone offsets of each window (time axis of 1 so ``x[idx, :window]`` slicing
      of every array keeps working).
    data: the config's ``data`` section (parents). stats: the training statistics (unused beyond validation;
    positions are scaled by :data:`POSITION_SCALE`, fixed so checkpoints do not depend on the data subset).
    """
    parents = tuple(data.parents)
    if tuple(windows.skeleton.parents) != parents:
        raise DatasetError(
            f"windows have a {windows.skeleton.num_joints}-joint skeleton whose parents differ from "
            f"config.data.parents ({len(parents)} joints); set data.parents to {tuple(windows.skeleton.parents)}")
    contacts = np.asarray(windows.contacts, np.float32)
    if contacts.shape[-1] != NUM_CONTACTS:
        raise DatasetError(f"windows have {contacts.shape[-1]} contact channels; the state has {NUM_CONTACTS} "
                           "(left foot, left toe, right foot, right toe)")
    rotations = np.asarray(windows.rotations, np.float64)
    positions = np.asarray(windows.positions, np.float64)
    _, global_positions = skel.forward_kinematics(rotations, positions, parents)
    if phase_labels is None:
        phase_labels = phase.phase_labels(contacts, windows.fps)
    phase_labels = np.asarray(phase_labels, np.float32)
    phase_labels = phase_labels.reshape(phase_labels.shape[:2] + (-1,))
    offsets = positions[:, :1].copy()
    offsets[..., 0, :] = 0.0
    return {
        "rotations": rotations.astype(np.float32),
        "root_positions": positions[:, :, 0].astype(np.float32),
        "contacts": contacts,
        "global_positions": global_positions.astype(np.float32),
        "phase": phase_labels,
        "offsets": offsets.astype(np.float32),
    }


def dataset_states(dataset: dict, velocity_scale: float):
    """Character states of every frame of a prepared dataset, (N, T, S) (phase pretraining input);
    velocity_scale: cm / frame per state unit (:data:`VELOCITY_SCALE`).

    Frame 0 of each window gets the velocity of frame 1 (the window has no previous frame).
    """
    xp = R.array_module(dataset["root_positions"])
    velocity = root_velocities(dataset["root_positions"], velocity_scale)
    velocity = xp.concatenate([velocity[:, 1:2], velocity[:, 1:]], axis=1)
    return state_vector(dataset["rotations"], velocity, dataset["contacts"])


def phase_training_arrays(dataset: dict, velocity_scale: float, fps: float) -> tuple:
    """(states (N, S), labels (N, 2C)) of every frame of a prepared dataset's windows and of the same windows
    played backwards (:func:`reverse_time`: the backward generator feeds the phase network time-reversed
    states, labelled from the reversed contacts), the phase network's pretraining set
    (``phase.pretrain_phase``); velocity_scale, fps: :data:`VELOCITY_SCALE` and ``data.fps``."""
    states = np.asarray(dataset_states(dataset, velocity_scale))
    states = states.reshape(-1, states.shape[-1])
    labels = np.asarray(dataset["phase"]).reshape(states.shape[0], -1)
    reversed_windows = reverse_time(dataset)
    rev_states = np.asarray(dataset_states(reversed_windows, velocity_scale))
    rev_labels = phase.phase_labels(reversed_windows["contacts"], fps)
    states = np.concatenate([states, rev_states.reshape(-1, states.shape[-1])])
    labels = np.concatenate([labels, np.asarray(rev_labels, np.float32).reshape(rev_states.shape[0] *
                                                                                rev_states.shape[1], -1)])
    return states, labels


def reverse_time(dataset: dict) -> dict:
    """The windows played backwards: "rotations", "root_positions", "contacts" with the time axis reversed."""
    return {name: np.asarray(dataset[name])[:, ::-1] for name in ("rotations", "root_positions", "contacts")}


def root_speed_percentiles(root_positions, fps: float, up_axis: int = 1) -> dict:
    """How fast the root moves over the ground in a set of windows: {"p50", "p99", "max"} in cm/s.

    root_positions: (..., T, 3) root positions in cm (training windows: (N, T, 3)); fps: their frame rate.
    The speed of each frame step is the horizontal distance (the axes other than ``up_axis``) between
    consecutive frames times ``fps``. ``bin/train`` saves the 99th percentile as ``stats["root_speed_p99"]``:
    the fastest a placed target may ask a transition to travel (``stitchjax.sample.takes``).
    """
    p = np.asarray(root_positions, np.float64)
    horizontal = [a for a in range(3) if a != up_axis]
    speed = np.linalg.norm(np.diff(p[..., horizontal], axis=-2), axis=-1).ravel() * float(fps)
    if speed.size == 0:
        raise DatasetError("no frame steps to measure the root speed on (windows of one frame)")
    return {"p50": float(np.percentile(speed, 50)), "p99": float(np.percentile(speed, 99)),
            "max": float(speed.max())}


# Arrays a random-start dataset carries besides the windows' own: "facing" (N, T', 4) the turn that faces the
# window at each frame (windows.facing_per_frame), "start_counts" (N, 1) int32 the starts each window holds.
RANDOM_START_KEYS = ("facing", "start_counts")
_TIME_KEYS = ("rotations", "root_positions", "contacts", "global_positions", "phase")


def cut_windows(data: dict, index, shift, window: int, facing_frame: int) -> dict:
    """Windows of ``window`` frames starting ``shift`` frames into the carried windows ``index``, centred and
    faced again as the benchmark aligns a window (root x/z mean over its frames subtracted, turned so that
    its root faces +X at its frame ``facing_frame``).

    data: a random-start dataset (:data:`RANDOM_START_KEYS` and the arrays of :func:`prepare_dataset` with
    T' >= shift + window frames); index, shift: (B,) int. Returns the :func:`prepare_dataset` arrays of the
    B windows, (B, window, ...) ("offsets" (B, 1, J, 3)): frame 0 is the start keyframe and frame
    ``window - 1`` the last frame. Works on numpy and jax arrays (a pure gather plus a rigid turn).
    """
    xp = R.array_module(data["rotations"])
    index = xp.asarray(index)
    frames = xp.asarray(shift)[:, None] + xp.arange(int(window))[None, :]  # (B, window)
    out = {name: data[name][index[:, None], frames] for name in _TIME_KEYS}
    out["offsets"] = data["offsets"][index]
    turn = data["facing"][index, frames[:, facing_frame]]  # (B, 4)
    root = out["root_positions"]
    mean = xp.mean(root, axis=1)  # (B, 3): only x and z are subtracted
    centre = mean * xp.asarray([1.0, 0.0, 1.0], dtype=root.dtype)
    turn_t = turn[:, None, :].astype(root.dtype)
    out["root_positions"] = R.quat_rotate(turn_t, root - centre[:, None, :])
    out["global_positions"] = R.quat_rotate(turn_t[:, :, None, :], out["global_positions"] - centre[:, None, None, :])
    rotations = out["rotations"]
    root_rotation = R.quat_mul(turn_t, rotations[:, :, 0, :])
    out["rotations"] = xp.concatenate([root_rotation[:, :, None, :], rotations[:, :, 1:, :]], axis=2)
    return out


def random_start_batch(data: dict, key, batch_size: int, window: int, facing_frame: int) -> dict:
    """A batch of ``batch_size`` training windows whose start is drawn uniformly (with replacement) from every
    frame that starts a whole window (data.random_starts): a carried window i with probability
    start_counts[i] / sum, then a shift uniform in [0, start_counts[i]); cut by :func:`cut_windows` (jax)."""
    import jax

    counts = data["start_counts"][:, 0].astype(jnp.float32)
    window_key, shift_key = jax.random.split(key)
    index = jax.random.categorical(window_key, jnp.log(counts), shape=(batch_size,))
    chosen = counts[index]
    shift = jnp.minimum(jnp.floor(jax.random.uniform(shift_key, (batch_size,)) * chosen), chosen - 1).astype(jnp.int32)
    return cut_windows(data, index, shift, window, facing_frame)
