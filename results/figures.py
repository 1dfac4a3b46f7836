#!/usr/bin/env python3
"""Figures of a trained model on the LAFAN1 test windows: a filmstrip and root paths of N samples of one
window, and the latent-space notebook executed on the model with its figures saved as PNG files.

    python results/figures.py --checkpoint runs/lafan1_cpu --data ../shared/data/lafan1 --out results/lafan1_cpu

Writes OUT/filmstrip_L50.png (ground truth first, then the samples), OUT/root_paths_L50.png,
OUT/window_L50.json (the window, the per-joint spread between samples at mid-transition in cm) and
OUT/notebook/latent_space_<k>.png (every figure of notebooks/latent_space.ipynb, in order).
"""
from __future__ import annotations

import argparse
import base64
import json
import os
import pathlib
import sys

REPO = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from stitchjax.eval import evaluate, metrics, plots  # noqa: E402
from stitchjax.data import lafan1
from stitchjax.sample import trained_model
from stitchjax.skeleton import forward_kinematics  # noqa: E402

START = 9  # the protocol's start keyframe (docs/design.md §6)


def window_figures(model, windows, index: int, length: int, samples: int, seed: int, out: pathlib.Path,
                   noise_scale: float = 1.0, noise_correlation: float | None = None,
                   noise_ramp: int = 0) -> dict:
    """Filmstrip and root paths of ``samples`` transitions of test window ``index``, the latent noise scaled
    by ``noise_scale``, correlated from frame to frame by ``noise_correlation`` (None: the model's) and
    ramped up over ``noise_ramp`` frames from each keyframe; returns a summary."""
    one = windows[index:index + 1]
    method = evaluate.model_method(model, noise_scale=noise_scale, noise_correlation=noise_correlation,
                                   noise_ramp_steps=noise_ramp)
    rotations, positions = method(one, START, length, samples, seed)  # (S, 1, L, J, .)
    rot_all = np.asarray(one.rotations, np.float64)[0, START:START + length + 2]
    pos_all = np.asarray(one.positions, np.float64)[0, START:START + length + 2]
    motions = []
    for s in range(samples):
        rot = rot_all.copy()
        pos = pos_all.copy()
        rot[1:-1], pos[1:-1] = rotations[s, 0], positions[s, 0]
        motions.append(forward_kinematics(rot, pos, model.parents)[1])
    truth = forward_kinematics(rot_all, pos_all, model.parents)[1]
    motions = np.stack(motions)  # (S, L + 2, J, 3) cm
    spread_mid = float(metrics.joint_spread_per_window(motions[:, None, 1:-1], frame=length // 2)[0])
    spread = float(metrics.joint_spread_per_window(motions[:, None, 1:-1])[0])
    titles = ["ground truth"] + [f"sample {s + 1}" for s in range(samples)]
    suffix = "" if noise_scale == 1.0 else f"_noise{noise_scale:g}"
    noise = "" if noise_scale == 1.0 else f", latent noise x{noise_scale:g}"
    if noise_correlation is not None:
        suffix += f"_rho{noise_correlation:g}"
        noise += f", noise correlation {noise_correlation:g}"
    if noise_ramp:
        suffix += f"_ramp{noise_ramp}"
        noise += f", ramp {noise_ramp}"
    plots.filmstrip([truth] + list(motions), model.parents, every=5, titles=titles,
                    title=f"LAFAN1 subject5 test window {index}, L = {length}: {samples} samples{noise} "
                          f"(mid-transition spread {spread_mid:.1f} cm per joint)",
                    path=out / f"filmstrip_L{length}{suffix}.png")
    plots.root_trajectories(list(motions), reference=truth, title=f"root paths, window {index}, L = {length}",
                            path=out / f"root_paths_L{length}{suffix}.png")
    summary = {"window": index, "length": length, "samples": samples, "seed": seed,
               "noise_scale": noise_scale, "noise_correlation": noise_correlation, "noise_ramp": noise_ramp,
               "spread_cm": spread, "spread_mid_cm": spread_mid}
    (out / f"window_L{length}{suffix}.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary


def notebook_figures(checkpoint: pathlib.Path, out: pathlib.Path) -> int:
    """Execute notebooks/latent_space.ipynb on ``checkpoint``; save its PNG outputs; return their number."""
    import nbclient
    import nbformat

    os.environ["STITCHJAX_CHECKPOINT"] = str(checkpoint.resolve())
    path = REPO / "notebooks" / "latent_space.ipynb"
    notebook = nbformat.read(path, as_version=4)
    nbclient.NotebookClient(notebook, timeout=1800, kernel_name="python3",
                            resources={"metadata": {"path": str(path.parent)}}).execute()
    out.mkdir(parents=True, exist_ok=True)
    count, text = 0, []
    for cell in notebook.cells:
        for output in cell.get("outputs", []):
            if "image/png" in output.get("data", {}):
                count += 1
                (out / f"latent_space_{count}.png").write_bytes(base64.b64decode(output["data"]["image/png"]))
            if output.get("output_type") == "stream":
                text.append(output.get("text", ""))
    (out / "latent_space_output.txt").write_text("".join(text))
    return count


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--checkpoint", required=True, help="training run folder of the model")
    parser.add_argument("--data", required=True, help="LAFAN1 folder with the subject5 files")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--window", type=int, default=100, help="test window index (default 100)")
    parser.add_argument("--length", type=int, default=50, help="transition length (default 50)")
    parser.add_argument("--samples", type=int, default=8, help="samples (default 8)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--noise-scale", type=float, default=1.0,
                        help="factor on the latent noise of the filmstrip's samples (default 1; files get a _noise<s> suffix)")
    parser.add_argument("--noise-correlation", type=float, default=None,
                        help="the latent noise's correlation from frame to frame (default: the model's; files get "
                             "a _rho<r> suffix when given)")
    parser.add_argument("--noise-ramp", type=int, default=0, metavar="FRAMES",
                        help="the noise rises from 0 at the frames next to the keyframes to full over this many "
                             "frames (default 0; files get a _ramp<n> suffix)")
    parser.add_argument("--no-notebook", action="store_true", help="skip executing the notebook")
    args = parser.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    model = trained_model.load_model(args.checkpoint)
    windows = lafan1.test_windows(args.data)
    if not 0 <= args.window < len(windows):
        parser.error(f"--window {args.window}: the test set has {len(windows)} windows (0..{len(windows) - 1})")
    print(json.dumps(window_figures(model, windows, args.window, args.length, args.samples, args.seed, out,
                                    args.noise_scale, args.noise_correlation, args.noise_ramp)))
    if not args.no_notebook:
        print(f"notebook: {notebook_figures(pathlib.Path(args.checkpoint), out / 'notebook')} figures")
    return 0


if __name__ == "__main__":
    sys.exit(main())
