"""Foot locking version 6: the settings chosen on non-test windows, by the rule fixed before the grid ran.

    python experiments/2026-12-06_footlock_v6/choose.py --validation validation_grid.json \
        --default-cache /tmp/val_default.npz --artefacts artefact_jumps.json --json choice.json

Rule: version 5's rule (``choose_v5.py``: on the 376 validation windows at
L = 10, 15, 30 and 50, every cost within +2 %, no joint jump more than 5 % above the model alone's, the
synthetic swing within 15 %, and at the release model's default sampling no joint jump more than 5 % above
the model alone's), and
  5. on the artefact set of ``jumps.py`` (the test takes' three motions by training subjects, L = 30 and 50,
     the paper's and the default sampling), no joint jump more than 5 % above the model alone's largest at the
     same sampling and length (version 5 passed rules 2 and 4 on the validation windows, then made a 43.6 cm
     jump on one test transition against the model alone's 36.5 cm: the validation windows were too few);
  6. (added after a probe of the jump guard on the artefact set, before the grid and before any test window
     was read: the guard kept the jumps but turned knees by up to 44 degrees in a frame, where the model
     alone's largest is 23.7; the guard's cut was then made gradual, ``foot_speed.slope_limited``) no
     knee-angle change per frame more than 6 degrees (the knee limit's ``knee_step``) above the model alone's
     largest, on the validation windows over the four lengths and on the artefact set at each sampling and
     length;
then take the one with the lowest foot slide averaged over L = 30 and 50, the lengths of the slide target.

Amended after the first choice (``guard8_cs3_floor15``), before any test figure was read: rule 3's ratio is
the largest over the synthetic swing at 0.98, 1 and 1.02 times its speed (``swing_ratio``). The first choice
passed with 1.127 on a knife edge: its largest step was 15.0 cm, exactly the guard's ``jump_floor``, and
whether the guard cut it (1.127) or not (1.25) depended on the last bit of a float (the test suite's XLA
flags gave 1.25). Candidates with a lower ``jump_floor`` were added (``candidates_second.json``).
"""
import argparse
import importlib.util
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
_spec = importlib.util.spec_from_file_location("choose_v5", os.path.join(HERE, "choose_v5.py"))
v5 = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(v5)
KNEE_DEGREES = 6.0  # FootLockConfig.knee_step


SWING_SCALES = (0.98, 1.0, 1.02)


def swing_ratio(fields: dict) -> float:
    """Rule 3's ratio: version 4's ``swing_ratio`` (the locked synthetic stand-swing-stand transition's largest
    joint jump over the generated one's), the largest over the swing at ``SWING_SCALES`` times its speed."""
    return max(v5.v4.swing_ratio(fields, scale) for scale in SWING_SCALES)


def merged(paths, key: str) -> dict:
    """The ``key`` entries of several JSON files of one kind (tune.py's "lengths", jumps.py's "rows"), merged."""
    out = {}
    for path in paths:
        for name, value in json.load(open(path))[key].items():
            if isinstance(value, dict) and isinstance(out.get(name), dict):
                out[name] = {**out[name], **value}
            else:
                out[name] = value
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--validation", required=True, nargs="+", help="tune.py's JSONs over the candidates")
    parser.add_argument("--default-cache", required=True, help="the validation transitions at the default sampling "
                        "(.npz; sampled and written there when missing)")
    parser.add_argument("--artefacts", required=True, nargs="+", help="jumps.py's JSONs over the candidates")
    parser.add_argument("--data", default="../shared/data/lafan1")
    parser.add_argument("--json", required=True)
    args = parser.parse_args()
    grid = {"lengths": merged(args.validation, "lengths")}
    artefacts = merged(args.artefacts, "rows")
    lengths = sorted(grid["lengths"], key=int)
    model_jump = max(grid["lengths"][L]["model"]["max_joint_jump_cm"] for L in lengths)
    model_knee = max(grid["lengths"][L]["model"]["max_knee_change_deg_per_frame"] for L in lengths)
    rows = v5.candidate_rows(grid, lengths, lambda name, per: per[lengths[0]]["fields"], swing_ratio)
    for name, row in rows.items():  # rules 5 and 6
        per = {L: grid["lengths"][L][name] for L in lengths}
        artefact_ok = all(artefacts[name][key][0] <= v5.JUMP_RATIO * artefacts["model"][key][0]
                          for key in artefacts["model"])
        knee = max(p["max_knee_change_deg_per_frame"] for p in per.values())
        knee_ok = knee <= model_knee + KNEE_DEGREES and all(
            artefacts[name][key][1] <= artefacts["model"][key][1] + KNEE_DEGREES for key in artefacts["model"])
        row.update({"max_knee_change_deg": knee, "knee_ok": knee_ok, "artefact_jumps_cm": artefacts[name],
                    "artefact_ok": artefact_ok, "kept": row["kept"] and artefact_ok and knee_ok})
    choice = v5.first_at_default_sampling(rows, args.default_cache, args.data, lengths)
    for name, row in sorted(rows.items(), key=lambda kv: kv[1]["slide"]):
        costs = " ".join(f"{c:+.1f}" for c in row["worst_cost_pct_by_length"].values())
        art = max(v[0] for v in row["artefact_jumps_cm"].values())
        print(f"{name:>22}: slide {row['slide']:.3f}  worst cost by L {costs} %  jump {row['max_joint_jump_cm']:.1f} "
              f"cm  artefact-set jump {art:.1f} cm  knee {row['max_knee_change_deg']:.1f}  swing "
              f"x{row['swing_jump_ratio']:.3f}  {'kept' if row['kept'] else '-'}"
              f"{'  <- chosen' if name == choice else ''}")
    art_model = {key: v[0] for key, v in artefacts["model"].items()}
    print(f"model alone's largest joint jump: validation {model_jump:.1f} cm, artefact set {art_model}; chosen: {choice}")
    json.dump({"rule": __doc__.split("Rule:")[1].strip(), "lengths": lengths, "model_max_joint_jump_cm": model_jump,
               "model_max_knee_change_deg": model_knee,
               "model_artefact_jumps_cm": artefacts["model"], "choice": choice, "rows": rows,
               "command": "python " + " ".join(sys.argv)}, open(args.json, "w"), indent=1)


if __name__ == "__main__":
    main()
