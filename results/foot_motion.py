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
per step whatever their height (cm), and the root's (cm). The same figures over the middle third of the steps
(far from both keyframes), and with ``--plot`` the foot slide and the feet's movement along the transition, step
by step, of each model at noise x1, interpolation and the ground truth.
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
from stitchjax.sample import trained_model
from foot_slide_frames import method_positions, per_frame_slide, truth_positions, with_keyframes  # noqa: E402  (results/, the script's folder)


def horizontal_movement_cm(positions, joints, up_axis: int = 1) -> np.ndarray:
    """positions (S, B, T, J, 3) global, data units -> (S, B, T - 1, len(joints)) how far each of ``joints``
    moves horizontally in each step (cm), whatever its height."""
    horizontal = [a for a in range(3) if a != up_axis]
    step = np.diff(positions[..., list(joints), :], axis=2)[..., horizontal]
    return np.linalg.norm(step, axis=-1) * metrics.LAFAN1_METRES_PER_UNIT * 100.0


def motion_figures(positions, ground, feet, up_axis: int = 1) -> dict:
    """positions (S, B, T, J, 3) global, data units, T = L + 2 frames with both keyframes; ground (B,) ->
    {"foot_slide" cm/frame, "weighed_share", "mean_weight", "slide_per_step_cm", "foot_movement_cm",
    "root_movement_cm"}. foot_slide = slide_per_step_cm / weighed_share: the protocol divides the weighted
    sliding by the joint-steps near the ground, slide_per_step_cm by all of them."""
    weighted, count = metrics.foot_slide_parts(positions, ground, feet)
    cm = metrics.LAFAN1_METRES_PER_UNIT * 100.0
    height = (positions[:, :, :-1][..., list(feet), up_axis] - ground[None, :, None, None]) * cm
    weight = metrics.foot_contact_weight(height)
    return {"foot_slide": float(weighted.sum() / max(count.sum(), 1.0)),
            "weighed_share": float((weight > 0).mean()), "mean_weight": float(weight.mean()),
            "slide_per_step_cm": float(weighted.sum() / weight.size),
            "foot_movement_cm": float(horizontal_movement_cm(positions, feet, up_axis).mean()),
            "root_movement_cm": float(horizontal_movement_cm(positions, (0,), up_axis).mean())}


def middle_third(positions) -> np.ndarray:
    """positions (S, B, T, J, 3) -> the frames of the middle third of its T - 1 steps (the steps from frame
    (T - 1) // 3 to frame T - 1 - (T - 1) // 3), as (S, B, T', J, 3)."""
    steps = positions.shape[2] - 1
    return positions[:, :, steps // 3:steps - steps // 3 + 1]


def foot_movement_along(positions, feet, up_axis: int = 1) -> np.ndarray:
    """positions (S, B, T, J, 3) global, data units -> (T - 1,) the feet's mean horizontal movement (cm) of
    each step, whatever their height."""
    return horizontal_movement_cm(positions, feet, up_axis).mean(axis=(0, 1, 3))


def plot_along(along: dict, length: int, windows: int, path) -> None:
    """Write ``path`` (the foot slide of each step along the transition, cm/frame) and <stem>_movement.png (the
    feet's movement of each step, cm) for the rows of ``along`` ({row: {"foot_slide", "foot_movement_cm"}})."""
    path = pathlib.Path(path)
    for key, ylabel, target in (("foot_slide", "foot slide (cm/frame)", path),
                                ("foot_movement_cm", "feet's movement (cm/step)",
                                 path.with_name(path.stem + "_movement.png"))):
        plots.error_over_time({name: curves[key] for name, curves in along.items()}, first_frame=0, ylabel=ylabel,
                              xlabel="step from transition frame t to t + 1 (0 = start keyframe)",
                              figsize=(7.0, 3.5), dpi=120, path=target,
                              title=f"{ylabel.split(' (')[0].capitalize()} along the transition, L = {length}, "
                                    f"{windows} windows")
        print(f"wrote {target}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("models", nargs="+", help="LABEL=CHECKPOINT (a run folder or a committed model)")
    parser.add_argument("--data", required=True, help="folder of the LAFAN1 BVH files")
    parser.add_argument("--length", type=int, default=50, help="transition length L (default 50)")
    parser.add_argument("--samples", type=int, default=4, help="samples per window at noise x1 (default 4)")
    parser.add_argument("--json", required=True, help="file to write")
    parser.add_argument("--plot", help="PNG of the foot slide along the transition (and <stem>_movement.png)")
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
    motions = {"ground truth": gt[None, :, start:start + length + 2]}
    for label, path in labelled:
        generated = method_positions(trained_model.load_model(path), windows, start, length, args.samples)
        for name, positions in generated.items():
            key = "interpolation" if name == "interpolation" else f"{label}, {name[len('model '):]}"
            motions[key] = with_keyframes(positions, gt, start, length)
    rows = {name: motion_figures(x, ground, feet) for name, x in motions.items()}
    middle = {name: motion_figures(middle_third(x), ground, feet) for name, x in motions.items()}
    along = {name: {"foot_slide": per_frame_slide(x, ground, feet).tolist(),
                    "foot_movement_cm": foot_movement_along(x, feet).tolist()}
             for name, x in motions.items() if not name.endswith("noise x0")}
    columns = list(rows["ground truth"])
    for title, table in ((f"L = {length}, {len(windows.rotations)} windows", rows),
                         ("the middle third of the steps", middle)):
        print(title)
        print(f"{'':28}" + "".join(f"{c:>18}" for c in columns))
        for name, row in table.items():
            print(f"{name:28}" + "".join(f"{row[c]:18.4f}" for c in columns))
    out = pathlib.Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"length": length, "windows": int(len(windows.rotations)), "samples_noise1": args.samples,
                               "models": dict(labelled), "rows": rows, "rows_middle_third": middle,
                               "along_transition": {name: {k: [round(v, 4) for v in c] for k, c in curves.items()}
                                                    for name, curves in along.items()},
                               "units": {"foot_slide": "cm/frame", "slide_per_step_cm": "cm per foot joint-step",
                                         "foot_movement_cm": "cm per step",
                                         "root_movement_cm": "cm per step"}}, indent=1) + "\n")
    print(f"wrote {out}")
    if args.plot:
        plot_along(along, length, len(windows.rotations), args.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
