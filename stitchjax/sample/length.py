"""How many frames a transition between two keyframes should take, proposed from the keyframes alone.

    length_model = load_length_model()             # shipped with the package (LAFAN1's skeleton, 30 fps)
    proposal = propose_length(length_model, start_positions, start_root, target_positions, target_root)
    proposal.frames, proposal.low, proposal.high   # at length_model.fps; positions (J, 3) cm, roots (4,) quats

The keyframes are described by a few numbers (:func:`pair_features`, :data:`FEATURES`): how far the root
travels over the ground, how far the body turns, how different the two poses are in the body's own frame,
how much the root rises or falls, and how high it is. A length model maps them to the number of frames
between the keyframes that captured motion took for pairs like them: three quantile regressions (low,
middle, high) of log(frames + 1) on transforms of those numbers, with coefficients on the amounts of change
kept non-negative, so more change never proposes fewer frames. The middle quantile is the proposal, the
low and high ones the plausible range. The fitted model is stored as JSON (:func:`save_length_model`) beside
the release model; it was fitted on keyframe pairs cut from LAFAN1's training takes at gaps of 10-50 frames.

Everything is in the model's terms: centimetres, +Y up, the model's frame rate; :mod:`stitchjax.sample.takes`
brings takes there and counts the proposal back in a take's own frames.
"""
from __future__ import annotations

import dataclasses
import json
import pathlib

import numpy as np

from stitchjax.config import RELEASE_MODEL
from stitchjax import rotations as R

__all__ = ["FEATURES", "COLUMNS", "MONOTONE", "LENGTH_MODEL_FILE", "LengthModel", "Proposal", "pair_features",
           "design_matrix", "propose_length", "propose_lengths", "proposal_frames", "load_length_model",
           "save_length_model", "length_model_for", "LengthModelError"]

# the numbers that describe a keyframe pair, in this order (units: cm, degrees)
FEATURES = ("distance", "turn", "pose", "rise", "height")
LENGTH_MODEL_FILE = "length_model.json"
SHIPPED = pathlib.Path(__file__).resolve().parent.parent / "pretrained" / RELEASE_MODEL / LENGTH_MODEL_FILE
FORMAT = "stitchjax-length-model"
FORMAT_VERSION = 1


class LengthModelError(ValueError):
    """No length model fits the request, or a length model file cannot be read."""


def _heading(root_rotation, forward_axis) -> np.ndarray:
    """(...,) angle (radians) of the root's forward direction over the ground, about +Y from +X."""
    q = np.asarray(root_rotation, np.float64)
    forward = R.quat_rotate(q, np.broadcast_to(np.asarray(forward_axis, np.float64), q.shape[:-1] + (3,)))
    return np.arctan2(-forward[..., 2], forward[..., 0])


def _body_frame(positions, heading) -> np.ndarray:
    """(..., J, 3) joint positions with the root's x, z put at 0 and the body turned to face +X (heights kept)."""
    p = np.asarray(positions, np.float64)
    p = p - p[..., :1, :] * np.array([1.0, 0.0, 1.0])
    c, s = np.cos(heading)[..., None], np.sin(heading)[..., None]
    # turn by -heading about +Y (heading measured from +X towards -Z)
    x = c * p[..., 0] - s * p[..., 2]
    z = s * p[..., 0] + c * p[..., 2]
    return np.stack([x, p[..., 1], z], axis=-1)


def pair_features(start_positions, start_root_rotation, target_positions, target_root_rotation,
                  forward_axis=(0.0, 1.0, 0.0)) -> np.ndarray:
    """The :data:`FEATURES` of keyframe pairs: (..., 5) float64.

    start_positions, target_positions: (..., J, 3) global joint positions (cm, +Y up, root first);
    start_root_rotation, target_root_rotation: (..., 4) the root's global rotation (w, x, y, z);
    forward_axis: the root's local forward axis (LAFAN1's Hips: +Y).
    distance: root travel over the ground (cm); turn: heading change, 0..180 degrees; pose: mean joint
    distance between the two poses in the body's own frame (root over the origin, facing +X; cm); rise:
    root height change (cm, signed); height: the two root heights' mean (cm).
    """
    a, b = np.asarray(start_positions, np.float64), np.asarray(target_positions, np.float64)
    ha, hb = _heading(start_root_rotation, forward_axis), _heading(target_root_rotation, forward_axis)
    gap = b[..., 0, :] - a[..., 0, :]
    distance = np.hypot(gap[..., 0], gap[..., 2])
    turn = np.degrees(np.abs(np.angle(np.exp(1j * (hb - ha)))))
    pose = np.linalg.norm(_body_frame(b, hb) - _body_frame(a, ha), axis=-1).mean(axis=-1)
    rise = gap[..., 1]
    height = 0.5 * (a[..., 0, 1] + b[..., 0, 1])
    return np.stack([distance, turn, pose, rise, height], axis=-1)


