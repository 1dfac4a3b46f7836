"""Foot locking version 5: the settings chosen on the validation split, by the rule fixed before the grid ran.

    python experiments/2026-12-06_footlock_v6/choose_v5.py --validation validation_grid.json --json choice.json

Rule: among the candidates of ``candidates.json`` (scored by ``tune.py`` on the 376 validation windows at
L = 10, 15, 30 and 50), keep those that
  1. change ADE, SLDE, NPSS and APD by at most +2 % against the model alone, at every one of those lengths
     (version 4's rule looked at L = 30 and 50 only, and its choice cost SLDE +4.9 % at L = 10);
  2. make no per-frame joint jump more than 5 % larger than the model alone's largest on the same windows;
  3. keep the package's synthetic stand-swing-stand transition within 15 % of its generated largest joint
     jump (version 4's ``swing_ratio``);
  4. (added after the first choice, before any test window was read: that choice made a 51.8 cm knee jump at
     the release model's default sampling, where the model alone's largest is 33.6 cm) make no joint jump
     more than 5 % larger than the model alone's on the same validation windows at the release model's
     default sampling (noise x2, correlation 0.95, ramp 4; ``--default-cache``), checked in order of slide
     until one passes;
then take the one with the lowest foot slide averaged over L = 30 and 50, the lengths of the slide target.
"""
import argparse
import importlib.util
import json
import os
import sys

import jax
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
_spec = importlib.util.spec_from_file_location("choose_v4", os.path.join(HERE, "choose_v4.py"))
v4 = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(v4)

COST_PCT, JUMP_RATIO, SWING_RATIO = v4.COST_PCT, v4.JUMP_RATIO, v4.SWING_RATIO
SLIDE_LENGTHS = ("30", "50")
DEFAULT_SAMPLING = {"noise_scale": 2.0, "noise_correlation": 0.95, "noise_ramp_steps": 4}
# The package's defaults of these fields when the version 5 and 6 grids ran (version 6 changed them): the grids
# recorded each candidate's fields relative to them, so they are put back under the recorded fields.
GRID_DEFAULTS = {"correction_step": 1.0, "jump_guard": 0, "jump_floor": 20.0}


def default_sampling_jumps(fields: dict, cache_path: str, data: str, lengths) -> dict:
    """{length: (the model alone's, the pass's) largest joint jump (cm)} on the validation windows at the
    release model's default sampling; the transitions are sampled once into ``cache_path``."""
    windows = v4.lafan1.build_windows([os.path.join(data, f"{t}.bvh") for t in v4.tune.VALIDATION], 65, 40,
                                      workers=1)
    parents = tuple(windows.skeleton.parents)
    if os.path.exists(cache_path):
        cache = dict(np.load(cache_path))
    else:
        rot, pos, con = (np.asarray(x, np.float64) for x in (windows.rotations, windows.positions, windows.contacts))
        model, cache = v4.tune.trained_model.pretrained(), {}
        for length in lengths:
            r, p, c = v4.tune.sample(model, rot, pos, con, int(length), 10, sampling=DEFAULT_SAMPLING)
            cache.update({f"r{length}": r, f"p{length}": p, f"c{length}": c})
        np.savez(cache_path, **cache)
    jump = lambda q, p: float(np.linalg.norm(np.diff(v4.forward_kinematics(q, p, parents)[1], axis=2),  # noqa: E731
                                             axis=-1).max())
    out = {}
    for length in lengths:
        r, p, c = cache[f"r{length}"], cache[f"p{length}"], cache[f"c{length}"]
        locked, _, _ = v4.footlock.lock_transitions(r, p, c, windows.skeleton, v4.tune.measure.FEET,
                                                    v4.footlock.FootLockConfig(**fields), sample_axis=1)
        out[str(length)] = (jump(r, p), jump(locked, p))
        jax.clear_caches()
    return out


