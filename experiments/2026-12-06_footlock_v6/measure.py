"""Foot locking measured: each length's transitions sampled once and scored without and with the pass.

    python experiments/2026-12-06_footlock_v6/measure.py --windows train --count 48 --json tune.json   # tuning
    python experiments/2026-12-06_footlock_v6/measure.py --windows test --json test.json               # 376 windows

--windows train: windows of 65 frames every 40 of training takes (subjects 1-4; --takes, default six of them),
evenly spaced --count of them; test: the subject5 test windows. Per length: foot slide (cm/frame), ADE,
SLDE (m), NPSS, APD (m) as in bin/evaluate model (ground = the window's lowest ground-truth foot height), the
largest per-frame joint displacement (cm) over the keyframes and generated frames against the ground truth's
over whole windows, the largest bone-length change (cm), the largest knee-angle change per frame (degrees;
the ground truth's beside it), the shares of planted, let-go and lifted (``clearance``) generated
leg-frames, and the pass's time against sampling's. --checkpoint: a training run or an exported model
folder (default: the release model, stitchjax.pretrained(); version 2 was measured with the earlier release
model lafan1_cpu_mixed, which git history keeps).
"""
import argparse
import dataclasses
import json
import os
import platform
import subprocess
import sys
import time

import numpy as np

from stitchjax.sample import footlock, inbetween, trained_model
from stitchjax.data import lafan1
from stitchjax.eval import metrics
from stitchjax.skeleton import forward_kinematics

TRAIN_TAKES = ("walk4_subject1", "obstacles1_subject2", "multipleActions1_subject3", "pushAndFall1_subject4",
               "dance1_subject2", "obstacles3_subject4")
FEET = (3, 4, 7, 8)
LEGS = ((1, 2, 3), (5, 6, 7))


def cpu_name():
    """The processor's model name (/proc/cpuinfo), else what platform says."""
    try:
        with open("/proc/cpuinfo") as f:
            return next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        return platform.processor() or platform.machine()


def knee_angles(g):
    """(..., 2) knee angles in degrees of global positions (..., J, 3)."""
    out = []
    for hip, knee, ankle in LEGS:
        u, v = g[..., hip, :] - g[..., knee, :], g[..., ankle, :] - g[..., knee, :]
        c = (u * v).sum(-1) / np.linalg.norm(u, axis=-1) / np.linalg.norm(v, axis=-1)
        out.append(np.degrees(np.arccos(np.clip(c, -1, 1))))
    return np.stack(out, -1)


