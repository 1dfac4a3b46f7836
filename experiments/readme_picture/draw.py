"""The README picture (docs/images/samples.png) and the viewer's screenshot (docs/images/viewer.png): 8 samples of
the release model between frames 200 and 246 of the bundled take (45 generated frames), at its default sampling.

Runs bin/inbetween (--samples 8 --html), draws its sample BVHs with stitchjax.eval.plots.samples_overview (root
paths from above above each sample's middle frame from the side) and screenshots its HTML page in headless chromium
(where one is installed; skipped otherwise), opened at the middle frame. Runs it again with --paper-sampling for
the spread at the paper's sampling. Writes drawn.json: what was drawn and how far apart the samples are.

    python experiments/readme_picture/draw.py [--checkpoint DIR] [--images docs/images]
"""
import argparse
import itertools
import json
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parent.parent
sys.path.insert(0, str(REPO))

from stitchjax.data import bvh  # noqa: E402
from stitchjax.eval import plots  # noqa: E402

TAKE = "stitchjax/data/sample_data/lafan1/obstacles1_subject5.bvh.gz"
START, END, SAMPLES, SEED = 200, 246, 8, 0
CONTEXT = 10  # frames bin/inbetween's page shows before the start keyframe
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--hide-scrollbars"]


def spreads(g, middle):
    """Spread figures (cm) of the samples' global positions g (S, T, J, 3) over frames START + 1 .. END - 1."""
    inner = g[:, START + 1:END]
    pairs = list(itertools.combinations(range(len(g)), 2))
    joint = [np.linalg.norm(inner[i] - inner[j], axis=-1) for i, j in pairs]  # (45, J) each
    root_mid = [np.linalg.norm(g[i, middle, 0, [0, 2]] - g[j, middle, 0, [0, 2]]) for i, j in pairs]
    chord = g[0, END, 0, [0, 2]] - g[0, START, 0, [0, 2]]
    side = np.array([-chord[1], chord[0]]) / max(np.linalg.norm(chord), 1e-9)
    offsets = (inner[:, :, 0][..., [0, 2]] - g[0, START, 0, [0, 2]]) @ side  # (S, 45): off the keyframes' line
    return {"joint_spread_middle_cm": round(float(np.mean([p[middle - START - 1].mean() for p in joint])), 2),
            "joint_spread_cm": round(float(np.mean([p.mean() for p in joint])), 2),
            "root_spread_middle_cm": round(float(np.mean(root_mid)), 2),
            "root_off_line_max_cm": [round(float(x), 1) for x in np.abs(offsets).max(axis=1)],
            "keyframe_root_distance_cm": round(float(np.linalg.norm(chord)), 1)}


def screenshot(page: pathlib.Path, frame: int, out: pathlib.Path) -> str | None:
    """A PNG of ``page`` opened at ``frame`` by headless chromium; None where there is none."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        return None
    with tempfile.TemporaryDirectory() as profile:
        subprocess.run([browser, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", "--window-size=960,600",
                        "--virtual-time-budget=2000", f"--screenshot={out}", f"{page.as_uri()}#frame={frame}"],
                       check=True, capture_output=True, timeout=120)
    version = subprocess.run([browser, "--version"], capture_output=True, text=True).stdout.strip()
    return version


def _shown(path: pathlib.Path) -> str:
    """``path`` relative to the repository where it lies inside it."""
    path = path.resolve()
    return str(path.relative_to(REPO)) if path.is_relative_to(REPO) else str(path)


def samples(checkpoint, extra: list, out: str) -> tuple:
    """(the bin/inbetween command, the samples' global positions (S, T, J, 3) cm) of one run into ``out``."""
    command = ["bin/inbetween", "--bvh", TAKE, "--start-frame", str(START), "--end-frame", str(END),
               "--samples", str(SAMPLES), "--seed", str(SEED), *extra, "--out", "OUT"]
    if checkpoint:
        command[1:1] = ["--checkpoint", checkpoint]
    subprocess.run([sys.executable] + [out if c == "OUT" else c for c in command], check=True, capture_output=True,
                   cwd=REPO)
    stem = pathlib.Path(TAKE).name.split(".")[0]
    paths = sorted(pathlib.Path(out).glob(f"{stem}_sample*.bvh"), key=lambda p: int(p.stem.rsplit("sample", 1)[1]))
    return " ".join(command), np.stack([bvh.load(p).global_positions() for p in paths])


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--checkpoint", help="model folder (default: the release model)")
    parser.add_argument("--images", default=str(REPO / "docs" / "images"), help="where samples.png and viewer.png go")
    args = parser.parse_args()
    images = pathlib.Path(args.images)
    started = time.perf_counter()
    stem = pathlib.Path(TAKE).name.split(".")[0]
    middle = (START + END) // 2
    take = bvh.load(REPO / TAKE)
    with tempfile.TemporaryDirectory() as tmp:
        command, g = samples(args.checkpoint, ["--html"], tmp)
        window = slice(START - CONTEXT, END + CONTEXT + 1)
        plots.samples_overview(list(g[:, window]), take.skeleton.parents, keyframes=(CONTEXT, CONTEXT + END - START),
                               reference=take.global_positions()[window],
                               title=f"{SAMPLES} samples of the release model between frames {START} and {END} of "
                                     f"{stem} (default sampling, seed {SEED})",
                               path=images / "samples.png")
        browser = screenshot(pathlib.Path(tmp) / f"{stem}.html", middle - (START - CONTEXT), images / "viewer.png")
    figures = spreads(g, middle)
    with tempfile.TemporaryDirectory() as tmp:
        paper_command, paper = samples(args.checkpoint, ["--paper-sampling"], tmp)
    paper_figures = spreads(paper, middle)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=REPO).stdout.strip()
    drawn = {"what": __doc__.split("\n\n")[0].replace("\n", " "), "command": command, "commit": commit,
             "take": TAKE, "keyframes": [START, END], "middle_frame": middle, "samples": SAMPLES, "seed": SEED,
             "units": "cm", "spread": figures, "paper_sampling": {"command": paper_command, "spread": paper_figures},
             "samples_png": _shown(images / "samples.png"),
             "viewer_png": _shown(images / "viewer.png") if browser else None, "browser": browser,
             "wall_s": round(time.perf_counter() - started, 1)}
    (HERE / "drawn.json").write_text(json.dumps(drawn, indent=2) + "\n")
    print(json.dumps(drawn, indent=2))


if __name__ == "__main__":
    main()