def candidate_rows(grid: dict, lengths, fields_of, swing_ratio) -> dict:
    """{name: row} of every candidate of tune.py's ``grid`` over ``lengths``: its slide, its worst cost per
    length, its largest joint jump, its swing ratio (``swing_ratio(fields)``) and "kept" by rules 1-3;
    ``fields_of(name, per-length entries)`` gives the candidate's fields (``GRID_DEFAULTS`` fill the rest)."""
    model_jump = max(grid["lengths"][L]["model"]["max_joint_jump_cm"] for L in lengths)
    rows = {}
    for name in grid["lengths"][lengths[0]]:
        if name == "model":
            continue
        per = {L: grid["lengths"][L][name] for L in lengths}
        costs = {L: max(p[f"{k}_change_pct"] for k in ("ade", "slde", "npss", "apd")) for L, p in per.items()}
        jump = max(p["max_joint_jump_cm"] for p in per.values())
        fields = {**GRID_DEFAULTS, **fields_of(name, per)}
        ratio = swing_ratio(fields)
        worst = max(costs.values())
        rows[name] = {"slide": float(np.mean([per[L]["foot_slide"] for L in SLIDE_LENGTHS])),
                      "slide_by_length": {L: p["foot_slide"] for L, p in per.items()},
                      "worst_cost_pct_by_length": costs, "worst_cost_pct": worst, "max_joint_jump_cm": jump,
                      "swing_jump_ratio": ratio,
                      "kept": worst <= COST_PCT and jump <= JUMP_RATIO * model_jump and ratio <= SWING_RATIO,
                      "fields": fields}
    return rows


def first_at_default_sampling(rows: dict, cache_path: str, data: str, lengths):
    """Rule 4: the kept rows in order of slide, each checked at the default sampling until one passes (its
    name, or None); every row checked records its jumps and whether it is still kept."""
    for name in sorted((k for k, v in rows.items() if v["kept"]), key=lambda k: rows[k]["slide"]):
        jumps = default_sampling_jumps(rows[name]["fields"], cache_path, data, lengths)
        ok = all(after <= JUMP_RATIO * before for before, after in jumps.values())
        rows[name].update({"default_sampling_jump_cm": jumps, "kept": ok})
        print(f"{name}: default sampling, largest joint jump (model, pass) by L: {jumps} -> {'kept' if ok else '-'}")
        if ok:
            return name
    return None


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--validation", required=True, help="tune.py's JSON over candidates.json")
    parser.add_argument("--default-cache", required=True, help="the validation transitions at the default sampling "
                        "(.npz; sampled and written there when missing)")
    parser.add_argument("--data", default="../shared/data/lafan1")
    parser.add_argument("--candidates", default=None, help="the candidates' complete fields (JSON), where the grid "
                        "recorded them relative to the defaults of its day (the first grid)")
    parser.add_argument("--json", required=True)
    args = parser.parse_args()
    grid = json.load(open(args.validation))
    complete = json.load(open(args.candidates)) if args.candidates else {}
    lengths = sorted(grid["lengths"], key=int)
    model_jump = max(grid["lengths"][L]["model"]["max_joint_jump_cm"] for L in lengths)
    rows = candidate_rows(grid, lengths, lambda name, per: complete.get(name, per[lengths[0]]["fields"]),
                          v4.swing_ratio)
    choice = first_at_default_sampling(rows, args.default_cache, args.data, lengths)
    for name, row in sorted(rows.items(), key=lambda kv: kv[1]["slide"]):
        costs = " ".join(f"{c:+.1f}" for c in row["worst_cost_pct_by_length"].values())
        print(f"{name:>24}: slide {row['slide']:.3f}  worst cost by L {costs} %  jump "
              f"{row['max_joint_jump_cm']:.1f} cm  swing x{row['swing_jump_ratio']:.3f}  "
              f"{'kept' if row['kept'] else '-'}{'  <- chosen' if name == choice else ''}")
    print(f"model alone's largest joint jump: {model_jump:.1f} cm; chosen: {choice}")
    json.dump({"rule": __doc__.split("Rule:")[1].strip(), "lengths": lengths, "model_max_joint_jump_cm": model_jump,
               "choice": choice, "rows": rows, "command": "python " + " ".join(sys.argv)},
              open(args.json, "w"), indent=1)


if __name__ == "__main__":
    main()
