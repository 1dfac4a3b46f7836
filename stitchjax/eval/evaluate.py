"""Evaluation: the official LAFAN1 baseline benchmark and the paper's protocol (docs/design.md §4, §6).

Two entry points, both float64 numpy:

* ``benchmark_baselines(train_stats, test_windows)`` reproduces the official LAFAN1 benchmark of the
  zero-velocity and interpolation baselines (L2Q, L2P, NPSS at n = 5, 15, 30, 45).
* ``evaluate_protocol(methods, windows, stats)`` runs any number of in-betweening *methods* through
  one code path and reports APD, ADE, ADE best, SLDE, NPSS, foot slide, L2P and L2Q per length.

A *method* is any callable with the signature of ``Method.__call__``::

    method(windows, start, length, num_samples, seed) -> (rotations, positions)

    windows      a chunk of B windows (``stitchjax.data.windows.Windows``: rotations (B, T, J, 4),
                 positions (B, T, J, 3), contacts (B, T, 4), skeleton, fps)
    start        index of the start keyframe; the target keyframe is start + length + 1.
                 A method may look at frames <= start and at the target frame only.
    length       number of frames to generate (frames start+1 .. start+length)
    num_samples  samples wanted per window (a deterministic method may return 1)
    seed         int, different for every call; use it for all randomness
    returns      local rotations (S, B, L, J, 4) and local positions (S, B, L, J, 3), S = 1 or num_samples

``zero_velocity_method`` and ``interpolation_method`` are the baselines in that form; a trained model
becomes one through :func:`model_method` (see bin/evaluate).
"""
from __future__ import annotations

import dataclasses
import sys
from typing import TYPE_CHECKING, Callable, Mapping, Protocol, Sequence

import numpy as np

from stitchjax.eval import baselines, metrics, scoring
from stitchjax.sample import inbetween
from stitchjax.skeleton import forward_kinematics
from stitchjax.sample.trained_model import InbetweenError, Model, load_model
from stitchjax.sample.sampling import Sampling

if TYPE_CHECKING:  # pragma: no cover
    from stitchjax.data.windows import Windows

BENCHMARK_LENGTHS = (5, 15, 30, 45)
PROTOCOL_LENGTHS = (10, 15, 30, 45, 50)
CONTEXT_FRAMES = 10  # official benchmark: 10 context frames, the last one (frame 9) is the start keyframe
START_FRAME = CONTEXT_FRAMES - 1
CONTACT_KEYS = ("penetration", "penetration_max", "penetration_share", "toe_clearance", "hover_share",
                "knee_turn_max", "joint_jump_max")  # ground truth has them too
METRIC_KEYS = ("apd", "spread", "spread_mid", "ade", "ade_best", "slde", "npss", "foot_slide", "l2p",
               "l2q") + CONTACT_KEYS


def metric_units(metres_per_unit: float) -> dict:
    return {
        "apd": "m",
        "spread": "cm (mean pairwise per-joint distance between samples, per frame)",
        "spread_mid": "cm (the same at the middle generated frame)",
        "ade": "m",
        "ade_best": "m",
        "slde": "m",
        "npss": "unitless",
        "foot_slide": "cm/frame",
        "l2p": "unitless (z-scored global positions)",
        "l2q": "unitless (global quaternions)",
        "penetration": "cm (mean depth of the foot joint-frames below the window's ground)",
        "penetration_max": "cm (the deepest foot joint-frame below the window's ground)",
        "penetration_share": "fraction of foot joint-frames below the window's ground",
        "toe_clearance": "cm (mean over swings of each swing's highest toe height above the window's ground)",
        "hover_share": f"fraction of generated leg-frames whose foot is more than {metrics.HOVER_HEIGHT_CM:g} cm up "
                       f"where the ground truth's is planted, in runs of {metrics.HOVER_MIN_FRAMES}+ frames",
        "knee_turn_max": "deg/frame (the largest change of a knee angle from one frame to the next, keyframes included)",
        "joint_jump_max": "cm/frame (the longest step of any joint from one frame to the next, keyframes included)",
        "data_positions": f"{metres_per_unit:g} m per unit",
    }


