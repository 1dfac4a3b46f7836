#!/usr/bin/env python3
"""Where in a transition the position error is: the protocol's joint error (m) per generated frame, for all
joints, the root alone and the four foot joints; and how far the feet move in the first and the last step
(from the start keyframe into frame 1, from frame L into the target keyframe).

    python results/error_frames.py --checkpoint results/lafan1_cpu/from_skate512/models/decay512 \
        --data ../shared/data/lafan1 --length 30 --out results/lafan1_cpu/from_decay512/error_frames_decay512

For the 376 subject5 test windows, the protocol's start keyframe and transitions of ``--length`` frames:
the model at noise x0 (the prior's mean path) and x1, and interpolation. Entry t is generated frame t + 1;
the mean over t of the "all joints" curve is the protocol's ADE, its last entry SLDE
(``plots.per_frame_error``). Foot movement: the horizontal distance (cm) each foot
joint moves in that step, averaged over joints, windows and samples; the ground truth's beside it. Writes
``error_L<L>.json`` and ``error_L<L>.png``.
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
from foot_slide_frames import method_positions, truth_positions  # noqa: E402  (results/, the script's folder)


def keyframe_steps(positions, first_key, last_key, feet, up_axis: int = 1) -> tuple[float, float]:
    """positions (S, B, L, J, 3) generated frames, first_key / last_key (B, J, 3) the keyframes -> mean
    horizontal distance (data units) the feet move from the start keyframe into frame 1 and from frame L
    into the target keyframe."""
    horizontal = [axis for axis in range(3) if axis != up_axis]

    def moved(a, b):
        return float(np.linalg.norm((a - b)[..., list(feet), :][..., horizontal], axis=-1).mean())

    return moved(positions[:, :, 0], first_key[None]), moved(last_key[None], positions[:, :, -1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--checkpoint", required=True, help="run folder of bin/train (or a committed model)")
    parser.add_argument("--data", required=True, help="folder of the LAFAN1 BVH files")
    parser.add_argument("--length", type=int, default=30, help="transition length L (default 30)")
    parser.add_argument("--samples", type=int, default=4, help="samples per window at noise x1 (default 4)")
    parser.add_argument("--out", required=True, help="folder for error_L<L>.json / .png")
    args = parser.parse_args(argv)
    model = trained_model.load_model(args.checkpoint)
    windows = lafan1.test_windows(args.data)
    start, length = evaluate.START_FRAME, args.length
    gt = truth_positions(windows)
    truth = gt[:, start + 1:start + length + 1]
    feet = list(skeleton.LAFAN1_FEET)
    first_key, last_key = gt[:, start], gt[:, start + length + 1]
    steps = {"ground truth": keyframe_steps(truth[None], first_key, last_key, feet)}
    curves = {}
    for name, p in method_positions(model, windows, start, length, args.samples).items():
        curves[name] = plots.per_frame_error(p, truth, metrics.LAFAN1_METRES_PER_UNIT)
        curves[name + ", root"] = plots.per_frame_error(p[..., :1, :], truth[..., :1, :], metrics.LAFAN1_METRES_PER_UNIT)
        curves[name + ", feet"] = plots.per_frame_error(p[..., feet, :], truth[..., feet, :],
                                                       metrics.LAFAN1_METRES_PER_UNIT)
        steps[name] = keyframe_steps(p, first_key, last_key, feet)

    print("frame " + "".join(f"{name:>22}" for name in curves))
    for t in range(length):
        print(f"{t + 1:5d} " + "".join(f"{c[t]:22.4f}" for c in curves.values()))
    print("mean  " + "".join(f"{c.mean():22.4f}" for c in curves.values()))
    print("horizontal foot movement (cm): start keyframe -> frame 1, frame L -> target keyframe")
    for name, (first, last) in steps.items():
        print(f"  {name:<16} {first:6.2f} {last:6.2f}")
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stem = out / f"error_L{length}"
    stem.with_suffix(".json").write_text(json.dumps(
        {"checkpoint": str(args.checkpoint), "length": length, "windows": int(len(windows.rotations)),
         "samples_noise1": args.samples, "units": "m, entry t = generated frame t + 1",
         "curves": {k: [round(float(x), 5) for x in v] for k, v in curves.items()},
         "foot_movement_cm": {"units": "cm, horizontal, mean over the 4 foot joints",
                              "start_keyframe_to_frame_1": {k: round(v[0], 3) for k, v in steps.items()},
                              "frame_L_to_target_keyframe": {k: round(v[1], 3) for k, v in steps.items()}}},
        indent=1) + "\n")
    h, k, _, _ = (int(x) for x in rollout.schedule(model.rollout_spec, length))
    plots.error_over_time(curves, ylabel="joint position error (m)", xlabel="generated frame", figsize=(7.0, 4.0),
                          dpi=120, path=stem.with_suffix(".png"),
                          title=f"Error along the transition, L = {length}, {len(windows.rotations)} windows "
                                f"(stitch overlap: frames {h - k + 1}-{h + k})")
    print(f"wrote {stem}.json and {stem}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