@dataclasses.dataclass(frozen=True)
class LengthModel:
    """A fitted length model (:func:`load_length_model`).

    Attributes:
      fps: the frame rate its frames are counted at.
      quantiles: (3,) the quantiles of its three rows (low, middle, high), e.g. (0.1, 0.5, 0.9).
      scales: {feature: scale} each transform's scale (cm or degrees), see :func:`design_matrix`.
      coefficients: (3, K) one row per quantile over the columns of :func:`design_matrix`.
      min_frames, max_frames: the lengths it was fitted on (proposals are kept within them).
      joint_names: the skeleton whose poses it was fitted on (its "pose" feature compares these joints).
      forward_axis: (3,) the root's local forward axis of that skeleton.
      notes: where it came from (data, command), JSON-able.
    """

    fps: float
    quantiles: tuple
    scales: dict
    coefficients: np.ndarray
    min_frames: int
    max_frames: int
    joint_names: tuple
    forward_axis: tuple = (0.0, 1.0, 0.0)
    notes: dict = dataclasses.field(default_factory=dict)


# design_matrix's columns after the intercept: (name, transform); "log" = log(1 + value / scale)
COLUMNS = (("distance", "log"), ("turn", "log"), ("pose", "log"), ("rise", "log_abs"), ("height", "log"))
# columns whose coefficient is kept >= 0: more change never proposes fewer frames
MONOTONE = ("distance", "turn", "pose", "rise")


def design_matrix(features, scales: dict) -> np.ndarray:
    """(..., 1 + len(COLUMNS)) the regression's inputs: 1, then log(1 + |value| / scale) of each feature."""
    f = np.asarray(features, np.float64)
    columns = [np.ones(f.shape[:-1])]
    for name, _ in COLUMNS:
        value = np.abs(f[..., FEATURES.index(name)])
        columns.append(np.log1p(value / float(scales[name])))
    return np.stack(columns, axis=-1)


@dataclasses.dataclass(frozen=True)
class Proposal:
    """A proposed transition length: ``frames`` (the proposal) in the plausible range ``low``..``high``,
    counted at ``fps``; ``distance`` (cm) and ``turn`` (degrees) of the keyframes, for messages."""

    frames: int
    low: int
    high: int
    fps: float
    distance: float
    turn: float

    def describe(self) -> str:
        """One line: "34 frames (plausible 26-45) from 2.1 m, 40 deg turn"."""
        return (f"{self.frames} frames (plausible {self.low}-{self.high}) from {self.distance / 100:.1f} m, "
                f"{self.turn:.0f} deg turn")


def proposal_frames(length_model: LengthModel, features) -> np.ndarray:
    """(..., 3) the low, middle and high frames (float, at ``length_model.fps``) of keyframe pairs with
    :func:`pair_features` ``features`` (..., 5), each kept within the fitted lengths."""
    x = design_matrix(features, length_model.scales)
    frames = np.exp(x @ np.asarray(length_model.coefficients, np.float64).T) - 1.0
    frames = np.maximum.accumulate(frames, axis=-1)  # low <= middle <= high, even where fits cross
    return np.clip(frames, length_model.min_frames, length_model.max_frames)


def propose_lengths(length_model: LengthModel, features, min_frames=1) -> np.ndarray:
    """(..., 3) int the low, proposed and high frames of keyframe pairs with :func:`pair_features` ``features``
    (..., 5), at ``length_model.fps``. min_frames: (...,) or a number, a floor for all three (e.g. the
    fewest frames that keep the root under the fastest speed the model was trained on, at least 1);
    low <= proposed <= high."""
    low, middle, high = np.moveaxis(proposal_frames(length_model, features), -1, 0)
    floor = np.maximum(np.asarray(min_frames), 1)
    frames = np.maximum(np.round(middle), floor)
    low = np.minimum(np.maximum(np.floor(low), floor), frames)
    high = np.maximum(np.ceil(high), frames)
    return np.stack([low, frames, high], axis=-1).astype(np.int64)


