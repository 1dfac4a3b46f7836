#!/usr/bin/env python3
"""Issue 12's showcase: keyframes from two LAFAN1 takes, the target placed 300 cm away and turned 90°.

    python results/placed_target.py --checkpoint runs/lafan1_cpu --out results/placed_target

Runs ``bin/inbetween`` from frame --start-frame of --start-bvh to frame --target-frame of --target-bvh,
the target turned by --turn (degrees about the vertical) and moved so that its root lies --offset (cm)
from the start keyframe's root (``--offset-from start``, the default: a transition that a person can walk),
or --offset from where its own take has it (``--offset-from file``, bin/inbetween's own convention),
writing the transition alone (``--output transition``). Then it measures, on the BVH files bin/inbetween wrote:

- end error: the largest distance (cm) between any joint of the last frame and the same joint of the
  placed target keyframe (``stitchjax.data.conform.place`` of the target take); likewise for the first frame;
- root speed (cm/frame): |root[t+1] - root[t]| over the L + 2 frames (keyframes included), and its
  jumps |speed[t] - speed[t-1]| (cm/frame per frame): the largest inside the transition, and the largest
  around the stitch (the middle frames L//2 - 1 .. L//2 + 2);
- the ground truth's largest root-speed jump over every frame of every take of --data (all files), with
  its file and frame, and the 99.9th percentile for scale.

Writes OUT/placed_target.json (every figure above, per sample and overall, with units), OUT/filmstrip.png
(stitchjax.eval.plots: the samples, keyframes black, each titled with its jumps) and OUT/root_speed.png, keeps
bin/inbetween's own output under OUT/inbetween/, and prints one verdict line. Exit status: 0 when the
output ends on the placed target (< --tolerance cm) and no sample's speed jump exceeds the ground truth's
largest, 1 when measured but not, 2 for bad input (one "placed_target: error: ..." line).
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import subprocess
import sys

REPO = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from stitchjax.data import bvh, conform  # noqa: E402
from stitchjax.eval import plots

DEFAULT_DATA = REPO.parent / "shared" / "data" / "lafan1"
MID_BEFORE, MID_AFTER = 1, 2  # jumps at frames L//2 - 1 .. L//2 + 2 count as "at the stitch"


class UserError(Exception):
    """A bad argument or input file; printed as one line, exit status 2."""


def root_speed(root_positions) -> np.ndarray:
    """(T - 1,) root speed |p[t+1] - p[t]| (file units per frame, cm for LAFAN1) of (T, 3) root positions."""
    p = np.asarray(root_positions, np.float64)
    return np.linalg.norm(np.diff(p, axis=0), axis=-1)


def speed_jumps(root_positions) -> np.ndarray:
    """(T - 2,) |speed[t] - speed[t-1]| (cm/frame per frame); entry k is the change at frame k + 1."""
    return np.abs(np.diff(root_speed(root_positions)))


def mid_frames(length: int) -> range:
    """Frames of an (L + 2)-frame transition whose speed jump counts as at the stitch (1 .. L)."""
    middle = length // 2
    return range(max(1, middle - MID_BEFORE), min(length, middle + MID_AFTER) + 1)


def ground_truth_jumps(files, fps: float) -> dict:
    """The largest root-speed jump (cm/frame per frame) over all frames of ``files`` (at ``fps``)."""
    best, where, everything = -1.0, None, []
    for path in files:
        take, _ = conform.resample(bvh.load(path), fps, 0)
        jumps = speed_jumps(take.positions[:, 0])
        everything.append(jumps)
        k = int(np.argmax(jumps))
        if jumps[k] > best:
            best, where = float(jumps[k]), {"file": pathlib.Path(path).name, "frame": k + 1}
    everything = np.concatenate(everything)
    return {"files": len(files), "frames": int(everything.size + 2 * len(files)), "max_jump": best,
            "max_jump_at": where, "p99_9_jump": float(np.percentile(everything, 99.9))}


def _take_path(text: str, data: pathlib.Path, flag: str) -> pathlib.Path:
    path = pathlib.Path(text)
    for candidate in (path, data / path):
        if candidate.is_file():
            return candidate
    raise UserError(f"{flag} {text}: no such file (looked in the current folder and in --data {data})")


def _truth_files(folder: pathlib.Path) -> list:
    if not folder.is_dir():
        raise UserError(f"--truth-data {folder}: not a folder; pass the LAFAN1 folder (default --data)")
    files = sorted(p for p in folder.iterdir() if p.name.lower().endswith((".bvh", ".bvh.gz")))
    if not files:
        raise UserError(f"--truth-data {folder}: no .bvh / .bvh.gz files in it")
    return files


def file_offset(args, start: pathlib.Path, target: pathlib.Path, offset: list, fps: float) -> list:
    """The offset (cm) to give bin/inbetween (relative to the target take) for --offset-from: "file" keeps
    --offset; "start" adds the horizontal distance from the target keyframe's root to the start keyframe's."""
    if args.offset_from == "file":
        return offset
    start_take, a = conform.resample(bvh.load(start), fps, args.start_frame)
    target_take, b = conform.resample(bvh.load(target), fps, args.target_frame)
    gap = start_take.positions[a, 0] - target_take.positions[b, 0]
    return [float(offset[0] + gap[0]), float(offset[1]), float(offset[2] + gap[2])]


def run_inbetween(args, start: pathlib.Path, target: pathlib.Path, out: pathlib.Path, offset: list) -> list:
    """bin/inbetween --output transition; returns the written sample BVH paths (in sample order)."""
    command = [sys.executable, str(REPO / "bin" / "inbetween"), "--checkpoint", str(args.checkpoint),
               "--bvh", str(start), "--start-frame", str(args.start_frame), "--target-bvh", str(target),
               "--target-frame", str(args.target_frame), "--length", str(args.length),
               "--target-offset=" + ",".join(f"{x:.6f}" for x in offset), "--offset-from", "file",  # measured here
               "--target-turn", str(args.turn), "--samples", str(args.samples),
               "--search", str(args.search), "--seed", str(args.seed), "--output", "transition", "--out", str(out)]
    command += ["--allow-fast"] if args.allow_fast else []
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO)] + [p for p in [os.environ.get("PYTHONPATH")] if p])}
    proc = subprocess.run(command, capture_output=True, text=True, env=env)  # this checkout's package
    if proc.returncode != 0:
        lines = [line for line in proc.stderr.splitlines() if line.strip()] or ["(no message)"]
        raise UserError(f"bin/inbetween failed ({proc.returncode}): {lines[-1]}")
    return [pathlib.Path(line) for line in proc.stdout.splitlines() if line.endswith(".bvh")]


def measure(samples: list, placed_target, start_pose, length: int) -> dict:
    """Per-sample figures of transitions (Motions of L + 2 frames) against the keyframes' FK (J, 3) cm."""
    mids = list(mid_frames(length))
    rows = []
    for motion in samples:
        g = motion.global_positions()
        jumps = speed_jumps(motion.positions[:, 0])  # jumps[k] at frame k + 1
        rows.append({
            "end_error_cm": float(np.linalg.norm(g[-1] - placed_target, axis=-1).max()),
            "start_error_cm": float(np.linalg.norm(g[0] - start_pose, axis=-1).max()),
            "root_speed_cm_per_frame": root_speed(motion.positions[:, 0]).round(4).tolist(),
            "max_jump": float(jumps.max()), "max_jump_frame": int(np.argmax(jumps)) + 1,
            "max_mid_jump": float(jumps[[f - 1 for f in mids]].max()),
        })
    return {"per_sample": rows, "mid_frames": mids,
            "end_error_cm": max(r["end_error_cm"] for r in rows),
            "start_error_cm": max(r["start_error_cm"] for r in rows),
            "max_jump": max(r["max_jump"] for r in rows), "max_mid_jump": max(r["max_mid_jump"] for r in rows)}


