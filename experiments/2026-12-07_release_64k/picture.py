"""The README picture and how far apart its samples are: 4 samples of frames 200 -> 246 (45 generated frames) of
the bundled take, at the model's default sampling and at the paper's; writes picture_spread.json (spread = mean
per-joint distance between the samples, mean over the 6 pairs, at the middle generated frame and over all 45).

    python experiments/2026-12-07_release_64k/picture.py --out experiments/2026-12-07_release_64k/picture_spread.json [--checkpoint DIR]
"""
import argparse
import itertools
import json
import pathlib
import shutil
import subprocess
import tempfile

import numpy as np

from stitchjax.data import bvh

TAKE = "stitchjax/data/sample_data/lafan1/obstacles1_subject5.bvh.gz"
START, END, SAMPLES = 200, 246, 4


def spreads(folder):
    """(spread at the middle generated frame, spread over all generated frames), cm."""
    paths = sorted(pathlib.Path(folder).glob("*_sample*.bvh"))
    g = [bvh.load(p).global_positions()[START + 1:END] for p in paths]  # (45, J, 3) each
    pairs = [np.linalg.norm(a - b, axis=-1) for a, b in itertools.combinations(g, 2)]  # (45, J)
    mid = (END - START - 1) // 2
    return float(np.mean([p[mid].mean() for p in pairs])), float(np.mean([p.mean() for p in pairs]))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", required=True)
    parser.add_argument("--checkpoint", help="model folder (default: the release model)")
    parser.add_argument("--figure", help="copy the default sampling's filmstrip here (e.g. docs/images/samples.png)")
    args = parser.parse_args()
    settings = {}
    for name, extra in (("default", []), ("paper's sampling", ["--paper-sampling"])):
        with tempfile.TemporaryDirectory() as tmp:
            command = ["bin/inbetween", "--bvh", TAKE, "--start-frame", str(START), "--end-frame", str(END),
                       "--samples", str(SAMPLES), "--seed", "0", *extra, "--out", "OUT"]
            if args.checkpoint:
                command[1:1] = ["--checkpoint", args.checkpoint]
            subprocess.run([tmp if c == "OUT" else c for c in command], check=True, capture_output=True)
            mid, whole = spreads(tmp)
            settings[name] = {"command": " ".join(command), "spread_mid_cm": round(mid, 2), "spread_cm": round(whole, 2)}
            if name == "default" and args.figure:
                shutil.copy(pathlib.Path(tmp) / "obstacles1_subject5_filmstrip.png", args.figure)
                settings[name]["figure"] = f"{args.figure} (OUT/obstacles1_subject5_filmstrip.png)"
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    json.dump({"what": __doc__.split("\n\n")[0], "commit": commit, "units": "cm", "settings": settings},
              open(args.out, "w"), indent=2)
    for name, s in settings.items():
        print(f"{name}: {s['spread_mid_cm']} cm apart mid-transition, {s['spread_cm']} over the transition")


if __name__ == "__main__":
    main()