def propose_length(length_model: LengthModel, start_positions, start_root_rotation, target_positions,
                   target_root_rotation, min_frames: int = 1) -> Proposal:
    """The proposed number of frames between two keyframes (at ``length_model.fps``), with its plausible
    range. Poses as in :func:`pair_features` ((J, 3) cm, +Y up; (4,) root rotation), on the length model's
    skeleton; min_frames as in :func:`propose_lengths`."""
    features = pair_features(start_positions, start_root_rotation, target_positions, target_root_rotation,
                             length_model.forward_axis)
    low, frames, high = (int(v) for v in propose_lengths(length_model, features, min_frames))
    return Proposal(frames=frames, low=low, high=high, fps=float(length_model.fps),
                    distance=float(features[0]), turn=float(features[1]))


def save_length_model(length_model: LengthModel, path) -> pathlib.Path:
    """Write ``length_model`` as JSON to ``path``; :func:`load_length_model` reads it back."""
    path = pathlib.Path(path)
    description = {"format": FORMAT, "version": FORMAT_VERSION, "features": list(FEATURES),
                   "columns": ["intercept"] + [f"{t}({name})" for name, t in COLUMNS],
                   **{f.name: getattr(length_model, f.name) for f in dataclasses.fields(length_model)}}
    description["coefficients"] = np.asarray(length_model.coefficients, np.float64).tolist()
    description["quantiles"] = [float(q) for q in length_model.quantiles]
    description["joint_names"] = list(length_model.joint_names)
    description["forward_axis"] = [float(x) for x in length_model.forward_axis]
    path.write_text(json.dumps(description, indent=1) + "\n")
    return path


def load_length_model(path=None) -> LengthModel:
    """The length model in JSON file ``path`` (default: the one shipped with the release model)."""
    path = SHIPPED if path is None else pathlib.Path(path)
    try:
        description = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        raise LengthModelError(f"length model {path} cannot be read ({error}); reinstall stitchjax") from None
    if description.get("format") != FORMAT or description.get("version") != FORMAT_VERSION:
        raise LengthModelError(f"{path}: not a {FORMAT} version {FORMAT_VERSION} file")
    if description.get("features") != list(FEATURES) or description.get("columns") != (
            ["intercept"] + [f"{t}({name})" for name, t in COLUMNS]):
        raise LengthModelError(f"{path}: fitted on other features ({description.get('columns')}); reinstall stitchjax")
    coefficients = np.asarray(description["coefficients"], np.float64)
    if coefficients.shape != (3, 1 + len(COLUMNS)):
        raise LengthModelError(f"{path}: coefficients of shape {coefficients.shape}, expected "
                               f"{(3, 1 + len(COLUMNS))}")
    return LengthModel(fps=float(description["fps"]), quantiles=tuple(float(q) for q in description["quantiles"]),
                       scales={k: float(v) for k, v in description["scales"].items()}, coefficients=coefficients,
                       min_frames=int(description["min_frames"]), max_frames=int(description["max_frames"]),
                       joint_names=tuple(description["joint_names"]),
                       forward_axis=tuple(float(x) for x in description["forward_axis"]),
                       notes=description.get("notes") or {})


def length_model_for(joint_names, forward_axis) -> LengthModel:
    """The shipped length model when a model's skeleton (``joint_names``, root ``forward_axis``) is the one it
    was fitted on; LengthModelError saying so (and to give the length) otherwise."""
    length_model = load_length_model()
    if joint_names is None or tuple(joint_names) != length_model.joint_names or not np.allclose(
            np.asarray(forward_axis, np.float64), length_model.forward_axis):
        raise LengthModelError(
            f"no length model for this model's skeleton (the shipped one was fitted on the "
            f"{len(length_model.joint_names)} joints of LAFAN1, root {length_model.joint_names[0]}); give the "
            f"transition length in frames instead of auto")
    return length_model
