#!/usr/bin/env python3
"""The LAFAN1 training files' horizontal root speed: the fallback limit of placed targets.

    python experiments/2026-12-04_root_speed/measure.py --data ../shared/data/lafan1 --json OUT.json

Every frame of every subject1-4 file (the training subjects; 30 fps, cm, +Y up): the horizontal
(x, z) distance the root moves from one frame to the next, its percentiles in cm/frame and cm/s, over the
whole files (``stitchjax.data.features.root_speed_percentiles`` of each file's root path) and over the
training windows (window 50, offset 20, as ``bin/train`` saves ``stats["root_speed_p99"]``).
"""
import argparse
import json
import pathlib
import platform
import subprocess
import sys
import time

REPO = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from stitchjax.data import bvh, features, lafan1  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", required=True)
    parser.add_argument("--json", required=True)
    args = parser.parse_args()
    started = time.time()
    files = sorted(p for p in pathlib.Path(args.data).glob("*.bvh") if not p.stem.endswith("subject5"))
    speeds = []
    for path in files:
        root = bvh.load(path).positions[:, 0]
        speeds.append(np.linalg.norm(np.diff(root[:, [0, 2]], axis=0), axis=-1))
    speeds = np.concatenate(speeds)
    windows = lafan1.load_windows(args.data, lafan1.TRAIN_SUBJECTS, 50, 20)
    in_windows = features.root_speed_percentiles(windows.positions[:, :, 0], windows.fps)
    commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, cwd=REPO).stdout.strip()
    result = {
        "command": " ".join(["python"] + sys.argv),
        "commit": commit,
        "machine": f"2-core AMD EPYC CPU VM ({platform.machine()})",
        "data": f"{len(files)} LAFAN1 files of subjects 1-4 in {args.data}",
        "fps": 30.0,
        "whole_files_cm_per_frame": {f"p{q:g}": float(np.percentile(speeds, q)) for q in (50, 90, 99, 99.9, 100)},
        "whole_files_frames": int(speeds.size),
        "training_windows_cm_per_s": in_windows,
        "wall_s": round(time.time() - started, 1),
    }
    result["whole_files_p99_cm_per_s"] = result["whole_files_cm_per_frame"]["p99"] * 30.0
    pathlib.Path(args.json).write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
