"""Evaluation: the official LAFAN1 baseline benchmark and the paper's protocol (DESIGN.md §4, §6).

Two entry points, both float64 numpy:

* ``benchmark_baselines(train_stats, test_windows)`` reproduces the official LAFAN1 benchmark of the
  zero-velocity and interpolation baselines (L2Q, L2P, NPSS at n = 5, 15, 30, 45).
* ``evaluate_protocol(methods, windows, stats)`` runs any number of in-betweening *methods* through
  one code path and reports APD, ADE, ADE best, SLDE, NPSS, foot slide, L2P and L2Q per length.

A *method* is any callable with the signature of ``Method.__call__``::

    method(windows, start, length, num_samples, seed) -> (rotations, positions)

    windows      a chunk of B windows (``stitchjax.windows.Windows``: rotations (B, T, J, 4),
                 positions (B, T, J, 3), contacts (B, T, 4), skeleton, fps)
    start        index of the start keyframe; the target keyframe is start + length + 1.
                 A method may look at frames <= start and at the target frame only.
    length       number of frames to generate (frames start+1 .. start+length)
    num_samples  samples wanted per window (a deterministic method may return 1)
    seed         int, different for every call; use it for all randomness
    returns      local rotations (S, B, L, J, 4) and local positions (S, B, L, J, 3), S = 1 or num_samples

``zero_velocity_method`` and ``interpolation_method`` are the baselines in that form; a trained model
becomes one through ``stitchjax.inbetween`` (see bin/evaluate).
"""
from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Callable, Mapping, Protocol, Sequence

import numpy as np

from stitchjax import baselines, metrics
from stitchjax.skeleton import forward_kinematics

if TYPE_CHECKING:  # pragma: no cover
    from stitchjax.windows import Windows

BENCHMARK_LENGTHS = (5, 15, 30, 45)
PROTOCOL_LENGTHS = (10, 15, 30, 45, 50)
CONTEXT_FRAMES = 10  # official benchmark: 10 context frames, the last one (frame 9) is the start keyframe
START_FRAME = CONTEXT_FRAMES - 1
METRIC_KEYS = ("apd", "spread", "spread_mid", "ade", "ade_best", "slde", "npss", "foot_slide", "l2p", "l2q")


def _units(metres_per_unit: float) -> dict:
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
    units = _units(metrics.LAFAN1_METRES_PER_UNIT)
    return {
        "n_windows": int(num_windows),
        "samples": 1,
        "lengths": results,
        "units": {k: units[k] for k in ("l2q", "l2p", "npss", "data_positions")},
        "settings": dict(BENCHMARK_SETTINGS),
    }


BENCHMARK_SETTINGS = {"zerov": "frame 9 held (official)", "interp": "slerp/lerp 9..10+n (official)"}


def format_benchmark_table(results: Mapping) -> str:
    """The official benchmark in the table layout of :func:`format_protocol_table` (one row per length and
    method, one column per metric with its unit)."""
    return format_protocol_table(results, title=f"LAFAN1 benchmark (official L2Q / L2P / NPSS, float64) on "
                                                f"{results['n_windows']} test windows")


def print_benchmark_table(results: Mapping, file=None) -> None:
    """Print ``format_benchmark_table(results)`` (to stdout by default)."""
    print(format_benchmark_table(results), file=file or sys.stdout)


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


# --------------------------------------------------------------------------- protocol


class _Accumulator:
    """Per-method running sums so windows can be processed in chunks."""

    def __init__(self):
        self.sums = dict.fromkeys(
            ("ade", "ade_best", "slde", "apd", "spread", "spread_mid", "npss", "l2p", "l2q", "slide",
             "slide_count"), 0.0
        )
        self.count = 0  # sample-windows
        self.windows = 0

    def result(self, npss_power: float, metres_per_unit: float) -> dict:
        s, n, w = self.sums, max(self.count, 1), max(self.windows, 1)
        samples = n / w
        return {
            "apd": s["apd"] / w * metres_per_unit,
            "spread": s["spread"] / w * metres_per_unit * 100.0,
            "spread_mid": s["spread_mid"] / w * metres_per_unit * 100.0,
            "ade": s["ade"] / n * metres_per_unit,
            "ade_best": s["ade_best"] / w * metres_per_unit,
            "slde": s["slde"] / n * metres_per_unit,
            "npss": s["npss"] / (samples * npss_power),
            "foot_slide": s["slide"] / s["slide_count"] if s["slide_count"] > 0 else 0.0,
            "l2p": s["l2p"] / n,
            "l2q": s["l2q"] / n,
        }


