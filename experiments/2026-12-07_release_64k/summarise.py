"""The release run's validation curve and an evaluation's ratios to interpolation, as JSON.

    python experiments/2026-12-07_release_64k/summarise.py --metrics runs/release_64k/metrics.jsonl \
        --evaluation experiments/2026-12-07_release_64k/validation_paper.json --out experiments/2026-12-07_release_64k/summary_validation.json

Curve: every validation record of metrics.jsonl (train.eval_every), each metric beside interpolation's on the
same validation windows, and the first step (and training wall time) at which the model is below interpolation
on ADE and NPSS at every validated length. Ratios: model / interp of ADE, NPSS, foot slide and SLDE per length
of a bin/evaluate JSON, with the mid-transition spread (cm, interpolation's is 0).
"""
import argparse
import json
import pathlib


def curve(metrics_path):
    rows = [json.loads(line) for line in pathlib.Path(metrics_path).read_text().splitlines() if '"val_ade_' in line]
    lengths = sorted({int(k.split("_L")[1]) for r in rows for k in r if k.startswith("val_ade_L") and
                      not k.endswith("_interp")})
    points, first = [], None
    for r in rows:
        point = {"step": r["step"], "time_s": r["time_s"]}
        below = True
        for n in lengths:
            for m in ("ade", "npss", "foot_slide", "slde"):
                model, interp = r[f"val_{m}_L{n}"], r[f"val_{m}_L{n}_interp"]
                point[f"{m}_L{n}_ratio"] = model / interp
            below = below and all(point[f"{m}_L{n}_ratio"] < 1 for m in ("ade", "npss"))
        point["below_interp_ade_npss"] = below
        points.append(point)
        if below and first is None:
            first = {"step": r["step"], "time_s": r["time_s"]}
    return {"lengths": lengths, "points": points, "first_below_interpolation_on_ade_and_npss": first}


def ratios(evaluation_path):
    results = json.loads(pathlib.Path(evaluation_path).read_text())
    out = {}
    for n, entry in results["lengths"].items():
        model, interp = entry["model"], entry["interp"]
        out[n] = {f"{m}_ratio": model[m] / interp[m] for m in ("ade", "npss", "foot_slide", "slde")}
        out[n]["spread_mid_cm"] = model["spread_mid"]
        out[n]["apd_m"] = model["apd"]
    return {"n_windows": results["n_windows"], "samples": results["samples"], "split": results.get("split"),
            "lengths": out}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--metrics", required=True, help="the run's metrics.jsonl")
    parser.add_argument("--evaluation", help="a bin/evaluate --json output")
    parser.add_argument("--out", required=True, help="summary JSON to write")
    args = parser.parse_args()
    summary = {"curve": curve(args.metrics)}
    if args.evaluation:
        summary["evaluation"] = ratios(args.evaluation)
    pathlib.Path(args.out).write_text(json.dumps(summary, indent=2) + "\n")
    print(json.dumps(summary.get("evaluation", summary["curve"]["first_below_interpolation_on_ade_and_npss"]),
                     indent=1))


if __name__ == "__main__":
    main()
