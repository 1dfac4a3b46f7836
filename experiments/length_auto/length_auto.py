"""Fit, choose and measure the length model of ``bin/inbetween --length auto`` (stitchjax.sample.length).

    python experiments/length_auto/length_auto.py choose      # fit on training, choose on validation
    python experiments/length_auto/length_auto.py reference   # k-NN on validation, not shipped
    python experiments/length_auto/length_auto.py test        # the chosen model on subject5, once
(--data FOLDER: the LAFAN1 folder, default ../shared/data/lafan1 beside the checkout)

Keyframe pairs are cut from the takes at every START_STEP-th frame and every gap of GAPS frames (frames between
the keyframes, at 30 fps). choose: fits each variant of VARIANTS on the training takes (LAFAN1 subjects 1-4 less
the validation files), scores them on the validation files, picks one by the rule of README.md, writes it to
stitchjax/pretrained/lafan1_cpu_release/length_model.json and choice.json here. test: scores the shipped model
and the baselines on the subject5 pairs and writes test.json here (no choice is made from it).
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import platform
import subprocess
import sys
import time

import numpy as np
from scipy import optimize

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parent.parent
sys.path.insert(0, str(REPO))

from stitchjax import pretrained  # noqa: E402
from stitchjax.data import bvh, features, lafan1  # noqa: E402
from stitchjax.sample import length, takes  # noqa: E402

VALIDATION = ("fallAndGetUp1_subject1", "ground1_subject4", "obstacles1_subject2")
GAPS = np.arange(10, 51)           # frames between the keyframes
START_STEP = 10                    # a start keyframe every 10 frames
QUANTILES = (0.1, 0.5, 0.9)
FIT_PAIRS = 20000                  # training pairs the quantile regressions are fitted on (random, seed 0)
# each transform's scale: log(1 + |value| / scale)
SCALES = {"distance": 50.0, "turn": 30.0, "pose": 10.0, "rise": 10.0, "height": 50.0}
# the grid: which columns of length.design_matrix each variant uses (the others' coefficients are 0)
VARIANTS = {
    "distance": ("distance",),
    "distance+turn": ("distance", "turn"),
    "distance+turn+pose": ("distance", "turn", "pose"),
    "distance+turn+pose+rise": ("distance", "turn", "pose", "rise"),
    "all": ("distance", "turn", "pose", "rise", "height"),
}
TIE_FRAMES = 0.25  # variants within this of the best validation median error count as tied: fewest columns wins


def take_pairs(path) -> tuple:
    """(features (N, 5), gaps (N,)) of every pair of one take: starts every START_STEP frames, every gap."""
    motion = bvh.load(path)
    rotations, positions = motion.global_transforms()
    starts = np.arange(0, motion.num_frames - GAPS.max() - 1, START_STEP)
    a = np.repeat(starts, len(GAPS))
    gaps = np.tile(GAPS, len(starts))
    b = a + gaps + 1
    f = length.pair_features(positions[a], rotations[a, 0], positions[b], rotations[b, 0], (0.0, 1.0, 0.0))
    return f, gaps


def pairs(files) -> tuple:
    """(features (N, 5), gaps (N,), take index (N,)) of all ``files``."""
    out = [take_pairs(p) for p in files]
    take = np.concatenate([np.full(len(g), k) for k, (_, g) in enumerate(out)])
    return np.concatenate([f for f, _ in out]), np.concatenate([g for _, g in out]), take


def quantile_fit(x, y, q: float, free, nonnegative) -> np.ndarray:
    """Coefficients (K,) of the q-quantile linear regression of y on x (N, K) (least absolute deviations,
    tilted), as a linear programme; columns not in ``free`` fixed at 0, those in ``nonnegative`` kept >= 0."""
    n, k = x.shape
    # variables: beta (k), u+ (n), u- (n); x beta + u+ - u- = y; minimise q sum u+ + (1 - q) sum u-
    cost = np.concatenate([np.zeros(k), np.full(n, q), np.full(n, 1.0 - q)])
    bounds = []
    for j in range(k):
        if j not in free:
            bounds.append((0.0, 0.0))
        elif j in nonnegative:
            bounds.append((0.0, None))
        else:
            bounds.append((None, None))
    bounds += [(0.0, None)] * (2 * n)
    from scipy import sparse
    a_eq = sparse.hstack([sparse.csr_matrix(x), sparse.identity(n), -sparse.identity(n)]).tocsr()
    result = optimize.linprog(cost, A_eq=a_eq, b_eq=y, bounds=bounds, method="highs-ipm")
    if not result.success:
        raise RuntimeError(f"quantile {q}: {result.message}")
    return result.x[:k]


def fit_variant(columns, feats, gaps) -> length.LengthModel:
    """The length model of one variant fitted on training pairs ``feats`` (N, 5), ``gaps`` (N,)."""
    x = length.design_matrix(feats, SCALES)
    y = np.log(gaps + 1.0)
    names = [name for name, _ in length.COLUMNS]
    free = {0} | {1 + names.index(c) for c in columns}
    nonnegative = {1 + names.index(c) for c in length.MONOTONE}
    coefficients = np.stack([quantile_fit(x, y, q, free, nonnegative) for q in QUANTILES])
    return length.LengthModel(fps=30.0, quantiles=QUANTILES, scales=dict(SCALES), coefficients=coefficients,
                              min_frames=int(GAPS.min()), max_frames=int(GAPS.max()),
                              joint_names=tuple(lafan1_joint_names()), forward_axis=(0.0, 1.0, 0.0))


def lafan1_joint_names():
    from stitchjax.skeleton import LAFAN1_JOINTS
    return LAFAN1_JOINTS


def speed_floor(feats) -> np.ndarray:
    """(N,) the fewest frames that keep each pair's root under the release model's speed limit, as
    stitchjax.sample.takes floors the proposal."""
    limit, _ = takes.root_speed_limit(pretrained())
    return takes.fewest_frames(feats[:, 0], limit, 30.0)


def score(pred, low, high, gaps) -> dict:
    err = np.abs(pred - gaps)
    out = {"median_abs_error": float(np.median(err)), "mean_abs_error": float(np.mean(err)),
           "p90_abs_error": float(np.percentile(err, 90)), "pairs": int(len(gaps))}
    if low is not None:
        out["within_range"] = float(np.mean((gaps >= low) & (gaps <= high)))
        out["mean_range_width"] = float(np.mean(high - low))
    return out


def model_predictions(length_model, feats) -> tuple:
    p = length.propose_lengths(length_model, feats, speed_floor(feats))
    return p[:, 1], p[:, 0], p[:, 2]


def walking_speed(train_files) -> dict:
    """Median root speed (cm/s) of the training walk takes and of all training takes (whole takes, 30 fps)."""
    def p50(files):
        roots = [bvh.load(f).positions[:, 0] for f in files]
        speeds = np.concatenate([np.linalg.norm(np.diff(r[:, [0, 2]], axis=0), axis=-1) * 30.0 for r in roots])
        return float(np.median(speeds))
    walks = [f for f in train_files if f.name.startswith("walk")]
    return {"walk_takes": [f.name for f in walks], "median_walking_speed": p50(walks),
            "median_speed_all_training": p50(train_files)}


def baseline(feats, speed) -> np.ndarray:
    """Distance over speed, in frames between the keyframes at 30 fps, kept within the gaps measured."""
    return np.clip(np.round(feats[:, 0] / speed * 30.0 - 1.0), GAPS.min(), GAPS.max())


def machine() -> str:
    return f"{platform.node()}, {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs"


def commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO, capture_output=True, text=True).stdout.strip()
    except OSError:
        return "unknown"


def split_files(data):
    found = lafan1.list_files(data)
    train = [p for s in lafan1.TRAIN_SUBJECTS for p in found.get(s, [])]
    validation = [p for p in train if p.name.split(".")[0] in VALIDATION]
    train = [p for p in train if p.name.split(".")[0] not in VALIDATION]
    test = [p for s in lafan1.TEST_SUBJECTS for p in found.get(s, [])]
    return sorted(train), sorted(validation), sorted(test)


def choose(args) -> None:
    started = time.perf_counter()
    train, validation, _ = split_files(args.data)
    tf, tg, _ = pairs(train)
    vf, vg, _ = pairs(validation)
    rng = np.random.default_rng(0)
    pick = rng.choice(len(tg), size=min(FIT_PAIRS, len(tg)), replace=False)
    speeds = walking_speed(train)
    # the rule's strongest form: the one speed that fits the validation pairs best
    grid = np.arange(20.0, 301.0, 1.0)
    speeds["best_validation_speed"] = float(grid[np.argmin([np.median(np.abs(baseline(vf, v) - vg)) for v in grid])])
    results = {"baseline_walking_speed": score(baseline(vf, speeds["median_walking_speed"]), None, None, vg),
               "baseline_best_speed": score(baseline(vf, speeds["best_validation_speed"]), None, None, vg),
               "baseline_all_speed": score(baseline(vf, speeds["median_speed_all_training"]), None, None, vg),
               "constant_30": score(np.full(len(vg), 30.0), None, None, vg)}
    fitted = {}
    for name, columns in VARIANTS.items():
        fitted[name] = fit_variant(columns, tf[pick], tg[pick])
        results[name] = {**score(*model_predictions(fitted[name], vf), vg), "columns": list(columns),
                         "coefficients": fitted[name].coefficients.tolist()}
        print(name, json.dumps({k: v for k, v in results[name].items() if k != "coefficients"}), flush=True)
    best = min(results[n]["median_abs_error"] for n in VARIANTS)
    tied = [n for n in VARIANTS if results[n]["median_abs_error"] <= best + TIE_FRAMES]
    chosen = min(tied, key=lambda n: (len(VARIANTS[n]), results[n]["median_abs_error"]))
    model = fitted[chosen]
    notes = {"fitted_by": "experiments/length_auto/length_auto.py choose", "variant": chosen,
             "data": f"LAFAN1 subjects 1-4 less {', '.join(VALIDATION)}: {len(train)} takes, {FIT_PAIRS} of "
                     f"{len(tg)} pairs (starts every {START_STEP} frames, gaps {GAPS.min()}-{GAPS.max()})",
             "chosen_on": f"validation takes {', '.join(VALIDATION)}"}
    model = length.LengthModel(**{**model.__dict__, "notes": notes})
    length.save_length_model(model, length.SHIPPED)
    record = {"command": " ".join(sys.argv), "commit": commit(), "machine": machine(),
              "wall_s": round(time.perf_counter() - started, 1), "train_takes": [p.name for p in train],
              "validation_takes": [p.name for p in validation], "train_pairs": int(len(tg)),
              "fit_pairs": int(len(pick)), "validation_pairs": int(len(vg)), "speeds_cm_per_s": speeds,
              "scales": SCALES, "quantiles": QUANTILES, "tie_frames": TIE_FRAMES, "results": results,
              "chosen": chosen}
    (HERE / "choice.json").write_text(json.dumps(record, indent=1) + "\n")
    print("chosen:", chosen, "written", length.SHIPPED)


def reference(args) -> None:
    """A nonparametric reference on the validation pairs, never shipped: the gaps of the k nearest training
    pairs (standardised design-matrix columns), their median as the proposal and 10th-90th percentile as the
    range; shows how much the small model leaves on the table."""
    from scipy.spatial import cKDTree

    started = time.perf_counter()
    train, validation, _ = split_files(args.data)
    tf, tg, _ = pairs(train)
    vf, vg, _ = pairs(validation)
    xt, xv = length.design_matrix(tf, SCALES)[:, 1:], length.design_matrix(vf, SCALES)[:, 1:]
    mean, std = xt.mean(0), xt.std(0)
    xt, xv = (xt - mean) / std, (xv - mean) / std
    names = [name for name, _ in length.COLUMNS]
    results = {}
    for variant in ("distance+turn+pose", "all"):
        cols = [names.index(c) for c in VARIANTS[variant]]
        tree = cKDTree(xt[:, cols])
        for k in (50, 400):
            _, index = tree.query(xv[:, cols], k=k)
            near = tg[index]
            results[f"knn{k} {variant}"] = score(np.round(np.median(near, 1)), np.percentile(near, 10, 1),
                                                 np.percentile(near, 90, 1), vg)
            print(f"knn{k} {variant}", json.dumps(results[f"knn{k} {variant}"]), flush=True)
    record = {"command": " ".join(sys.argv), "commit": commit(), "machine": machine(),
              "wall_s": round(time.perf_counter() - started, 1), "train_pairs": int(len(tg)),
              "validation_pairs": int(len(vg)), "results": results}
    (HERE / "reference.json").write_text(json.dumps(record, indent=1) + "\n")


def test(args) -> None:
    started = time.perf_counter()
    train, _, test_files = split_files(args.data)
    f, g, _ = pairs(test_files)
    speeds = {**walking_speed(train), "best_validation_speed": json.loads(
        (HERE / "choice.json").read_text())["speeds_cm_per_s"]["best_validation_speed"]}
    model = length.load_length_model()
    results = {"length_auto": score(*model_predictions(model, f), g),
               "baseline_walking_speed": score(baseline(f, speeds["median_walking_speed"]), None, None, g),
               "baseline_best_speed": score(baseline(f, speeds["best_validation_speed"]), None, None, g),
               "baseline_all_speed": score(baseline(f, speeds["median_speed_all_training"]), None, None, g),
               "constant_30": score(np.full(len(g), 30.0), None, None, g)}
    by_gap = {}
    pred, low, high = model_predictions(model, f)
    base = baseline(f, speeds["median_walking_speed"])
    for lo, hi in ((10, 20), (21, 30), (31, 40), (41, 50)):
        sel = (g >= lo) & (g <= hi)
        by_gap[f"{lo}-{hi}"] = {"length_auto": score(pred[sel], low[sel], high[sel], g[sel]),
                                "baseline_walking_speed": score(base[sel], None, None, g[sel])}
    record = {"command": " ".join(sys.argv), "commit": commit(), "machine": machine(),
              "wall_s": round(time.perf_counter() - started, 1), "test_takes": [p.name for p in test_files],
              "test_pairs": int(len(g)), "speeds_cm_per_s": speeds, "variant": model.notes.get("variant"),
              "results": results, "by_gap": by_gap}
    (HERE / "test.json").write_text(json.dumps(record, indent=1) + "\n")
    print(json.dumps(results, indent=1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("stage", choices=("choose", "reference", "test"))
    parser.add_argument("--data", default=str(REPO.parent / "shared" / "data" / "lafan1"))
    args = parser.parse_args()
    {"choose": choose, "reference": reference, "test": test}[args.stage](args)


if __name__ == "__main__":
    main()
