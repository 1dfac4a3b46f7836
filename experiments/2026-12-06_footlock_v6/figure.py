"""The before/after figure: foot heights and sliding along one 50-frame test transition, without and with
foot locking, planted spans shaded.

    python experiments/2026-12-06_footlock_v6/figure.py --out experiments/2026-12-06_footlock_v6/foot_lock_L50.png

The window: among the first 64 subject5 test windows (one sample each, seed 0), the one whose foot slide
without the pass is closest to the mean over those 64 (a typical window, not a chosen one).
"""
import argparse
import json
import sys
import time

import numpy as np

from stitchjax.sample import footlock, inbetween, trained_model
from stitchjax.data import lafan1
from stitchjax.eval import metrics, plots
from stitchjax.skeleton import forward_kinematics

FEET = (3, 4, 7, 8)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", default="../shared/data/lafan1")
    parser.add_argument("--checkpoint", default="stitchjax/pretrained/lafan1_cpu_release")
    parser.add_argument("--length", type=int, default=50)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    started = time.time()
    windows = lafan1.test_windows(args.data)[:64]
    model = trained_model.load_model(args.checkpoint)
    parents = tuple(windows.skeleton.parents)
    rot, pos, con = (np.asarray(x, np.float64) for x in (windows.rotations, windows.positions, windows.contacts))
    s, t = 9, 9 + args.length + 1
    captured = []
    real = inbetween._locked
    inbetween._locked = lambda m, r, p, c, cfg, counts: captured.append(c) or r
    r, p, _ = inbetween.transitions_in_frame(model, rot[:, s], pos[:, s], con[:, s], rot[:, t], pos[:, t], con[:, t],
                                             args.length, 1, seed=0, foot_lock=True)
    inbetween._locked = real
    ground = metrics.ground_heights(forward_kinematics(rot, pos, parents)[1], FEET)
    g = forward_kinematics(r[:, 0], p[:, 0], parents)[1]  # (B, T, J, 3)
    weighted, count = metrics.foot_slide_parts(g[:, 1:], ground, FEET)
    slide = weighted / np.maximum(count, 1)
    k = int(np.argmin(np.abs(slide - weighted.sum() / count.sum())))
    locked, _, stats = footlock.lock_transitions(r[k, 0], p[k, 0], captured[0][k, 0], windows.skeleton, FEET)
    after = forward_kinematics(locked, p[k, 0], parents)[1]
    w_after, c_after = metrics.foot_slide_parts(after[None, 1:], ground[k:k + 1], FEET)
    source = windows.sources[k] if getattr(windows, "sources", None) else f"window {k}"
    title = (f"{source}, L = {args.length}, sample 0: foot slide {slide[k]:.2f} -> "
             f"{float(w_after.sum() / c_after.sum()):.2f} cm/frame (ground truth ground)")
    plots.foot_lock_before_after(g[k], after, stats["planted"], FEET, let_go=stats["let_go"], ground=ground[k],
                                 title=title, path=args.out)
    print(title)
    with open(args.out.rsplit(".", 1)[0] + ".json", "w") as f:
        json.dump({"window": k, "source": source, "foot_slide_before": float(slide[k]),
                   "foot_slide_after": float(w_after.sum() / c_after.sum()),
                   "command": "python " + " ".join(sys.argv),
                   "wall_s": time.time() - started}, f, indent=1)


if __name__ == "__main__":
    main()