class Method(Protocol):
    """An in-betweening method as ``evaluate_protocol`` calls it (see the module docstring)."""

    def __call__(
        self, windows: "Windows", start: int, length: int, num_samples: int, seed: int
    ) -> tuple[np.ndarray, np.ndarray]: ...


# --------------------------------------------------------------------------- helpers


def _as_f64(x) -> np.ndarray:
    return np.asarray(x, dtype=np.float64)


def _bone_offsets(offsets, num_joints: int) -> np.ndarray:
    """Training bone offsets of joints 1..J-1 as (J-1, 3), from (J, 3) or (J-1, 3) (any leading 1s)."""
    off = _as_f64(offsets)
    off = off.reshape(-1, 3)
    if off.shape[0] == num_joints:
        off = off[1:]
    if off.shape[0] != num_joints - 1:
        raise ValueError(
            f"training offsets have {off.shape[0]} rows, expected {num_joints} (or {num_joints - 1} "
            "without the root); were the statistics computed on the same skeleton?"
        )
    return off


def _parents(windows) -> tuple:
    return tuple(int(p) for p in windows.skeleton.parents)


# --------------------------------------------------------------------------- official benchmark


def benchmark_baselines(
    train_stats, test_windows: "Windows", lengths: Sequence[int] = BENCHMARK_LENGTHS
) -> dict:
    """The official LAFAN1 benchmark of the zero-velocity and interpolation baselines.

    train_stats: ``Stats`` with mean (J*3,), std (J*3,) of training global positions and bone
        offsets (J, 3); test_windows: the test windows (N, T, J, ...), centred and facing-aligned.
    For each n in ``lengths``: 10 context frames, start keyframe = frame 9, target = frame 10 + n,
    scored frames 10 .. 10+n-1; local positions are the root trajectory plus the training offsets,
    as in the official code.
    Returns the nesting of :func:`evaluate_protocol`: {"n_windows": N, "samples": 1, "lengths": {"5":
    {"zerov": {"l2q", "l2p", "npss"}, "interp": {...}}, ...}, "units": {metric: unit}, "settings": {method:
    what it is}}; print it with :func:`format_protocol_table` (what :func:`print_benchmark_table` does).
    """
    rotations = _as_f64(test_windows.rotations)
    roots = _as_f64(test_windows.positions)[:, :, :1, :]
    num_windows, num_frames, num_joints = rotations.shape[:3]
    parents = _parents(test_windows)
    offsets = _bone_offsets(train_stats.offsets, num_joints)
    local_positions = np.concatenate(
        [roots, np.broadcast_to(offsets, (num_windows, num_frames, num_joints - 1, 3))], axis=2
    )
    results = {}
    for n in lengths:
        target = CONTEXT_FRAMES + n
        if target >= num_frames:
            raise ValueError(
                f"transition length {n} needs windows of at least {target + 1} frames, got {num_frames}"
            )
        scored = slice(CONTEXT_FRAMES, target)
        gt_q, gt_p = forward_kinematics(rotations[:, scored], local_positions[:, scored], parents)
        start_r, start_p = rotations[:, START_FRAME], local_positions[:, START_FRAME]
        predictions = {
            "zerov": baselines.zero_velocity(start_r, start_p, n),
            "interp": baselines.interpolation(
                start_r, start_p, rotations[:, target], local_positions[:, target], n
            ),
        }
        entry = {}
        for name, (pred_r, pred_p) in predictions.items():
            q, p = forward_kinematics(pred_r, pred_p, parents)
            entry[name] = {"l2q": metrics.l2q(q, gt_q), "l2p": metrics.l2p(p, gt_p, train_stats.mean, train_stats.std),
                           "npss": metrics.npss(q, gt_q)}
        results[str(n)] = entry
    units = metric_units(metrics.LAFAN1_METRES_PER_UNIT)
    return {
        "n_windows": int(num_windows),
        "samples": 1,
        "lengths": results,
        "units": {k: units[k] for k in ("l2q", "l2p", "npss", "data_positions")},
        "settings": dict(BENCHMARK_SETTINGS),
    }