def scores(rotations, positions, gt_q, gt_p, ground, offsets, parents):
    """Metrics of transitions (B, S, T, J, ...) (keyframes included) against the ground truth (B, L, J, ...)."""
    q, g = forward_kinematics(rotations, positions, parents)
    qs, gs = np.swapaxes(q, 0, 1)[:, :, 1:-1], np.swapaxes(g, 0, 1)
    gen = gs[:, :, 1:-1]
    weighted, count = metrics.foot_slide_parts(gs[:, :, 1:], ground, FEET)
    _, power = metrics.npss_parts(gt_q, gt_q)
    samples = gen.shape[0]
    bones = np.linalg.norm(g[..., 1:, :] - g[..., np.array(parents[1:]), :], axis=-1)
    return {
        "foot_slide": float(weighted.sum() / count.sum()),
        "ade": float(metrics.displacement_per_window(gen, gt_p).mean() * 0.01),
        "slde": float(metrics.displacement_per_window(gen[:, :, -1:], gt_p[:, -1:]).mean() * 0.01),
        "npss": float(metrics.npss_parts(qs, gt_q)[0].sum() / (samples * power.sum())),
        "apd": float(metrics.apd_per_window(gen).mean() * 0.01),
        "max_joint_jump_cm": float(np.linalg.norm(np.diff(g, axis=2), axis=-1).max()),
        "max_bone_length_change_cm": float(np.abs(bones - np.linalg.norm(offsets[1:], axis=-1)).max()),
        "max_knee_change_deg_per_frame": float(np.abs(np.diff(knee_angles(g), axis=2)).max()),
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", default="../shared/data/lafan1")
    parser.add_argument("--checkpoint", default=None, help="default: the release model (stitchjax.pretrained())")
    parser.add_argument("--windows", choices=("train", "test"), default="train")
    parser.add_argument("--takes", default=",".join(TRAIN_TAKES),
                        help="with --windows train: the training takes (comma-separated names, no .bvh)")
    parser.add_argument("--count", type=int, default=0, help="evenly spaced windows (0: all)")
    parser.add_argument("--lengths", default="10,15,30,45,50")
    parser.add_argument("--samples", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--chunk", type=int, default=128, help="windows per sampling call")
    parser.add_argument("--config", default="{}", help="FootLockConfig fields as JSON (default: the defaults)")
    parser.add_argument("--json", required=True)
    args = parser.parse_args(argv)
    started = time.time()
    if args.windows == "train":
        takes = args.takes.split(",")
        if any(t.endswith("subject5") for t in takes):
            parser.error("--takes: subject5 is the test set")
        windows = lafan1.build_windows([os.path.join(args.data, f"{t}.bvh") for t in takes], 65, 40, workers=1)
    else:
        windows = lafan1.test_windows(args.data)
    if 0 < args.count < len(windows.rotations):
        windows = windows[np.linspace(0, len(windows.rotations) - 1, args.count).round().astype(int)]
    config = footlock.FootLockConfig(**json.loads(args.config))
    model = trained_model.load_model(args.checkpoint) if args.checkpoint else trained_model.pretrained()
    parents = tuple(windows.skeleton.parents)
    rot, pos, con = (np.asarray(x, np.float64) for x in (windows.rotations, windows.positions, windows.contacts))
    gt_q_all, gt_p_all = forward_kinematics(rot, pos, parents)
    ground = metrics.ground_heights(gt_p_all, FEET)
    offsets = np.asarray(windows.skeleton.offsets)
    result = {"windows": args.windows, "n_windows": int(len(rot)), "samples": args.samples,
              "config": dataclasses.asdict(config), "lengths": {},
              "ground_truth": {"max_joint_jump_cm": float(np.linalg.norm(np.diff(gt_p_all, axis=1), axis=-1).max()),
                               "max_knee_change_deg_per_frame": float(np.abs(np.diff(knee_angles(gt_p_all),
                                                                                     axis=1)).max())}}
    start = 9
    for length in (int(x) for x in args.lengths.split(",")):
        target = start + length + 1
        captured = []
        real_locked = inbetween._locked

        def capture(model_, rotations, positions, contacts, config_, counts):
            captured.append(contacts)
            return rotations

        inbetween._locked = capture
        t0 = time.perf_counter()
        parts = []
        for i in range(0, len(rot), args.chunk):
            c = slice(i, i + args.chunk)
            parts.append(inbetween.transitions_in_frame(
                model, rot[c, start], pos[c, start], con[c, start], rot[c, target], pos[c, target],
                con[c, target], length, args.samples, seed=args.seed * 1000 + length + i, foot_lock=True)[:2])
        sampling_s = time.perf_counter() - t0
        inbetween._locked = real_locked
        r = np.concatenate([p[0] for p in parts])
        p = np.concatenate([p[1] for p in parts])
        contacts = np.concatenate(captured)
        skeleton = windows.skeleton
        footlock.lock_transitions(r[:1], p[:1], contacts[:1], skeleton, FEET, config, sample_axis=1)  # compile small
        footlock.lock_transitions(r, p, contacts, skeleton, FEET, config, sample_axis=1)  # compile this shape
        t0 = time.perf_counter()
        locked, _, stats = footlock.lock_transitions(r, p, contacts, skeleton, FEET, config, sample_axis=1)
        lock_s = time.perf_counter() - t0
        gt_q, gt_p = gt_q_all[:, start + 1:target], gt_p_all[:, start + 1:target]
        entry = {"model": scores(r, p, gt_q, gt_p, ground, offsets, parents),
                 "model+footlock": scores(locked, p, gt_q, gt_p, ground, offsets, parents)}
        inner = {k: v[:, :, 1:-1] for k, v in stats.items()}
        entry["model+footlock"].update(
            planted_share=float(inner["planted"].mean()), let_go_share=float(inner["let_go"].mean()),
            changed_share=float(inner["changed"].mean()), lifted_share=float(inner["lifted"].mean()))
        entry["ground_truth"] = {"foot_slide": float(np.divide(*[x.sum() for x in metrics.foot_slide_parts(
            gt_p_all[:, start + 1:target + 1], ground, FEET)]))}
        entry["time_s"] = {"sampling": sampling_s, "foot_lock": lock_s, "transitions": int(r.shape[0] * r.shape[1])}
        result["lengths"][str(length)] = entry
        a, b = entry["model"], entry["model+footlock"]
        print(f"L={length}: " + ", ".join(f"{k} {a[k]:.4g} -> {b[k]:.4g}" for k in a)
              + f", let go {b['let_go_share']:.3%}, planted {b['planted_share']:.1%}, "
                f"lifted {b['lifted_share']:.1%}, "
                f"sampling {sampling_s:.1f} s, pass {lock_s:.2f} s", flush=True)
    result["command"] = "python " + " ".join(sys.argv)
    result["commit"] = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                      text=True).stdout.strip()
    result["machine"] = f"{cpu_name()}, {os.cpu_count()} CPUs"
    result["wall_s"] = time.time() - started
    with open(args.json, "w") as f:
        json.dump(result, f, indent=1)
    print(f"({result['wall_s']:.0f} s) -> {args.json}")


if __name__ == "__main__":
    main()
