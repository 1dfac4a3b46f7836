"""Choose the release model's default sampling on the validation split.

    python experiments/2026-12-07_release_64k/choose_sampling.py GRID.json ... --out sampling_choice.json

Each GRID.json is a `bin/evaluate model --split validation --noise-correlation RHO --noise-ramp K
--noise-scales S1,S2,...` output. Every model row (noise x1 and each scale) of every file is a candidate
(scale, RHO, K). A candidate is admissible when it is below interpolation on ADE, NPSS and foot slide at every
length of the files (L = 30 and 50) by a margin: each ratio at most --margin (default 0.95, fixed before any
grid was read beyond the first two settings: the validation split is three takes, and a default must hold on
other motion); the choice is the admissible candidate whose samples are furthest apart at
mid-transition at the longest length (mean per-joint distance, cm). When no candidate is admissible (the model
itself slides its feet more than interpolation), the rule falls back to: ADE and NPSS within the margin,
and foot slide no higher than at the paper's sampling (scale 1, RHO 0, K 0) at every length; the output says
which rule chose. Prints the table and the choice.
"""
import argparse
import json
import pathlib

CRITERIA = ("ade", "npss", "foot_slide")


def candidates(path: pathlib.Path):
    """(scale, rho, ramp, {L: model row}, {L: interp row}) for every model row of one evaluation."""
    results = json.loads(path.read_text())
    settings = results["sampling"]
    lengths = sorted(results["lengths"], key=int)
    rows = [name for name in results["lengths"][lengths[0]] if name.startswith("model")]
    for name in rows:
        scale = 1.0 if name == "model" else float(name[len("model_noise"):])
        yield (scale, settings["noise_correlation"], settings["noise_ramp_steps"],
               {n: results["lengths"][n][name] for n in lengths}, {n: results["lengths"][n]["interp"] for n in lengths})


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("grids", nargs="+", help="bin/evaluate --split validation JSON files (with a 'sampling' key "
                                                 "added: {noise_correlation, noise_ramp_steps})")
    parser.add_argument("--out", required=True)
    parser.add_argument("--margin", type=float, default=0.95, help="largest admissible ratio to interpolation")
    args = parser.parse_args()
    table = []
    for path in args.grids:
        for scale, rho, ramp, model, interp in candidates(pathlib.Path(path)):
            ratios = {f"{m}_L{n}": model[n][m] / interp[n][m] for n in model for m in CRITERIA}
            table.append({"noise_scale": scale, "noise_correlation": rho, "noise_ramp_steps": ramp, **ratios,
                          "spread_mid_cm": {n: model[n]["spread_mid"] for n in model},
                          "admissible": all(r <= args.margin for r in ratios.values()),
                          "source": pathlib.Path(path).name})
    longest = max(table[0]["spread_mid_cm"], key=int)
    rule = f"ADE, NPSS and foot slide at most {args.margin:g} x interpolation's at every length"
    if not any(row["admissible"] for row in table):
        paper = next(r for r in table if (r["noise_scale"], r["noise_correlation"], r["noise_ramp_steps"]) == (1.0, 0.0, 0))
        rule = (f"no candidate has foot slide at most {args.margin:g} x interpolation's; fallback: ADE and NPSS at "
                f"most {args.margin:g} x interpolation's, foot slide no higher than at the paper's sampling, at every "
                "length")
        for row in table:
            row["admissible"] = all(row[k] <= args.margin for k in row if k.startswith(("ade_L", "npss_L"))) and all(
                row[k] <= paper[k] for k in row if k.startswith("foot_slide_L"))
    admissible = [row for row in table if row["admissible"]]
    best = max(admissible, key=lambda row: row["spread_mid_cm"][longest]) if admissible else None
    print(f"{'scale':>5} {'rho':>5} {'ramp':>4}  " + "  ".join(f"{k:>13}" for k in table[0] if "_L" in k)
          + "  spread mid (cm)  ok")
    for row in table:
        print(f"{row['noise_scale']:5g} {row['noise_correlation']:5g} {row['noise_ramp_steps']:4d}  "
              + "  ".join(f"{row[k]:13.3f}" for k in row if "_L" in k)
              + "  " + " / ".join(f"{v:.1f}" for v in row["spread_mid_cm"].values()) + f"  {row['admissible']}")
    print("chosen:", None if best is None else {k: best[k] for k in ("noise_scale", "noise_correlation",
                                                                      "noise_ramp_steps", "spread_mid_cm")})
    print("rule:", rule)
    pathlib.Path(args.out).write_text(json.dumps({"rule": f"admissible: {rule}; chosen: the widest spread at "
                                                          "mid-transition at the longest length",
                                                  "chosen": best, "candidates": table}, indent=1) + "\n")


if __name__ == "__main__":
    main()