BENCHMARK_SETTINGS = {"zerov": "frame 9 held (official)", "interp": "slerp/lerp 9..10+n (official)"}


# --------------------------------------------------------------------------- methods


def zero_velocity_method(windows, start, length, num_samples, seed):
    """Zero-velocity baseline as a ``Method``: the start keyframe held. Returns S = 1."""
    r, p = baselines.zero_velocity(
        _as_f64(windows.rotations)[:, start], _as_f64(windows.positions)[:, start], length
    )
    return r[None], p[None]


def interpolation_method(windows, start, length, num_samples, seed):
    """Interpolation baseline as a ``Method``: slerp / lerp between the two keyframes. S = 1."""
    target = start + length + 1
    rot, pos = _as_f64(windows.rotations), _as_f64(windows.positions)
    r, p = baselines.interpolation(rot[:, start], pos[:, start], rot[:, target], pos[:, target], length)
    return r[None], p[None]


BASELINE_METHODS: dict[str, Callable] = {"interp": interpolation_method, "zerov": zero_velocity_method}


def model_method(model, sampling: Sampling | None = None, **overrides):
    """The model as a ``Method``:
    ``method(windows, start, length, num_samples, seed) -> (rotations (S, B, L, J, 4), positions (S, B, L, J, 3))``.

    model: a :class:`stitchjax.sample.trained_model.Model` or a checkpoint path (loaded once). The method uses frames
    ``start`` and ``start + length + 1`` of each window and their foot-contact labels from ``windows.contacts``
    (the keyframes' character state, as in training); it returns the L generated frames only.
    sampling: a :class:`stitchjax.sample.sampling.Sampling` (default ``Sampling.paper()``: the paper's noise, no
    search, no foot locking); overrides: its fields as keywords on top of it (search, noise_scale,
    noise_correlation, noise_ramp_steps, foot_lock; None keeps a field). With foot locking
    (:mod:`stitchjax.sample.footlock`) the method's ``foot_lock_counts`` dict adds up its planted, changed and
    lifted leg-frames.
    """
    if not isinstance(model, Model):
        model = load_model(model)
    sampling = (Sampling.paper() if sampling is None else sampling).replace(**overrides)

    def method(windows, start, length, num_samples, seed):
        inbetween.check_skeleton(model, windows.skeleton)
        target = start + length + 1
        if not 0 <= start < target < windows.rotations.shape[1]:
            raise InbetweenError(f"keyframes {start} and {target} are outside windows of "
                                 f"{windows.rotations.shape[1]} frames")
        rot, pos = np.asarray(windows.rotations), np.asarray(windows.positions)
        contacts = np.asarray(windows.contacts)
        rotations, positions, _ = inbetween.transitions_in_frame(
            model, inbetween.Keyframes(rot[:, start], pos[:, start], contacts[:, start]),
            inbetween.Keyframes(rot[:, target], pos[:, target], contacts[:, target]), length, num_samples, seed,
            sampling, foot_lock_counts=method.foot_lock_counts)
        # (B, S, L+2, ...) -> generated frames, samples first: (S, B, L, ...)
        return (np.swapaxes(rotations[:, :, 1:-1], 0, 1), np.swapaxes(positions[:, :, 1:-1], 0, 1))

    method.model = model
    method.sampling = sampling
    method.foot_lock_counts = {}
    return method


def evaluation_method(checkpoint, sampling: Sampling | None = None, **overrides):
    """:func:`model_method` of a checkpoint folder (``checkpoint`` may also be a loaded ``Model``)."""
    model = checkpoint if isinstance(checkpoint, Model) else load_model(checkpoint)
    return model_method(model, sampling, **overrides)


# --------------------------------------------------------------------------- protocol


def _check_protocol_lengths(lengths: Sequence[int], start: int, num_frames: int) -> None:
    for length in lengths:
        if start + length + 1 >= num_frames or length < 1:
            raise ValueError(
                f"transition length {length} with start keyframe {start} needs windows of at least "
                f"{start + length + 2} frames; these have {num_frames}"
            )


