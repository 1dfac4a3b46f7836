#!/usr/bin/env python3
"""How the feet and the root move in the generated transitions, beside the protocol's foot slide: whether a
lower foot slide comes from feet that stay planted or from a character that moves less.

    python results/foot_motion.py --data ../shared/data/lafan1 --length 50 \
        --json results/lafan1_cpu/from_scratch_mixed/foot_motion_L50.json \
        posterior=results/lafan1_cpu/from_scratch_mixed/models/n64_pkl0.02_s256 \
        none=results/lafan1_cpu/from_scratch_mixed/models/nn_s256

For the 376 subject5 test windows, the protocol's start keyframe and transitions of ``--length`` frames, each
model at noise x0 (the prior's mean path) and x1 (``--samples``), interpolation and the ground truth, over the
L + 1 steps from the start keyframe to the target: foot slide (cm/frame, the protocol's), the share of foot
joint-steps the protocol weighs (the foot near the ground), their mean weight, the weighted sliding per foot
joint-step (cm: the foot slide before the protocol divides by the weighed share), the feet's horizontal movement
per step whatever their height (cm), and the root's (cm).
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys

import numpy as np

REPO = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from stitchjax import evaluate, lafan1, metrics, skeleton, trained_model  # noqa: E402
from foot_slide_frames import method_positions, truth_positions, with_keyframes  # noqa: E402  (results/, the script's folder)


def motion_figures(positions, ground, feet, up_axis: int = 1) -> dict:
    """positions (S, B, T, J, 3) global, data units, T = L + 2 frames with both keyframes; ground (B,) ->
    {"foot_slide" cm/frame, "weighed_share", "mean_weight", "slide_per_step_cm", "foot_movement_cm",
    "root_movement_cm"}. foot_slide = slide_per_step_cm / weighed_share: the protocol divides the weighted
    sliding by the joint-steps near the ground, slide_per_step_cm by all of them."""
    weighted, count = metrics.foot_slide_parts(positions, ground, feet)
    cm = metrics.LAFAN1_METRES_PER_UNIT * 100.0
    horizontal = [a for a in range(3) if a != up_axis]
    step = np.diff(positions, axis=2)[..., horizontal]  # (S, B, T - 1, J, 2)
    foot_steps = np.linalg.norm(step[..., list(feet), :], axis=-1) * cm
    height = (positions[:, :, :-1][..., list(feet), up_axis] - ground[None, :, None, None]) * cm
    weight = metrics.foot_contact_weight(height)
    return {"foot_slide": float(weighted.sum() / max(count.sum(), 1.0)),
            "weighed_share": float((weight > 0).mean()), "mean_weight": float(weight.mean()),
            "slide_per_step_cm": float(weighted.sum() / weight.size),
            "foot_movement_cm": float(foot_steps.mean()),
            "root_movement_cm": float((np.linalg.norm(step[..., 0, :], axis=-1) * cm).mean())}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("models", nargs="+", help="LABEL=CHECKPOINT (a run folder or a committed model)")
    parser.add_argument("--data", required=True, help="folder of the LAFAN1 BVH files")
    parser.add_argument("--length", type=int, default=50, help="transition length L (default 50)")
    parser.add_argument("--samples", type=int, default=4, help="samples per window at noise x1 (default 4)")
    parser.add_argument("--json", required=True, help="file to write")
    args = parser.parse_args(argv)
    labelled = []
    for item in args.models:
        label, sep, path = item.partition("=")
        if not sep or not label or not path:
            parser.error(f"model {item!r} must look like LABEL=CHECKPOINT")
        labelled.append((label, path))
    windows = lafan1.test_windows(args.data)
    feet, start, length = tuple(skeleton.LAFAN1_FEET), evaluate.START_FRAME, args.length
    gt = truth_positions(windows)
    ground = metrics.ground_heights(gt, feet)
    rows = {"ground truth": motion_figures(gt[None, :, start:start + length + 2], ground, feet)}
    for label, path in labelled:
        generated = method_positions(trained_model.load_model(path), windows, start, length, args.samples)
        for name, positions in generated.items():
            key = "interpolation" if name == "interpolation" else f"{label}, {name[len('model '):]}"
            rows[key] = motion_figures(with_keyframes(positions, gt, start, length), ground, feet)
    columns = list(rows["ground truth"])
    print(f"L = {length}, {len(windows.rotations)} windows")
    print(f"{'':28}" + "".join(f"{c:>18}" for c in columns))
    for name, row in rows.items():
        print(f"{name:28}" + "".join(f"{row[c]:18.4f}" for c in columns))
    out = pathlib.Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"length": length, "windows": int(len(windows.rotations)), "samples_noise1": args.samples,
                               "models": dict(labelled), "rows": rows,
                               "units": {"foot_slide": "cm/frame", "slide_per_step_cm": "cm per foot joint-step",
                                         "foot_movement_cm": "cm per step",
                                         "root_movement_cm": "cm per step"}}, indent=1) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