def evaluate_protocol(
    methods: Mapping[str, Callable],
    windows: "Windows",
    stats,
    lengths: Sequence[int] = PROTOCOL_LENGTHS,
    samples: int = 10,
    start: int = START_FRAME,
    feet: Sequence[int] = (3, 4, 7, 8),
    metres_per_unit: float = metrics.LAFAN1_METRES_PER_UNIT,
    up_axis: int = 1,
    batch_size: int = 256,
    seed: int = 0,
    progress: bool = True,
    settings: Mapping[str, str] | None = None,
) -> dict:
    """The paper's evaluation protocol (DESIGN.md §6) for several methods through one code path.

    methods: name -> ``Method`` (e.g. {"model": ..., **BASELINE_METHODS}).
    windows: test windows (N, T, J, ...), centred and facing-aligned; stats: anything with
        ``mean`` and ``std`` (J*3,) of training global positions (for L2P).
    For each L in ``lengths``: start keyframe = ``start``, target keyframe = start + L + 1, the L
    generated frames start+1 .. start+L are scored. Foot slide: for every generated frame, the
    displacement to the next frame (the last one's is to the target keyframe), weighted by the
    height above the window's ground (lowest ground-truth foot height in the whole window).
    With S samples per window, ADE, SLDE, NPSS, L2P and L2Q are averaged over samples, ADE best
    keeps the best sample of each window, APD averages the sample pairs of each window and foot
    slide pools all samples. A method returning one sample is deterministic (APD 0). "spread" is the
    per-frame, per-joint pairwise distance in cm and "spread_mid" the same at the middle generated frame.
    settings: optional method name -> a short description (e.g. "search 16, noise x1"), kept in the
    results and printed beside the method.
    Returns {"n_windows", "samples", "lengths": {"L": {name: {metric: value}, "ground_truth":
    {"foot_slide": value}}}, "units": {...}}; see ``_units`` for the units of each metric.
    """
    rotations_all = _as_f64(windows.rotations)
    positions_all = _as_f64(windows.positions)
    num_windows, num_frames = rotations_all.shape[:2]
    parents = _parents(windows)
    for length in lengths:
        if start + length + 1 >= num_frames or length < 1:
            raise ValueError(
                f"transition length {length} with start keyframe {start} needs windows of at least "
                f"{start + length + 2} frames; these have {num_frames}"
            )
    mean, std = _as_f64(stats.mean), _as_f64(stats.std)
    gt_rot_all, gt_pos_all = forward_kinematics(rotations_all, positions_all, parents)
    ground_all = metrics.ground_heights(gt_pos_all, feet, up_axis)
    slide_kw = dict(feet=feet, metres_per_unit=metres_per_unit, up_axis=up_axis)

    chunks = [slice(i, min(i + batch_size, num_windows)) for i in range(0, num_windows, batch_size)]
    steps = [(length, c) for length in lengths for c in range(len(chunks))]
    results = {}
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(steps) * len(methods), desc="evaluate", unit="batch", file=sys.stderr)
    for length in lengths:
        target = start + length + 1
        scored = slice(start + 1, target)
        accumulators = {name: _Accumulator() for name in methods}
        npss_power = 0.0
        gt_slide, gt_slide_count = 0.0, 0.0
        for chunk_index, chunk in enumerate(chunks):
            gt_q, gt_p = gt_rot_all[chunk, scored], gt_pos_all[chunk, scored]
            ground = ground_all[chunk]
            _, power = metrics.npss_parts(gt_q, gt_q)
            npss_power += float(power.sum())
            weighted, count = metrics.foot_slide_parts(gt_pos_all[chunk, start + 1 : target + 1], ground, **slide_kw)
            gt_slide += float(weighted.sum())
            gt_slide_count += float(count.sum())
            chunk_windows = windows[chunk]
            call_seed = int(seed) * 1_000_003 + length * 10_007 + chunk_index
            for name, method in methods.items():
                pred_r, pred_p = method(chunk_windows, start, length, samples, call_seed)
                pred_r, pred_p = _as_f64(pred_r), _as_f64(pred_p)
                expected = (gt_q.shape[0], length, gt_q.shape[2])
                if pred_r.ndim != 5 or pred_r.shape[1:4] != expected or pred_p.shape[:4] != pred_r.shape[:4]:
                    raise ValueError(
                        f"method {name!r} returned rotations {pred_r.shape} and positions {pred_p.shape}; "
                        f"expected (S, {expected[0]}, {length}, {expected[2]}, 4) and (S, ..., 3)"
                    )
                q, p = forward_kinematics(pred_r, pred_p, parents)  # (S, b, L, J, ...)
                acc = accumulators[name]
                displacement = metrics.displacement_per_window(p, gt_p)  # (S, b)
                acc.sums["ade"] += float(displacement.sum())
                acc.sums["ade_best"] += float(displacement.min(axis=0).sum())
                acc.sums["slde"] += float(metrics.displacement_per_window(p[:, :, -1:], gt_p[:, -1:]).sum())
                acc.sums["apd"] += float(metrics.apd_per_window(p).sum())
                acc.sums["spread"] += float(metrics.joint_spread_per_window(p).sum())
                acc.sums["spread_mid"] += float(metrics.joint_spread_per_window(p, frame=length // 2).sum())
                acc.sums["npss"] += float(metrics.npss_parts(q, gt_q)[0].sum())
                acc.sums["l2p"] += float(metrics.l2p_per_window(p, gt_p, mean, std).sum())
                acc.sums["l2q"] += float(metrics.l2q_per_window(q, gt_q).sum())
                target_pose = gt_pos_all[chunk, target][None, :, None]  # (1, b, 1, J, 3)
                full = np.concatenate([p, np.broadcast_to(target_pose, p[:, :, :1].shape)], axis=2)
                weighted, count = metrics.foot_slide_parts(full, ground, **slide_kw)
                acc.sums["slide"] += float(weighted.sum())
                acc.sums["slide_count"] += float(count.sum())
                acc.count += displacement.size
                acc.windows += displacement.shape[1]
                if bar is not None:
                    bar.update(1)
        entry = {name: acc.result(npss_power, metres_per_unit) for name, acc in accumulators.items()}
        entry["ground_truth"] = {"foot_slide": gt_slide / gt_slide_count if gt_slide_count > 0 else 0.0}
        results[str(length)] = entry
    if bar is not None:
        bar.close()
    return {
        "n_windows": int(num_windows),
        "samples": int(samples),
        "lengths": results,
        "units": _units(metres_per_unit),
        "settings": {name: str((settings or {}).get(name, "")) for name in methods},
    }


def format_protocol_table(results: Mapping, title: str | None = None) -> str:
    """One row per (length, method), one column per metric, units in the header (4 decimals), a units
    legend below. ``results``: as :func:`evaluate_protocol` or :func:`benchmark_baselines` return them."""
    units = results.get("units", {})
    short = {"m": "m", "cm/frame": "cm/f", "cm": "cm"}
    cols = [(k, f"{k} ({short.get(units.get(k, '').split(' ')[0], '-')})") for k in METRIC_KEYS if k in _first_row(results)]
    settings = results.get("settings", {})
    width = max([12] + [len(n) for n in settings])
    setting_width = max([7] + [len(v) for v in settings.values()])
    header = f"{'L':>3} {'method':<{width}} {'setting':<{setting_width}}" + "".join(f" {title:>15}" for _, title in cols)
    if title is None:
        title = f"Protocol on {results['n_windows']} windows, {results['samples']} samples per window"
    lines = [title, header, "-" * len(header)]
    for length, entry in results["lengths"].items():
        for name, values in entry.items():
            if name == "ground_truth":
                continue
            lines.append(
                f"{length:>3} {name:<{width}} {settings.get(name, ''):<{setting_width}}"
                + "".join(f" {values.get(k, float('nan')):>15.4f}" for k, _ in cols)
            )
        gt = entry.get("ground_truth", {})
        if "foot_slide" in gt:
            cells = "".join(
                f" {gt['foot_slide']:>15.4f}" if k == "foot_slide" else f" {'':>15}" for k, _ in cols
            )
            lines.append(f"{length:>3} {'ground_truth':<{width}} {'':<{setting_width}}" + cells)
    lines.append("units: " + "; ".join(f"{k} {units[k]}" for k, _ in cols if k in units))
    return "\n".join(lines)


def _first_row(results: Mapping) -> dict:
    for entry in results["lengths"].values():
        for name, values in entry.items():
            if name != "ground_truth":
                return values
    return {}
