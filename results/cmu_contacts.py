#!/usr/bin/env python3
"""Training on a non-LAFAN1 skeleton: the CMU file through the generic BVH-folder dataset, and its contacts.

    python results/cmu_contacts.py --data ../shared/data/cmu --workdir runs/cmu --out results/cmu

1. Trains `bin/train --config cmu --workdir WORKDIR --data DATA --max-steps N` (a short run: the point is
   that any skeleton trains and checkpoints) and loads the checkpoint back (`trained_model.load_model`),
   whose saved skeleton facts name the contact joints.
2. The contact labels of the training windows, per foot channel: the fraction of frames in contact.
3. The check by hand: the first file again, loaded the way the loader loads it (cm, +Y up, 30 fps), its
   feet's FK positions, and for each foot joint and frame the displacement to the next frame (cm) and the
   height above the take's lowest foot point (cm). A frame is a contact when the squared displacement is
   below ``windows.CONTACT_THRESHOLD`` (cm²): recounted here from those positions, independently of the
   loader, and compared with the labels of the first window frame by frame. OUT/contacts.png shows each
   foot's height with its contact frames shaded (a foot on the ground is low and still); OUT/contacts.json
   holds every figure and the table of a few frames printed below.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import subprocess
import sys

REPO = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from stitchjax import config as config_lib  # noqa: E402
from stitchjax.data import bvh_folder, datasets
from stitchjax.sample import trained_model
from stitchjax.skeleton import forward_kinematics  # noqa: E402
from stitchjax.data.windows import CONTACT_THRESHOLD  # noqa: E402

DEFAULT_DATA = REPO.parent / "shared" / "data" / "cmu"


def train(data: pathlib.Path, workdir: pathlib.Path, steps: int) -> float:
    """bin/train --config cmu for `steps` steps; returns its wall time (s). Raises on a non-zero exit."""
    import time

    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, str(REPO / "bin" / "train"), "--config", "cmu", "--workdir",
                           str(workdir), "--data", str(data), "--max-steps", str(steps), "--no-progress"],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"cmu_contacts: error: bin/train failed ({proc.returncode}): {proc.stderr[-500:]}")
    return time.perf_counter() - t0


def hand_count(path, data, feet, frames: int):
    """(squared displacement (T-1, C) cm², height (T, C) cm) of the feet of take `path` as the loader reads it."""
    motion, _ = bvh_folder.load_take(path, data)
    _, positions = forward_kinematics(motion.rotations[:frames + 1], motion.positions[:frames + 1],
                                      motion.skeleton.parents)
    feet_positions = positions[:, list(feet)]
    step = np.sum(np.diff(feet_positions, axis=0) ** 2, axis=-1)
    height = feet_positions[..., 1] - feet_positions[..., 1].min()
    return step, height


def take_labels(windows, name: str, frames: int) -> np.ndarray:
    """(F, C) contact labels of frames 0 .. F - 1 of take `name`, each from the first training window that
    holds it (windows.sources: "<file>:<start frame>"), F <= `frames`, up to the last frame covered."""
    length = windows.contacts.shape[1]
    labels = []
    for index, source in enumerate(windows.sources):
        file, start = source.rsplit(":", 1)
        if file != name:
            continue
        start = int(start)
        if start > len(labels):
            break
        labels.extend(windows.contacts[index, len(labels) - start:length - 1])  # a window's last frame repeats
        if len(labels) >= frames:
            break
    return np.asarray(labels[:frames])


def contact_figure(height, labels, names, title: str, path) -> None:
    """One panel per foot joint: its height (cm) over the frames, the frames labelled contact shaded."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 1.6 * len(names)), dpi=100)
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    for c, (ax, name) in enumerate(zip(axes, names)):
        ax.plot(height[:, c], color="C0", lw=1.2)
        for t in np.flatnonzero(labels[:, c]):
            ax.axvspan(t - 0.5, t + 0.5, color="C2", alpha=0.25, lw=0)
        ax.set_ylabel(f"{name}\n(cm)", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[-1].set_xlabel("frame (30 fps)", fontsize=8)
    axes[0].set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="cmu_contacts", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", default=str(DEFAULT_DATA), help=f"folder of CMU BVH files (default {DEFAULT_DATA})")
    parser.add_argument("--workdir", required=True, help="training run folder (created or resumed)")
    parser.add_argument("--steps", type=int, default=40, help="training steps (default 40)")
    parser.add_argument("--frames", type=int, default=300, help="frames of the first take checked (default 300)")
    parser.add_argument("--out", required=True, help="output folder for contacts.json and contacts.png")
    args = parser.parse_args(argv)
    data_dir, out = pathlib.Path(args.data), pathlib.Path(args.out)
    if not data_dir.is_dir():
        parser.error(f"--data {data_dir}: no such folder")
    wall = train(data_dir, pathlib.Path(args.workdir), args.steps)
    model = trained_model.load_model(args.workdir)
    config = config_lib.load_config("cmu")
    windows, _ = datasets.get("bvh_folder").training_windows(data_dir, config.data)
    fraction = windows.contacts.mean(axis=(0, 1))
    first = bvh_folder.split_files(data_dir, config.data, "train")[0]
    labels = take_labels(windows, first.name, args.frames)  # the loader's labels on the take's own frames
    step, height = hand_count(first, config.data, model.feet, len(labels))
    recount = (step < CONTACT_THRESHOLD).astype(float)  # frame t: from t to t + 1
    agree = float((recount[:len(labels)] == labels).mean())
    rows = [{"frame": int(t), **{name: {"displacement_cm": round(float(np.sqrt(step[min(t, len(step) - 1), c])), 3),
                                        "height_cm": round(float(height[t, c]), 2), "label": int(labels[t, c])}
                                 for c, name in enumerate(model.feet_names)}}
            for t in range(0, len(labels), max(1, len(labels) // 12))]
    out.mkdir(parents=True, exist_ok=True)
    summary = {
        "command": f"bin/train --config cmu --workdir {args.workdir} --data {data_dir} --max-steps {args.steps}",
        "train_wall_s": round(wall, 1), "checkpoint": model.source, "windows": int(windows.contacts.shape[0]),
        "feet": list(model.feet_names), "feet_indices": list(model.feet),
        "contact_fraction_per_foot": {n: round(float(f), 4) for n, f in zip(model.feet_names, fraction)},
        "frames_checked": int(len(labels)), "labels_equal_recount": agree, "threshold_cm2_per_frame": CONTACT_THRESHOLD,
        "table": rows, "units": {"displacement_cm": "cm to the next frame (30 fps)",
                                 "height_cm": "cm above the lowest foot point of the frames checked"},
    }
    (out / "contacts.json").write_text(json.dumps(summary, indent=2) + "\n")
    contact_figure(height, labels, model.feet_names, f"{first.name}: foot height, contact frames shaded",
                   out / "contacts.png")
    print(f"feet: {', '.join(model.feet_names)}; contact fraction per foot over {summary['windows']} windows: "
          + ", ".join(f"{n} {f:.3f}" for n, f in summary["contact_fraction_per_foot"].items())
          + f"; frames 0-{len(labels) - 1} of {first.name}: labels equal the recount on {100 * agree:.1f} % of frames")
    for row in rows:
        print(f"frame {row['frame']:3d}: " + "; ".join(
            f"{n} {row[n]['displacement_cm']:.2f} cm/f, {row[n]['height_cm']:.1f} cm, "
            f"{'contact' if row[n]['label'] else 'moving'}" for n in model.feet_names))
    return 0


if __name__ == "__main__":
    sys.exit(main())
