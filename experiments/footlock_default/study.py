"""Foot locking's default settings: sample once, score every candidate on the cached transitions, choose by the rule.

    python experiments/footlock_default/study.py sample --set validation --sampling default --cache /tmp/fl
    python experiments/footlock_default/study.py grid --candidates candidates.json --cache /tmp/fl --json grid.json
    python experiments/footlock_default/study.py choose --grid grid.json --json choice.json

sample: the model (--checkpoint, default the release model) generates 10 samples per window of one set at one
  sampling and every length; the transitions and the predicted contacts are cached (the pass is not run), so the
  grid re-runs only the pass. Sets (none holds a subject5 test take):
    validation  the model's validation takes (its config's data.validation_files), 65-frame windows every 40;
    artefacts   the test takes' three motions by training subjects (fallAndGetUp1_subject4, ground1_subject1,
                obstacles1_subject1), cut the same way: fast falls and floor work, where jumps and knee turns show;
    dev         four other training takes, 64 windows: for trying the pass while it was written, never for choosing.
  Samplings: paper (noise x1, independent per frame, no ramp) and default (the model's model.json "sampling",
  what bin/inbetween uses).
grid: each candidate (FootLockConfig fields) on every cached set, sampling and length, scored as bin/evaluate scores
  (stitchjax.eval.scoring) against the model alone on the same transitions.
choose: the rule of README.md over the grid.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import subprocess
import sys
import time

import jax
import numpy as np

from stitchjax.data import datasets, lafan1
from stitchjax.eval import evaluate, metrics, scoring
from stitchjax.sample import footlock, inbetween, trained_model
from stitchjax.skeleton import LAFAN1_FEET, forward_kinematics

ARTEFACT_TAKES = ("fallAndGetUp1_subject4", "ground1_subject1", "obstacles1_subject1")
DEV_TAKES = ("walk4_subject1", "multipleActions1_subject3", "pushAndFall1_subject4", "dance1_subject2")
DEV_WINDOWS = 64
LENGTHS = {"validation": (10, 30, 50), "artefacts": (30, 50), "dev": (30, 50)}
SAMPLES = 10
CHUNK = 128  # windows per sampling call
BLOCK = 64  # windows per call of the pass: one compiled pass per length serves every set
START = evaluate.START_FRAME
FEET = LAFAN1_FEET


def cpu_name() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            return next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        return platform.processor() or platform.machine()


def provenance(started: float) -> dict:
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True,
                           text=True).stdout.strip()
    return {"command": "python " + " ".join(sys.argv), "commit": commit + ("+changes" if dirty else ""),
            "machine": f"{cpu_name()}, {os.cpu_count()} CPUs, jax {jax.__version__}",
            "wall_s": round(time.time() - started, 1)}


def load_model(checkpoint):
    return trained_model.load_model(checkpoint) if checkpoint else trained_model.pretrained()


def windows_of(name: str, data: str, model):
    """(windows, training statistics) of one set."""
    if name == "validation":
        return datasets.validation_windows(data, model.config.data)
    takes = ARTEFACT_TAKES if name == "artefacts" else DEV_TAKES
    windows = lafan1.load_file_windows([os.path.join(data, f"{t}.bvh") for t in takes], lafan1.TEST_WINDOW,
                                       lafan1.TEST_OFFSET)
    if name == "dev":
        windows = windows[np.linspace(0, windows.num_windows - 1, DEV_WINDOWS).round().astype(int)]
    return windows, lafan1.train_statistics(data)


def sampling_of(name: str, model):
    """The Sampling of the set (foot locking on, so that the pass is reached and its inputs captured)."""
    return (model.paper_sampling if name == "paper" else model.sampling).replace(foot_lock=True)


class _Capture:
    """Stands in for ``footlock.lock_transitions`` while sampling: keeps what the pass would be given (the
    transitions and the model's predicted contacts) and returns the transitions unchanged."""

    def __init__(self):
        self.parts = []

    def __call__(self, rotations, positions, contacts, *args, **kwargs):
        self.parts.append((rotations, positions[..., 0, :], positions[:, 0, 0, 1:], contacts))
        return rotations, positions, {}


def sample(args) -> None:
    started = time.time()
    model = load_model(args.checkpoint)
    windows, _ = windows_of(args.set, args.data, model)
    sampling = sampling_of(args.sampling, model)
    rot, pos, con = (np.asarray(x) for x in (windows.rotations, windows.positions, windows.contacts))
    os.makedirs(args.cache, exist_ok=True)
    real = footlock.lock_transitions
    for length in LENGTHS[args.set]:
        path = cache_path(args.cache, args.set, args.sampling, length)
        if os.path.exists(path):
            print(f"{path}: cached", flush=True)
            continue
        target = START + length + 1
        capture = _Capture()
        footlock.lock_transitions = capture
        try:
            for k, i in enumerate(range(0, len(rot), CHUNK)):
                c = slice(i, i + CHUNK)
                inbetween.transitions_in_frame(
                    model, (rot[c, START], pos[c, START], con[c, START]), (rot[c, target], pos[c, target],
                                                                           con[c, target]),
                    length, SAMPLES, seed=length * 10_007 + k, sampling=sampling)
        finally:
            footlock.lock_transitions = real
        parts = list(zip(*capture.parts))
        np.savez(path, rotations=np.concatenate(parts[0]), roots=np.concatenate(parts[1]),
                 offsets=np.concatenate(parts[2]), contacts=np.concatenate(parts[3]).astype(np.float32))
        print(f"{path}: {len(rot)} windows x {SAMPLES} samples, {time.time() - started:.0f} s", flush=True)
    info = {"set": args.set, "sampling": sampling.noise, "windows": int(len(rot)), "samples": SAMPLES,
            "lengths": LENGTHS[args.set], "model": model.source, **provenance(started)}
    with open(os.path.join(args.cache, f"{args.set}_{args.sampling}.json"), "w") as f:
        json.dump(info, f, indent=1)


def load_cache(path: str):
    """(rotations (B, S, T, J, 4), local positions (B, S, T, J, 3), contacts (B, S, T, C)) of one cached file."""
    cached = np.load(path)
    rotations, roots, offsets = cached["rotations"], cached["roots"], cached["offsets"]
    positions = np.empty(rotations.shape[:-1] + (3,))
    positions[..., 1:, :] = offsets[:, None, None]
    positions[..., 0, :] = roots
    return rotations, positions, cached["contacts"]


def lock_blocks(rotations, positions, contacts, skeleton, config):
    """``footlock.lock_transitions`` over blocks of :data:`BLOCK` windows (the last one padded), so every set shares
    one compiled pass per length. Returns (rotations, stats) of all windows."""
    num = len(rotations)
    parts, stats = [], []
    for i in range(0, num, BLOCK):
        pick = np.minimum(np.arange(i, i + BLOCK), num - 1)
        locked, _, block_stats = footlock.lock_transitions(rotations[pick], positions[pick], contacts[pick], skeleton,
                                                           FEET, config, sample_axis=1)
        keep = min(BLOCK, num - i)
        parts.append(locked[:keep])
        stats.append({k: v[:keep] for k, v in block_stats.items()})
    return np.concatenate(parts), {k: np.concatenate([b[k] for b in stats]) for k in stats[0]}


def score(rotations, positions, truth, length: int, npss_power: float) -> dict:
    """bin/evaluate's figures (stitchjax.eval.scoring) of transitions (B, S, T, ...) with both keyframes."""
    target = START + length + 1
    q, p = forward_kinematics(rotations[:, :, 1:-1], positions[:, :, 1:-1], truth.parents)
    q, p = np.swapaxes(q, 0, 1), np.swapaxes(p, 0, 1)  # (S, B, L, ...) as a method returns them
    sums = scoring.MethodSums()
    sums.add(q, p, truth.rotations[:, START + 1:target], truth.positions[:, START + 1:target],
             truth.positions[:, target][None, :, None], truth.ground, truth, truth.positions[:, START][None, :, None])
    return sums.result(npss_power, metrics.LAFAN1_METRES_PER_UNIT)


def ground_truth_row(truth, length: int) -> dict:
    target = START + length + 1
    weighted, count = metrics.foot_slide_parts(truth.positions[:, START + 1:target + 1], truth.ground,
                                               **truth.slide_kw)
    contact = scoring.ContactSums()
    contact.add(truth.positions[:, START + 1:target], truth.positions[:, START:target + 1], truth.ground,
                truth.contact_kw)
    return {"foot_slide": float(weighted.sum() / max(count.sum(), 1.0)), **contact.result()}


def grid(args) -> None:
    started = time.time()
    candidates = json.load(open(args.candidates))
    model = load_model(args.checkpoint)
    out = {"candidates": candidates, "rows": {}}
    for name in args.sets:
        windows, stats = windows_of(name, args.data, model)
        truth = scoring.ground_truth(windows, stats, FEET, metrics.LAFAN1_METRES_PER_UNIT, 1)
        for sampling in args.samplings:
            for length in [n for n in LENGTHS[name] if not args.lengths or n in args.lengths]:
                path = cache_path(args.cache, name, sampling, length)
                if not os.path.exists(path):
                    raise SystemExit(f"{path} is missing: run the sample stage first")
                rotations, positions, contacts = load_cache(path)
                target = START + length + 1
                gt_q = truth.rotations[:, START + 1:target]
                npss_power = float(metrics.npss_parts(gt_q, gt_q)[1].sum())
                row = {"model": score(rotations, positions, truth, length, npss_power),
                       "ground_truth": ground_truth_row(truth, length)}
                for candidate, fields in candidates.items():
                    t0 = time.perf_counter()
                    locked, stats_ = lock_blocks(rotations, positions, contacts, windows.skeleton,
                                                 footlock.FootLockConfig(**fields))
                    seconds = time.perf_counter() - t0
                    row[candidate] = score(locked, positions, truth, length, npss_power)
                    inner = {k: v[:, :, 1:-1] for k, v in stats_.items()}
                    row[candidate].update({f"{k}_share": float(v.mean()) for k, v in inner.items()},
                                          pass_s=round(seconds, 2))
                    m, c = row["model"], row[candidate]
                    print(f"{name}/{sampling}/L{length} {candidate}: slide {m['foot_slide']:.3f} -> "
                          f"{c['foot_slide']:.3f}, pen {m['penetration']:.2f} -> {c['penetration']:.2f}, hover "
                          f"{m['hover_share']:.3f} -> {c['hover_share']:.3f}, knee {m['knee_turn_max']:.1f} -> "
                          f"{c['knee_turn_max']:.1f} (gt {row['ground_truth']['knee_turn_max']:.1f}), jump "
                          f"{m['joint_jump_max']:.1f} -> {c['joint_jump_max']:.1f}, " + ", ".join(
                              f"{k} {100 * (c[k] / m[k] - 1):+.1f}%" for k in ("ade", "slde", "npss", "apd"))
                          + f" ({seconds:.0f} s)", flush=True)
                out["rows"][f"{name}/{sampling}/L{length}"] = row
                with open(args.json, "w") as f:  # after every row, so a stopped grid keeps what it scored
                    json.dump({**out, **provenance(started)}, f, indent=1)


COST_LIMITS = {"ade": 3.0, "npss": 3.0, "slde": 3.0}  # % above the model alone's, at most
APD_LIMIT = 5.0  # % either way
TARGETS = {"foot_slide": 0.4, "penetration": 0.5, "hover_share": 0.05}  # at most
KNEE_MARGIN = 6.0  # degrees per frame above the ground truth's fastest knee turn, at most
TOLERANCE = 0.01  # cm or degrees: the pass computes in float32, the scores in float64


def checks(row: dict, candidate: str, validation: bool) -> dict:
    """{check name: (passed, value, limit)} of one candidate on one set, sampling and length (RULE in README.md)."""
    model, truth, c = row["model"], row["ground_truth"], row[candidate]
    out = {"joint_jump_max": (c["joint_jump_max"] <= model["joint_jump_max"] + TOLERANCE, c["joint_jump_max"],
                              model["joint_jump_max"]),
           "knee_turn_max": (c["knee_turn_max"] <= truth["knee_turn_max"] + KNEE_MARGIN + TOLERANCE,
                             c["knee_turn_max"], truth["knee_turn_max"] + KNEE_MARGIN)}
    if validation:
        for key, limit in COST_LIMITS.items():
            change = 100.0 * (c[key] / model[key] - 1.0)
            out[key] = (change <= limit, change, limit)
        change = 100.0 * (c["apd"] / model["apd"] - 1.0)
        out["apd"] = (abs(change) <= APD_LIMIT, change, APD_LIMIT)
        for key, limit in TARGETS.items():
            out[key] = (c[key] <= limit, c[key], limit)
    return out


def choose(args) -> None:
    """The rule of README.md over the grid's JSONs: every check passed at every set, sampling and length; of those
    passing, the lowest foot slide on the validation split (mean over its lengths and both samplings), ties within
    0.005 cm/frame broken by the lower hover share. None passing: the one failing the fewest checks, then the
    smallest worst excess over a limit (relative)."""
    started = time.time()
    grids = [json.load(open(path)) for path in args.grid]
    candidates = {name: fields for g in grids for name, fields in g["candidates"].items()}
    rows = {}
    for g in grids:
        for key, row in g["rows"].items():
            rows.setdefault(key, {}).update(row)
    summary = {}
    for name in candidates:
        failed, worst, slides, hovers = [], 0.0, [], []
        for key, row in rows.items():
            validation = key.startswith("validation/")
            for check, (ok, value, limit) in checks(row, name, validation).items():
                if not ok:
                    failed.append(f"{key} {check}: {value:.3f} (limit {limit:.3f})")
                    worst = max(worst, abs(value - limit) / max(abs(limit), 1e-9))
            if validation:
                slides.append(row[name]["foot_slide"])
                hovers.append(row[name]["hover_share"])
        summary[name] = {"fields": candidates[name], "passed": not failed, "failed": failed, "worst_excess": worst,
                         "slide": float(np.mean(slides)), "hover": float(np.mean(hovers))}
    passing = [n for n, s in summary.items() if s["passed"]]
    if passing:
        best = min(summary[n]["slide"] for n in passing)
        close = [n for n in passing if summary[n]["slide"] <= best + 0.005]
        chosen = min(close, key=lambda n: (summary[n]["hover"], summary[n]["slide"]))
    else:
        chosen = min(summary, key=lambda n: (len(summary[n]["failed"]), summary[n]["worst_excess"]))
    for name, s in sorted(summary.items(), key=lambda kv: kv[1]["slide"]):
        print(f"{name:>24}: slide {s['slide']:.3f}, hover {s['hover']:.4f}, "
              f"{'passes' if s['passed'] else str(len(s['failed'])) + ' failed checks'}"
              f"{'   <- chosen' if name == chosen else ''}")
        for line in s["failed"][:6]:
            print(f"{'':>26}{line}")
    print(f"chosen: {chosen} {candidates[chosen]} ({'passes' if summary[chosen]['passed'] else 'NO candidate passes'})")
    with open(args.json, "w") as f:
        json.dump({"chosen": chosen, "fields": candidates[chosen], "passed": summary[chosen]["passed"],
                   "candidates": summary, **provenance(started)}, f, indent=1)


def check_defaults(args) -> None:
    """Exit 1 unless the chosen settings (choice.json) are FootLockConfig's defaults: the test windows are read
    with the package's defaults only."""
    fields = json.load(open(args.choice))["fields"]
    defaults = dataclasses.asdict(footlock.DEFAULT_CONFIG)
    differ = {k: (v, defaults[k]) for k, v in fields.items() if defaults[k] != v}
    if differ:
        raise SystemExit("the chosen settings are not FootLockConfig's defaults (chosen, default): " + ", ".join(
            f"{k} {a} vs {b}" for k, (a, b) in differ.items()) + "; set them in stitchjax/sample/footlock first")
    print(f"the chosen settings are FootLockConfig's defaults: {defaults}")


def cache_path(cache: str, name: str, sampling: str, length: int) -> str:
    return os.path.join(cache, f"{name}_{sampling}_L{length}.npz")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="stage", required=True)
    p = sub.add_parser("sample")
    p.add_argument("--set", choices=tuple(LENGTHS), required=True)
    p.add_argument("--sampling", choices=("paper", "default"), required=True)
    p.add_argument("--cache", required=True, help="folder of the cached transitions")
    p.add_argument("--data", default="../shared/data/lafan1")
    p.add_argument("--checkpoint", default=None, help="a model folder (default: the release model)")
    p.set_defaults(func=sample)
    p = sub.add_parser("grid")
    p.add_argument("--candidates", required=True, help="JSON file {name: {FootLockConfig field: value}}")
    p.add_argument("--sets", nargs="+", default=["validation", "artefacts"], choices=tuple(LENGTHS))
    p.add_argument("--samplings", nargs="+", default=["paper", "default"], choices=("paper", "default"))
    p.add_argument("--lengths", nargs="+", type=int, default=[], help="only these lengths (default: all of a set's)")
    p.add_argument("--cache", required=True)
    p.add_argument("--json", required=True)
    p.add_argument("--data", default="../shared/data/lafan1")
    p.add_argument("--checkpoint", default=None)
    p.set_defaults(func=grid)
    p = sub.add_parser("choose")
    p.add_argument("--grid", nargs="+", required=True, help="the grid stage's JSONs")
    p.add_argument("--json", required=True)
    p.set_defaults(func=choose)
    p = sub.add_parser("check-defaults")
    p.add_argument("--choice", required=True, help="the choose stage's JSON")
    p.set_defaults(func=check_defaults)
    args = parser.parse_args(argv)
    args.func(args)


if __name__ == "__main__":
    main()