def figures(samples: list, measured: dict, truth: dict, args, out: pathlib.Path) -> None:
    parents = samples[0].skeleton.parents
    rows = [m.global_positions() for m in samples]
    every = max(1, (args.length + 1) // 8)
    frames = sorted(set(range(0, args.length + 2, every)) | {0, args.length + 1})
    titles = [f"sample {k}\njump {r['max_jump']:.2f}\nstitch {r['max_mid_jump']:.2f}"
              for k, r in enumerate(measured["per_sample"])]
    plots.filmstrip([r[frames] for r in rows], parents, every=1, keyframes=(0, len(frames) - 1), titles=titles,
                    title=f"{args.start_bvh}:{args.start_frame} -> {args.target_bvh}:{args.target_frame} placed "
                          f"({args.offset} cm from the {args.offset_from}, {args.turn:g} deg), L = {args.length}\nroot-speed jumps (cm/frame): "
                          f"largest in the transition, at the stitch; ground truth's largest {truth['max_jump']:.2f}",
                    path=out / "filmstrip.png")
    plots.error_over_time({f"sample {k}": r["root_speed_cm_per_frame"] for k, r in enumerate(measured["per_sample"])},
                          first_frame=0, ylabel="root speed (cm/frame)", xlabel="frame of the transition (t -> t+1)",
                          title="root speed; stitch at the middle frames", path=out / "root_speed.png")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="placed_target", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--checkpoint", required=True, help="training run folder (or checkpoints/<step>)")
    parser.add_argument("--data", default=str(DEFAULT_DATA), help=f"LAFAN1 folder (default {DEFAULT_DATA})")
    parser.add_argument("--start-bvh", default="walk4_subject1.bvh", help="start take (a path, or a name in --data)")
    parser.add_argument("--start-frame", type=int, default=300)
    parser.add_argument("--target-bvh", default="obstacles1_subject5.bvh", help="target take (path or name)")
    parser.add_argument("--target-frame", type=int, default=500)
    parser.add_argument("--length", type=int, default=50, help="generated frames (default 50: 300 cm is a walk)")
    parser.add_argument("--offset", default="300,0,0", help="target root offset x,y,z in cm (default 300,0,0)")
    parser.add_argument("--offset-from", choices=("start", "file"), default="start",
                        help="--offset from the start keyframe's root (default) or from the target take's own place")
    parser.add_argument("--turn", type=float, default=90.0, help="target turn about the vertical, degrees")
    parser.add_argument("--allow-fast", action="store_true",
                        help="pass --allow-fast to bin/inbetween (a transition faster than the training data's)")
    parser.add_argument("--samples", type=int, default=8)
    parser.add_argument("--search", type=int, default=0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--truth-data", default=None, help="takes for the ground-truth speed jumps (default --data)")
    parser.add_argument("--tolerance", type=float, default=1e-3, help="end error counted as exact, cm")
    parser.add_argument("--out", required=True, help="output folder (created)")
    args = parser.parse_args(argv)
    try:
        data = pathlib.Path(args.data)
        start, target = _take_path(args.start_bvh, data, "--start-bvh"), _take_path(args.target_bvh, data, "--target-bvh")
        truth_files = _truth_files(pathlib.Path(args.truth_data) if args.truth_data else data)
        offset = [float(x) for x in args.offset.split(",")] if args.offset.count(",") == 2 else None
        if offset is None:
            raise UserError(f"--offset {args.offset!r}: give x,y,z in cm, e.g. 300,0,0")
        out = pathlib.Path(args.out)
        if out.exists() and not out.is_dir():
            raise UserError(f"--out {out}: is a file; pass a folder")
        moved = file_offset(args, start, target, offset, bvh.load(start).fps)
        paths = run_inbetween(args, start, target, out / "inbetween", moved)
        samples = [bvh.load(p) for p in paths]
        if len(samples) != args.samples or any(m.num_frames != args.length + 2 for m in samples):
            raise UserError(f"bin/inbetween wrote {len(samples)} transitions, expected {args.samples} of "
                            f"{args.length + 2} frames")
        fps = samples[0].fps
        target_take, b = conform.resample(bvh.load(target), fps, args.target_frame)
        placed = conform.place(target_take, moved, args.turn, pivot=b)[b].global_positions()[0]
        start_take, a = conform.resample(bvh.load(start), fps, args.start_frame)
        measured = measure(samples, placed, start_take[a].global_positions()[0], args.length)
        truth = ground_truth_jumps(truth_files, fps)
    except (UserError, OSError, ValueError) as error:
        message = " ".join(str(error).split()) or type(error).__name__
        print(f"placed_target: error: {message}", file=sys.stderr)
        return 2
    exact = measured["end_error_cm"] < args.tolerance and measured["start_error_cm"] < args.tolerance
    smooth = measured["max_jump"] <= truth["max_jump"]
    verdict = (f"{'PASS' if exact and smooth else 'FAIL'}: ends on the placed target "
               f"{'exactly' if exact else 'NOT exactly'} (max joint error {measured['end_error_cm']:.2g} cm); "
               f"largest root-speed jump {measured['max_jump']:.3f} cm/frame in the transition, "
               f"{measured['max_mid_jump']:.3f} at the stitch, vs {truth['max_jump']:.3f} in the ground truth "
               f"({truth['files']} takes, 99.9th percentile {truth['p99_9_jump']:.3f})")
    out.mkdir(parents=True, exist_ok=True)
    figures(samples, measured, truth, args, out)
    summary = {
        "checkpoint": str(args.checkpoint), "fps": fps, "length": args.length, "samples": args.samples,
        "search": args.search, "seed": args.seed,
        "start": {"file": start.name, "frame": args.start_frame},
        "target": {"file": target.name, "frame": args.target_frame, "offset_cm": offset, "offset_from": args.offset_from,
                   "offset_from_target_take_cm": moved, "turn_degrees": args.turn},
        "transition": measured, "ground_truth": truth, "pass": bool(exact and smooth), "verdict": verdict,
        "units": {"end_error_cm": "cm (largest joint distance)", "start_error_cm": "cm",
                  "root_speed_cm_per_frame": "cm/frame", "max_jump": "cm/frame per frame (|speed change|)",
                  "max_mid_jump": "cm/frame per frame, frames mid_frames", "p99_9_jump": "cm/frame per frame"},
    }
    (out / "placed_target.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(verdict)
    return 0 if exact and smooth else 1


if __name__ == "__main__":
    sys.exit(main())
