#!/usr/bin/env python3
"""Where in a transition the feet slide: the protocol's foot slide (cm/frame) per frame of the transition.

    python results/foot_slide_frames.py --checkpoint runs/cvae_long --data ../shared/data/lafan1 --length 30 \
        --out results/lafan1_cpu/foot_slide_frames

For the 376 subject5 test windows, the start keyframe of the protocol and transitions of ``--length`` frames:
the model at noise x0 (the prior's mean path) and x1, interpolation and the ground truth. Entry t is the
step from frame t to frame t + 1 of the transition (frame 0 = the start keyframe, frame L + 1 = the target),
scored with ``metrics.foot_slide_parts`` (the protocol's weights) on that pair of frames alone. Writes
``foot_slide_L<L>.json`` and ``foot_slide_L<L>.png`` into ``--out``.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys

import numpy as np

REPO = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from stitchjax import skeleton  # noqa: E402
from stitchjax.eval import evaluate, metrics, plots
from stitchjax.data import lafan1
from stitchjax.model import rollout
from stitchjax.sample import trained_model
from stitchjax.skeleton import forward_kinematics  # noqa: E402


def per_frame_slide(positions, ground, feet) -> np.ndarray:
    """positions (S, B, T, J, 3) global, T = L + 2 frames with both keyframes -> (T - 1,) cm/frame."""
    out = []
    for t in range(positions.shape[2] - 1):
        weighted, count = metrics.foot_slide_parts(positions[:, :, t:t + 2], ground, feet)
        out.append(float(weighted.sum()) / max(float(count.sum()), 1.0))
    return np.asarray(out)


def truth_positions(windows) -> np.ndarray:
    """Global positions (B, T, J, 3) of the whole test windows (file units)."""
    parents = tuple(int(p) for p in windows.skeleton.parents)
    return forward_kinematics(np.asarray(windows.rotations, np.float64), np.asarray(windows.positions, np.float64),
                              parents)[1]


def with_keyframes(positions, truth, start: int, length: int) -> np.ndarray:
    """Generated frames (S, B, L, J, 3) -> (S, B, L + 2, J, 3) between the ground truth's (B, T, J, 3) start
    keyframe ``start`` and target keyframe ``start + length + 1``."""
    first = np.broadcast_to(truth[None, :, start:start + 1], positions[:, :, :1].shape)
    last = np.broadcast_to(truth[None, :, start + length + 1:start + length + 2], positions[:, :, :1].shape)
    return np.concatenate([first, positions, last], axis=2)


def method_positions(model, windows, start: int, length: int, samples: int) -> dict:
    """Global positions (S, B, L, J, 3) of the generated frames of the test windows: {"model noise x0" (S = 1),
    "model noise x1" (S = samples), "interpolation" (S = 1)}."""
    parents = tuple(int(p) for p in windows.skeleton.parents)
    methods = {"model noise x0": (evaluate.model_method(model, noise_scale=0.0), 1),
               "model noise x1": (evaluate.model_method(model), samples),
               "interpolation": (evaluate.interpolation_method, 1)}
    out = {}
    for name, (method, count) in methods.items():
        rotations, positions = method(windows, start, length, count, 0)
        out[name] = forward_kinematics(np.asarray(rotations, np.float64), np.asarray(positions, np.float64),
                                       parents)[1]
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--checkpoint", required=True)
    parser.add_argument("--data", required=True)
    parser.add_argument("--length", type=int, default=30)
    parser.add_argument("--samples", type=int, default=4, help="samples per window at noise x1 (default 4)")
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    model = trained_model.load_model(args.checkpoint)
    windows = lafan1.test_windows(args.data)
    feet, start, length = tuple(skeleton.LAFAN1_FEET), evaluate.START_FRAME, args.length
    gt = truth_positions(windows)
    ground = metrics.ground_heights(gt, feet)
    curves = {name: per_frame_slide(with_keyframes(p, gt, start, length), ground, feet)
              for name, p in method_positions(model, windows, start, length, args.samples).items()}
    curves["ground truth"] = per_frame_slide(gt[None, :, start:start + length + 2], ground, feet)

    print("step    " + "".join(f"{name:>16}" for name in curves))
    for t in range(length + 1):
        print(f"{t:2d}->{t + 1:<3d} " + "".join(f"{c[t]:16.2f}" for c in curves.values()))
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stem = out / f"foot_slide_L{length}"
    stem.with_suffix(".json").write_text(json.dumps(
        {"checkpoint": str(args.checkpoint), "length": length, "windows": int(len(windows.rotations)),
         "samples_noise1": args.samples, "units": "cm/frame, entry t = frame t to t + 1",
         "curves": {k: [round(float(x), 4) for x in v] for k, v in curves.items()}}, indent=1) + "\n")
    h, k, _, _ = (int(x) for x in rollout.schedule(model.rollout_spec, length))
    plots.error_over_time(curves, first_frame=0, ylabel="foot slide (cm/frame)",
                          xlabel="step from transition frame t to t + 1 (0 = start keyframe)", figsize=(7.0, 3.5),
                          dpi=120, path=stem.with_suffix(".png"),
                          title=f"Foot slide along the transition, L = {length}, {len(windows.rotations)} windows "
                                f"(stitch overlap: frames {h - k + 1}-{h + k})")
    print(f"wrote {stem}.json and {stem}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
