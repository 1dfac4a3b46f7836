#!/usr/bin/env python3
"""Wall time of training until the validation samples first beat interpolation, along a lineage of runs.

    python experiments/time_to_quality/time_to_quality.py runs/repro/metrics.jsonl runs/height32/metrics.jsonl ... \
        [--length 30] [--json OUT]

The files are the `metrics.jsonl` of runs in the order they continued one another (`--init-from`, or a
resume in the same workdir). Each file counts up to the step where the next one starts; its loop time is
the sum of its processes' `time_s` (which restarts at 0 when a run is resumed). A validation row "beats
interpolation" when the samples' NPSS and foot slide at L = `--length` are both below interpolation's on
the same windows (`val_npss_L30` < `val_npss_L30_interp`, ...).
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys

REPO = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from stitchjax.train import reporting  # noqa: E402


def read_rows(path: pathlib.Path) -> list[dict]:
    """The records of one metrics.jsonl that carry `time_s`, in file order."""
    return [r for r in reporting.read_metrics(path) if "time_s" in r]


def with_loop_time(rows: list[dict]) -> list[tuple[dict, float]]:
    """(row, seconds of training loop since the file's first process started), across resumes."""
    out, done, last = [], 0.0, 0.0
    for row in rows:
        if row["time_s"] < last:  # a new process: its clock restarted
            done += last
        last = row["time_s"]
        out.append((row, done + last))
    return out


def beats(row: dict, length: int) -> dict:
    """Which of NPSS and foot slide at `length` are below interpolation's in one validation row."""
    out = {}
    for metric in ("npss", "foot_slide"):
        key = f"val_{metric}_L{length}"
        if key in row and key + "_interp" in row:
            out[metric] = row[key] < row[key + "_interp"]
    return out


def lineage(paths: list[pathlib.Path], length: int) -> dict:
    """Per-file step ranges and loop seconds, and the first validation rows that beat interpolation."""
    files = [read_rows(p) for p in paths]
    segments, offset = [], 0.0
    first = {"npss": None, "both": None}
    for index, (path, rows) in enumerate(zip(paths, files)):
        if not rows:
            raise SystemExit(f"{path}: no records with time_s; is this a bin/train metrics.jsonl?")
        until = files[index + 1][0]["step"] if index + 1 < len(files) else None
        timed = [(r, t) for r, t in with_loop_time(rows) if until is None or r["step"] < until]
        for row, t in timed:
            won = beats(row, length)
            if won.get("npss") and first["npss"] is None:
                first["npss"] = {"step": row["step"], "wall_s": offset + t, "file": str(path)}
            if len(won) == 2 and all(won.values()) and first["both"] is None:
                first["both"] = {"step": row["step"], "wall_s": offset + t, "file": str(path),
                                 **{k: row[k] for k in row if k.startswith("val_") and f"_L{length}" in k}}
        seconds = timed[-1][1] if timed else 0.0
        segments.append({"file": str(path), "first_step": timed[0][0]["step"] if timed else None,
                         "last_step": timed[-1][0]["step"] if timed else None, "loop_s": seconds,
                         "cumulative_s": offset + seconds})
        offset += seconds
    return {"length": length, "segments": segments, "first_below_interp_npss": first["npss"],
            "first_below_interp_npss_and_foot_slide": first["both"]}


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("metrics", nargs="+", type=pathlib.Path, help="metrics.jsonl files, in lineage order")
    parser.add_argument("--length", type=int, default=30, help="the validated transition length (frames)")
    parser.add_argument("--json", type=pathlib.Path, help="also write the result here")
    args = parser.parse_args(argv)
    for path in args.metrics:
        if not path.is_file():
            raise SystemExit(f"{path}: no such file (give the metrics.jsonl of each run)")
    result = lineage(args.metrics, args.length)
    print("| run | steps | loop (s) | cumulative (s) |\n| --- | --- | --- | --- |")
    for s in result["segments"]:
        print(f"| {s['file']} | {s['first_step']}-{s['last_step']} | {s['loop_s']:.0f} | {s['cumulative_s']:.0f} |")
    for name, key in (("NPSS", "first_below_interp_npss"), ("NPSS and foot slide",
                                                             "first_below_interp_npss_and_foot_slide")):
        hit = result[key]
        print(f"first below interpolation's {name} at L = {args.length}: "
              + (f"step {hit['step']}, {hit['wall_s']:.0f} s ({hit['wall_s'] / 3600:.2f} h) of loop"
                 if hit else "never"))
    if args.json:
        args.json.write_text(json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