def _predict(name: str, method: Callable, windows, start: int, length: int, samples: int, seed: int,
             parents: tuple, expected: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Global rotations and positions (S, b, L, J, ...) of one method's transitions on a chunk of windows,
    checked to be (S,) + ``expected`` (b, L, J) + (4,) and (3,)."""
    pred_r, pred_p = method(windows, start, length, samples, seed)
    pred_r, pred_p = _as_f64(pred_r), _as_f64(pred_p)
    if pred_r.ndim != 5 or pred_r.shape[1:4] != expected or pred_p.shape[:4] != pred_r.shape[:4]:
        raise ValueError(
            f"method {name!r} returned rotations {pred_r.shape} and positions {pred_p.shape}; "
            f"expected (S, {expected[0]}, {length}, {expected[2]}, 4) and (S, ..., 3)"
        )
    return forward_kinematics(pred_r, pred_p, parents)


def _progress_bar(total: int):
    """A progress bar on stderr counting method calls (one per method, chunk and length)."""
    from tqdm.auto import tqdm

    return tqdm(total=total, desc="evaluate", unit="batch", file=sys.stderr)


def _protocol_length(methods: Mapping[str, Callable], windows: "Windows", truth: scoring.Truth, chunks: list,
                     length: int, start: int, samples: int, seed: int, metres_per_unit: float, bar) -> dict:
    """One length's entry of :func:`evaluate_protocol`: {name: {metric: value}, "ground_truth": {...}}."""
    target = start + length + 1
    scored = slice(start + 1, target)
    accumulators = {name: scoring.MethodSums() for name in methods}
    npss_power = 0.0
    gt_slide, gt_slide_count = 0.0, 0.0
    gt_contact = scoring.ContactSums()
    for chunk_index, chunk in enumerate(chunks):
        gt_q, gt_p = truth.rotations[chunk, scored], truth.positions[chunk, scored]
        ground = truth.ground[chunk]
        _, power = metrics.npss_parts(gt_q, gt_q)
        npss_power += float(power.sum())
        weighted, count = metrics.foot_slide_parts(truth.positions[chunk, start + 1 : target + 1], ground,
                                                   **truth.slide_kw)
        gt_slide += float(weighted.sum())
        gt_slide_count += float(count.sum())
        gt_contact.add(gt_p, truth.positions[chunk, start:target + 1], ground, truth.contact_kw)
        chunk_windows = windows[chunk]
        call_seed = int(seed) * 1_000_003 + length * 10_007 + chunk_index
        target_pose = truth.positions[chunk, target][None, :, None]  # (1, b, 1, J, 3)
        start_pose = truth.positions[chunk, start][None, :, None]
        expected = (gt_q.shape[0], length, gt_q.shape[2])
        for name, method in methods.items():
            q, p = _predict(name, method, chunk_windows, start, length, samples, call_seed, truth.parents,
                            expected)
            accumulators[name].add(q, p, gt_q, gt_p, target_pose, ground, truth, start_pose)
            if bar is not None:
                bar.update(1)
    entry = {name: acc.result(npss_power, metres_per_unit) for name, acc in accumulators.items()}
    entry["ground_truth"] = {"foot_slide": gt_slide / gt_slide_count if gt_slide_count > 0 else 0.0,
                             **gt_contact.result()}
    return entry


@dataclasses.dataclass(frozen=True)
class Protocol:
    """What :func:`evaluate_protocol` measures: transition ``lengths`` (frames), ``samples`` per window, the
    ``start`` keyframe's frame, the contact joints ``feet`` (left foot, left toe, right foot, right toe),
    ``metres_per_unit`` of the windows' positions, their ``up_axis`` and the ``seed`` of the first call."""

    lengths: Sequence[int] = PROTOCOL_LENGTHS
    samples: int = 10
    start: int = START_FRAME
    feet: Sequence[int] = (3, 4, 7, 8)
    metres_per_unit: float = metrics.LAFAN1_METRES_PER_UNIT
    up_axis: int = 1
    seed: int = 0


def evaluate_protocol(methods: Mapping[str, Callable], windows: "Windows", stats, protocol: Protocol | None = None, *,
                      batch_size: int = 256, progress: bool = True, settings: Mapping[str, str] | None = None,
                      **overrides) -> dict:
    """The paper's evaluation protocol (docs/design.md §6) for several methods through one code path.

    methods: name -> ``Method`` (e.g. {"model": ..., **BASELINE_METHODS}).
    windows: test windows (N, T, J, ...), centred and facing-aligned; stats: anything with
        ``mean`` and ``std`` (J*3,) of training global positions (for L2P).
    protocol: a :class:`Protocol` (default ``Protocol()``: the paper's lengths, 10 samples); overrides: its
        fields as keywords on top of it (``lengths=(10, 30)``, ``samples=2``, ...). batch_size: windows per
        call of a method; progress: a progress bar on stderr.
    For each L in ``lengths``: start keyframe = ``start``, target keyframe = start + L + 1, the L
    generated frames start+1 .. start+L are scored. Foot slide: for every generated frame, the
    displacement to the next frame (the last one's is to the target keyframe), weighted by the
    height above the window's ground (lowest ground-truth foot height in the whole window).
    Ground contact (cm, against the same ground, ``metrics.ground_penetration_parts`` /
    ``swing_clearance_parts``): "penetration" the mean depth of the generated foot joint-frames below the
    ground, "penetration_max" the deepest, "penetration_share" the share of foot joint-frames below it, and
    "toe_clearance" the mean of each swing's highest toe height (toes: ``feet[1::2]``, the order left foot,
    left toe, right foot, right toe; swings from the start to the target keyframe, a toe moving faster than
    ``metrics.SWING_SPEED_CM_PER_S``; None when no toe swings). Leg motion (``metrics.hover_parts``,
    ``knee_turn_max``, ``joint_jump_max``): "hover_share" the share of generated leg-frames whose foot is off the
    ground where the ground truth's is planted (in runs of ``metrics.HOVER_MIN_FRAMES`` frames or more),
    "knee_turn_max" the largest change of a knee angle per frame and "joint_jump_max" the longest step of any
    joint per frame, both from the start keyframe to the target keyframe. The ground truth gets them too.
    With S samples per window, ADE, SLDE, NPSS, L2P and L2Q are averaged over samples, ADE best
    keeps the best sample of each window, APD averages the sample pairs of each window and foot
    slide pools all samples. A method returning one sample is deterministic (APD 0). "spread" is the
    per-frame, per-joint pairwise distance in cm and "spread_mid" the same at the middle generated frame.
    settings: optional method name -> a short description (e.g. "search 16, noise x1"), kept in the
    results and printed beside the method.
    Returns {"n_windows", "samples", "lengths": {"L": {name: {metric: value}, "ground_truth":
    {"foot_slide", "penetration", ...: value}}}, "units": {...}}; see ``metric_units`` for the units of each metric.
    """
    protocol = dataclasses.replace(protocol or Protocol(), **overrides)
    lengths, samples, start, feet = protocol.lengths, protocol.samples, protocol.start, protocol.feet
    metres_per_unit, up_axis, seed = protocol.metres_per_unit, protocol.up_axis, protocol.seed
    num_windows, num_frames = np.shape(windows.rotations)[:2]
    _check_protocol_lengths(lengths, start, num_frames)
    truth = scoring.ground_truth(windows, stats, feet, metres_per_unit, up_axis)
    chunks = [slice(i, min(i + batch_size, num_windows)) for i in range(0, num_windows, batch_size)]
    bar = _progress_bar(len(lengths) * len(chunks) * len(methods)) if progress else None
    results = {str(length): _protocol_length(methods, windows, truth, chunks, length, start, samples, seed,
                                             metres_per_unit, bar)
               for length in lengths}
    if bar is not None:
        bar.close()
    return {
        "n_windows": int(num_windows),
        "samples": int(samples),
        "lengths": results,
        "units": metric_units(metres_per_unit),
        "settings": {name: str((settings or {}).get(name, "")) for name in methods},
    }
