"""Foot-locking settings compared on one set of cached transitions (validation takes only, never subject5).

    python experiments/2026-12-06_footlock_v6/tune.py --data /path/to/lafan1 --cache /tmp/val.npz \
        --variants '{"v3": {}, "lift_any": {"clearance_contact": false}}' --json out.json

The transitions are sampled once per length (the release model, 10 samples, the paper's sampling; cached in
--cache) and every variant (FootLockConfig fields) is scored on the same ones, as measure.py scores them; for
each, the remaining foot slide is split by where it comes from (the metric's weighted horizontal steps of the
foot joints within 2.5 cm of the ground): planted frames, frames the pass moved without planting (eased or
lifted), and frames it left alone.
"""
import argparse
import json
import os
import sys
import time

import jax
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import measure  # noqa: E402

from stitchjax.data import lafan1  # noqa: E402
from stitchjax.eval import metrics  # noqa: E402
from stitchjax.sample import footlock, inbetween, trained_model  # noqa: E402
from stitchjax.skeleton import forward_kinematics  # noqa: E402

VALIDATION = ("fallAndGetUp1_subject1", "ground1_subject4", "obstacles1_subject2")
START = 9


def sample(model, rot, pos, con, length, samples, chunk=128, sampling=None):
    """(rotations, positions, contacts) of the generated transitions (B, S, T, ...), keyframes included."""
    target = START + length + 1
    captured, real = [], inbetween._locked

    def capture(model_, rotations, positions, contacts, config_, counts):
        captured.append(contacts)
        return rotations

    inbetween._locked = capture
    try:
        parts = [inbetween.transitions_in_frame(
            model, rot[c, START], pos[c, START], con[c, START], rot[c, target], pos[c, target], con[c, target],
            length, samples, seed=length + i, foot_lock=True, **(sampling or {}))[:2]
            for i in range(0, len(rot), chunk) for c in [slice(i, i + chunk)]]
    finally:
        inbetween._locked = real
    return (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
            np.concatenate(captured))


def slide_sources(rotations, positions, stats, ground, parents):
    """The metric's foot slide split by the kind of frame each step starts from: {planted, moved (eased or
    lifted, not planted), untouched}, cm/frame over all counted joint-frames (they add up to the foot slide)."""
    _, g = forward_kinematics(rotations, positions, parents)
    x = np.swapaxes(g, 0, 1)[:, :, 1:][..., list(measure.FEET), :]  # (S, B, T-1, F, 3): as the metric reads it
    step = np.linalg.norm((x[:, :, 1:] - x[:, :, :-1])[..., [0, 2]], axis=-1)  # (S, B, T-2, F) cm
    weight = metrics.foot_contact_weight(x[:, :, :-1, :, 1] - ground[None, :, None, None])
    contribution, counted = weight * step, (weight > 0).sum()
    leg = np.array([0, 0, 1, 1])  # ankle, toe of the left leg, then the right
    planted = np.swapaxes(stats["planted"], 0, 1)[:, :, 1:-1][..., leg]
    changed = np.swapaxes(stats["changed"], 0, 1)[:, :, 1:-1][..., leg]
    return {"planted": float(contribution[planted].sum() / counted),
            "moved": float(contribution[changed & ~planted].sum() / counted),
            "untouched": float(contribution[~changed].sum() / counted)}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", default="../shared/data/lafan1")
    parser.add_argument("--cache", required=True)
    parser.add_argument("--lengths", default="30,50")
    parser.add_argument("--samples", type=int, default=10)
    parser.add_argument("--variants", required=True, help="JSON {name: {FootLockConfig field: value}}")
    parser.add_argument("--sampling", default="{}", help="JSON of transitions_in_frame's noise_scale, "
                        "noise_correlation, noise_ramp_steps (default: the paper's sampling)")
    parser.add_argument("--json", required=True)
    args = parser.parse_args(argv)
    windows = lafan1.build_windows([os.path.join(args.data, f"{t}.bvh") for t in VALIDATION], 65, 40, workers=1)
    parents = tuple(windows.skeleton.parents)
    rot, pos, con = (np.asarray(x, np.float64) for x in (windows.rotations, windows.positions, windows.contacts))
    gt_q_all, gt_p_all = forward_kinematics(rot, pos, parents)
    ground = metrics.ground_heights(gt_p_all, measure.FEET)
    offsets = np.asarray(windows.skeleton.offsets)
    lengths = [int(x) for x in args.lengths.split(",")]
    if os.path.exists(args.cache):
        cache = dict(np.load(args.cache))
    else:
        model = trained_model.pretrained()
        cache = {}
        for length in lengths:
            r, p, c = sample(model, rot, pos, con, length, args.samples, sampling=json.loads(args.sampling))
            cache.update({f"r{length}": r, f"p{length}": p, f"c{length}": c})
        np.savez(args.cache, **cache)
    variants = json.loads(args.variants)
    result = {"windows": int(len(rot)), "takes": VALIDATION, "samples": args.samples,
              "sampling": json.loads(args.sampling), "lengths": {}}
    for length in lengths:
        r, p, c = cache[f"r{length}"], cache[f"p{length}"], cache[f"c{length}"]
        target = START + length + 1
        gt_q, gt_p = gt_q_all[:, START + 1:target], gt_p_all[:, START + 1:target]
        entry = {"model": measure.scores(r, p, gt_q, gt_p, ground, offsets, parents)}
        for name, fields in variants.items():
            config = footlock.FootLockConfig(**fields)
            t0 = time.perf_counter()
            locked, _, stats = footlock.lock_transitions(r, p, c, windows.skeleton, measure.FEET, config, sample_axis=1)
            s = measure.scores(locked, p, gt_q, gt_p, ground, offsets, parents)
            m = entry["model"]
            s.update({f"{k}_change_pct": 100 * (s[k] / m[k] - 1) for k in ("ade", "slde", "npss", "apd")})
            s["sources"] = slide_sources(locked, p, stats, ground, parents)
            s["fields"] = fields
            s["seconds"] = time.perf_counter() - t0
            entry[name] = s
            jax.clear_caches()  # one compiled pass per setting: without this, memory grows with every setting
            print(f"L={length} {name:>14}: slide {m['foot_slide']:.3f} -> {s['foot_slide']:.3f} "
                  f"(planted {s['sources']['planted']:.3f} moved {s['sources']['moved']:.3f} "
                  f"untouched {s['sources']['untouched']:.3f}) ADE {s['ade_change_pct']:+.1f}% "
                  f"SLDE {s['slde_change_pct']:+.1f}% NPSS {s['npss_change_pct']:+.1f}% "
                  f"APD {s['apd_change_pct']:+.1f}% jump {s['max_joint_jump_cm']:.1f} "
                  f"knee {s['max_knee_change_deg_per_frame']:.1f}", flush=True)
        result["lengths"][str(length)] = entry
    result["command"] = "python " + " ".join(sys.argv)
    with open(args.json, "w") as f:
        json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
