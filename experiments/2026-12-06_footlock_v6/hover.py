"""How often the pass leaves a foot hovering: lifted clear of the ground for many frames where the generated
foot is on it (validation split only).

    python experiments/2026-12-06_footlock_v6/hover.py --cache /tmp/footlock_v5_validation.npz --json hover.json

On the cached validation transitions (``tune.py``'s cache: the release model, 10 samples, the paper's
sampling), with the package's defaults (or --fields): a leg hovers in a frame when the pass raised its ankle by more than
5 cm there while the generated ankle was within 5 cm of the keyframes' ground. Printed per length: the share
of generated leg-frames that hover, and the share that lie in hover runs of at least 10 frames.
"""
import argparse
import json
import os
import sys

import jax
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import measure  # noqa: E402
import tune  # noqa: E402

from stitchjax.data import lafan1  # noqa: E402
from stitchjax.sample import foot_spans, footlock  # noqa: E402
from stitchjax.skeleton import forward_kinematics  # noqa: E402

RAISED_CM, LOW_CM, LONG_FRAMES = 5.0, 5.0, 10
ANKLES = (3, 7)


def long_runs(mask, frames: int):
    """(..., T) bool: the frames of ``mask`` (..., T) in runs of at least ``frames`` along the last axis."""
    flat = np.ascontiguousarray(mask).reshape(-1, mask.shape[-1])
    return np.asarray(jax.vmap(lambda m: foot_spans.drop_short_spans(m, frames))(flat)).reshape(mask.shape)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", default="../shared/data/lafan1")
    parser.add_argument("--cache", required=True, help="tune.py's cache of the validation transitions")
    parser.add_argument("--fields", default="{}", help="FootLockConfig fields (JSON) in place of the defaults")
    parser.add_argument("--json", required=True)
    args = parser.parse_args()
    config = footlock.FootLockConfig(**json.loads(args.fields))
    windows = lafan1.build_windows([os.path.join(args.data, f"{t}.bvh") for t in tune.VALIDATION], 65, 40, workers=1)
    parents = tuple(windows.skeleton.parents)
    cache = dict(np.load(args.cache))
    result = {"fields": json.loads(args.fields), "raised_cm": RAISED_CM, "low_cm": LOW_CM, "long_frames": LONG_FRAMES,
              "lengths": {}}
    for length in sorted({int(k[1:]) for k in cache}):
        r, p, c = cache[f"r{length}"], cache[f"p{length}"], cache[f"c{length}"]
        locked, _, _ = footlock.lock_transitions(r, p, c, windows.skeleton, measure.FEET, config, sample_axis=1)
        before = forward_kinematics(r, p, parents)[1][..., list(ANKLES), 1]  # (B, S, T, legs)
        after = forward_kinematics(locked, p, parents)[1][..., list(ANKLES), 1]
        ground = np.minimum(before[:, :, :1], before[:, :, -1:]).min(axis=-1, keepdims=True)  # keyframes' lowest
        hover = ((after - before) > RAISED_CM) & ((before - ground) < LOW_CM)
        hover = np.moveaxis(hover[:, :, 1:-1], -1, -2)  # (B, S, legs, L): generated frames only
        long = long_runs(hover, LONG_FRAMES)
        result["lengths"][str(length)] = {"hover_share": float(hover.mean()), "long_hover_share": float(long.mean())}
        print(f"L={length}: {100 * hover.mean():.1f} % of generated leg-frames hover, "
              f"{100 * long.mean():.1f} % in runs of {LONG_FRAMES}+ frames", flush=True)
    result["command"] = "python " + " ".join(sys.argv)
    with open(args.json, "w") as f:
        json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
