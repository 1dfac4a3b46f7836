"""Table 4 (ablations) and Table 3 (Human3.6M) at CPU scale from the study's evaluation JSONs, beside the paper's.

    python experiments/paper_ablations/tables.py table4 --out experiments/paper_ablations/table4
    python experiments/paper_ablations/tables.py table3 --out experiments/paper_ablations/table3

Reads eval/<run>_<split>.json (bin/evaluate model --direction-ends; --eval names another folder), writes OUT.md
and OUT.json. A run not evaluated yet is listed as missing. The verdict rules are fixed here, before any
run is trained (README.md of this folder states them).
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import runs as runs_lib  # noqa: E402  (this folder's run list)

# (key, label, where it is read, True when lower is better)
METRICS = (
    ("apd", "APD (m)", "protocol", False),
    ("ade", "ADE (m)", "protocol", True),
    ("slde", "SLDE (m)", "protocol", True),
    ("npss", "NPSS", "protocol", True),
    ("foot_slide", "foot slide (cm/frame)", "protocol", True),
    ("spread_mid", "spread mid (cm)", "protocol", False),
    ("target_step", "target step (m)", "ends", True),
    ("forward_end_gap", "fwd end gap (m)", "ends", True),
    ("backward_end_gap", "bwd end gap (m)", "ends", True),
    ("seam_gap", "seam gap (m)", "ends", True),
)
PAPER_KEYS = ("apd", "ade", "slde", "npss", "foot_slide")
# The paper's Table 4 (L = 50, LAFAN1 test set); APD in the paper's unstated units.
PAPER_TABLE4 = {
    "base": (63.269, 0.123, 0.016, 0.311, 0.468),
    "no_bidirectional": (60.467, 0.190, 0.237, 0.419, 0.548),
    "no_stitch_loss": (63.476, 0.130, 0.018, 0.313, 0.517),
    "no_latent_interpolation": (71.260, 0.126, 0.017, 0.318, 0.493),
    "no_aligning": (62.443, 0.124, 0.018, 0.315, 0.541),
    "no_phase": (62.880, 0.128, 0.016, 0.325, 0.554),
}
# The paper's Table 3 (Human3.6M, L = 50): Slerp, RMIB, Ours; no units stated.
PAPER_TABLE3 = {"Slerp": (0.000, 1.552, 0.532, 0.356, 2.352), "RMIB": (36.069, 0.851, 0.904, 0.252, 1.550),
                "Ours": (63.751, 0.622, 0.291, 0.229, 1.309)}
SPLITS = ("validation", "test")
LENGTHS = ("50", "30")


def _load(path: pathlib.Path):
    return json.loads(path.read_text()) if path.is_file() else None


def run_figures(evaluation: dict, length: str) -> dict:
    """{metric: value or None} of the model row at one length, the direction ends included."""
    protocol = evaluation["lengths"][length]["model"]
    ends = (evaluation.get("direction_ends") or {}).get("lengths", {}).get(length, {}).get("model", {})
    return {key: (protocol.get(key) if where == "protocol" else ends.get(key)) for key, _, where, _ in METRICS}


def reference_figures(evaluation: dict, length: str) -> dict:
    """Interpolation's figures and the ground truth's foot slide and target step at one length."""
    entry = evaluation["lengths"][length]
    ends = (evaluation.get("direction_ends") or {}).get("lengths", {}).get(length, {})
    return {"interp": {key: entry["interp"].get(key) for key, _, where, _ in METRICS if where == "protocol"},
            "ground_truth": {"foot_slide": entry["ground_truth"]["foot_slide"],
                             "target_step": (ends.get("ground_truth") or {}).get("target_step")}}


def change(value, base):
    """Relative change (fraction) of value against base; None when either is missing or base is 0."""
    if value is None or base is None or base == 0:
        return None
    return value / base - 1.0


def verdict_of(value, base, band, lower_is_better: bool) -> str:
    """"worse", "better" or "within noise": the ablation's figure against the base's, where a difference no
    larger than the seed band (the two base seeds' difference) is noise; "n/a" when a figure is missing."""
    if value is None or base is None or band is None:
        return "n/a"
    difference = value - base
    if abs(difference) <= band:
        return "within noise"
    return "worse" if (difference > 0) == lower_is_better else "better"


def _combine(verdicts: list) -> str:
    """One conclusion from the checks it needs: confirmed when every one says so, within noise when every one is
    within noise, n/a when one is missing, not confirmed otherwise."""
    if any(v == "n/a" for v in verdicts):
        return "n/a"
    if all(v == "yes" for v in verdicts):
        return "confirmed"
    if all(v == "within noise" for v in verdicts):
        return "within noise"
    return "not confirmed"


def conclusions(rows: dict, band: dict) -> list:
    """The paper's three conclusions of section 5.3 (and Appendix D's claim), each checked on one split and
    length: [(claim, verdict, the checks it rests on)]. A check says "yes" when the ablation is worse than the
    base by more than the seed band in the direction the paper claims."""
    base = rows.get("base")
    lower = {key: lower_better for key, _, _, lower_better in METRICS}

    def check(run, key, claimed):  # claimed: "worse" (the ablation loses) or "better"
        figures = rows.get(run)
        if figures is None or base is None:
            return "n/a", f"{run}: not evaluated"
        v = verdict_of(figures[key], base[key], band.get(key), lower[key])
        return ("yes" if v == claimed else v), f"{run} {key} {v}"

    def claim(text, checks):
        results = [check(*c) for c in checks]
        return text, _combine([r[0] for r in results]), "; ".join(r[1] for r in results)

    return [
        claim("1. BS fixes the target frame (w/o BS: SLDE and the step into the target larger)",
              [("no_bidirectional", "slde", "worse"), ("no_bidirectional", "target_step", "worse")]),
        claim("2a. SL, BA and LI smooth the seam (each ablation: larger seam gap)",
              [("no_stitch_loss", "seam_gap", "worse"), ("no_aligning", "seam_gap", "worse"),
               ("no_latent_interpolation", "seam_gap", "worse")]),
        claim("2b. LI trades diversity for naturalness (w/o LI: larger APD, worse NPSS and foot slide)",
              [("no_latent_interpolation", "apd", "better"), ("no_latent_interpolation", "npss", "worse"),
               ("no_latent_interpolation", "foot_slide", "worse")]),
        claim("3. PM improves quality (w/o PM: worse ADE, NPSS and foot slide)",
              [("no_phase", "ade", "worse"), ("no_phase", "npss", "worse"), ("no_phase", "foot_slide", "worse")]),
        claim("App. D: the discriminators earn their place (w/o D: worse NPSS and foot slide)",
              [("no_discriminators", "npss", "worse"), ("no_discriminators", "foot_slide", "worse")]),
        claim("App. D: the LSTM earns its place (w/o LSTM: worse ADE and NPSS)",
              [("no_lstm", "ade", "worse"), ("no_lstm", "npss", "worse")]),
    ]


def _fmt(value, digits: int = 4) -> str:
    if value is None:
        return "–"
    return f"{value:.{digits}f}" if abs(value) < 100 else f"{value:.1f}"


def _pct(fraction) -> str:
    return "–" if fraction is None else f"{100 * fraction:+.1f} %"


def table4(out: pathlib.Path, folder: pathlib.Path) -> None:
    runs = runs_lib.lafan1_runs()
    seeds = [name for name, *_ in runs if name.startswith("base_seed")]
    lines = ["# Table 4 at CPU scale (generated by tables.py; do not edit)", ""]
    data = {"splits": {}}
    for split in SPLITS:
        for length in LENGTHS:
            rows, missing, reference = {}, [], None
            for name, *_ in runs:
                evaluation = _load(folder / f"{name}_{split}.json")
                if evaluation is None or length not in evaluation["lengths"]:
                    missing.append(name)
                    continue
                rows[name] = run_figures(evaluation, length)
                reference = reference or reference_figures(evaluation, length)
            base = rows.get("base")
            band = {}
            if base is not None and seeds and seeds[0] in rows:
                other = rows[seeds[0]]
                band = {key: (None if base[key] is None or other[key] is None else abs(other[key] - base[key]))
                        for key, *_ in METRICS}
            data["splits"].setdefault(split, {})[length] = {
                "rows": rows, "seed_band": band, "reference": reference, "missing": missing,
                "conclusions": [dict(zip(("claim", "verdict", "checks"), c)) for c in conclusions(rows, band)]}
            lines += _table4_section(split, length, runs, rows, band, reference, missing)
    lines += _paper_comparison(data)
    out.with_suffix(".json").write_text(json.dumps(data, indent=1) + "\n")
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print(f"wrote {out.with_suffix('.md')} and {out.with_suffix('.json')}")


def _table4_section(split, length, runs, rows, band, reference, missing) -> list:
    heads = [label for _, label, _, _ in METRICS]
    lines = [f"## {split}, L = {length}", "",
             "Each cell: the figure, then its change against the base (seed 0). Seed band: the two base seeds' "
             "difference, absolute (and relative to the base).", "",
             "| run | " + " | ".join(heads) + " |", "|---" * (len(heads) + 1) + "|"]
    base = rows.get("base")
    for name, label, *_ in runs:
        if name not in rows:
            continue
        cells = []
        for key, *_ in METRICS:
            value = rows[name][key]
            cells.append(_fmt(value) if name == "base" else f"{_fmt(value)} ({_pct(change(value, base and base[key]))})")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    if band:
        lines.append("| seed band | " + " | ".join(
            f"{_fmt(band[key])} ({_pct(None if band[key] is None or not base[key] else band[key] / base[key])})"
            for key, *_ in METRICS) + " |")
    if reference:
        interp, truth = reference["interp"], reference["ground_truth"]
        lines.append("| interpolation | " + " | ".join(_fmt(interp.get(key)) for key, *_ in METRICS) + " |")
        lines.append("| ground truth | " + " | ".join(_fmt(truth.get(key)) for key, *_ in METRICS) + " |")
    if missing:
        lines += ["", f"Not evaluated yet: {', '.join(missing)}."]
    lines += ["", "| the paper's claim | verdict | checks |", "|---|---|---|"]
    lines += [f"| {claim} | {verdict} | {checks} |" for claim, verdict, checks in conclusions(rows, band)]
    return lines + [""]


def _paper_comparison(data: dict) -> list:
    """Each ablation's change against the base, ours (test, L = 50) beside the paper's Table 4."""
    entry = data["splits"].get("test", {}).get("50", {})
    rows, band = entry.get("rows", {}), entry.get("seed_band", {})
    lines = ["## Beside the paper's Table 4 (test set, L = 50)", "",
             "Change against the base: ours / the paper's. The paper's APD has no stated units; the relative "
             "change is comparable, the values are not.", "",
             "| run | " + " | ".join(f"{k}: ours / paper" for k in PAPER_KEYS) + " |",
             "|---" * (len(PAPER_KEYS) + 1) + "|"]
    base = rows.get("base")
    for name, label, *_ in runs_lib.lafan1_runs():
        if name not in PAPER_TABLE4 or name == "base":
            continue
        paper = dict(zip(PAPER_KEYS, PAPER_TABLE4[name]))
        paper_base = dict(zip(PAPER_KEYS, PAPER_TABLE4["base"]))
        ours = rows.get(name)
        cells = [f"{_pct(change(ours and ours[k], base and base[k]))} / {_pct(change(paper[k], paper_base[k]))}"
                 for k in PAPER_KEYS]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    if band and base:
        lines.append("| seed band (ours) | " + " | ".join(
            _pct(None if band.get(k) is None or not base[k] else band[k] / base[k]) for k in PAPER_KEYS) + " |")
    lines += ["", "The paper's rows (L = 50): " + "; ".join(
        f"{name}: " + ", ".join(f"{k} {v}" for k, v in zip(PAPER_KEYS, values)) for name, values in PAPER_TABLE4.items())
        + ". Appendix D's figures (w/o D, w/o LSTM) are not in the paper's text available here.", ""]
    return lines


def table3(out: pathlib.Path, folder: pathlib.Path) -> None:
    evaluation = _load(folder / "h36m_test.json")
    lines = ["# Table 3 at CPU scale: Human3.6M, L = 50 (generated by tables.py; do not edit)", ""]
    data = {}
    if evaluation is None:
        lines.append("Not evaluated yet (eval/h36m_test.json is missing).")
    else:
        entry = evaluation["lengths"]["50"]
        units = evaluation["units"]
        keys = PAPER_KEYS
        lines += [f"{evaluation['n_windows']} windows of S9 and S11 (65 frames every 40 at 25 Hz), "
                  f"{evaluation['samples']} samples each. Ratio: the figure over interpolation's (Slerp).", "",
                  "| method | " + " | ".join(f"{k} ({units[k]})" for k in keys) + " |", "|---" * (len(keys) + 1) + "|"]
        for name, label in (("model", "Ours (h36m_cpu)"), ("interp", "Slerp (interpolation)"),
                            ("zerov", "zero velocity")):
            row = entry[name]
            cells = [f"{_fmt(row[k])} ({row[k] / entry['interp'][k]:.3f})" if entry["interp"][k] else _fmt(row[k])
                     for k in keys]
            lines.append(f"| {label} | " + " | ".join(cells) + " |")
            data[name] = {k: row[k] for k in keys}
        slerp = dict(zip(keys, PAPER_TABLE3["Slerp"]))
        for name, values in PAPER_TABLE3.items():
            cells = [f"{v} ({v / slerp[k]:.3f})" if slerp[k] else f"{v}" for k, v in zip(keys, values)]
            lines.append(f"| paper: {name} | " + " | ".join(cells) + " |")
        below = {k: entry["model"][k] < entry["interp"][k] for k in ("ade", "npss")}
        lines += ["", "Ours below Slerp: " + ", ".join(f"{k.upper()} {'yes' if v else 'no'}" for k, v in below.items())
                  + " (the issue's check; the paper: yes on both)."]
        data["below_slerp"] = below
        data["ground_truth_foot_slide"] = entry["ground_truth"]["foot_slide"]
    out.with_suffix(".json").write_text(json.dumps(data, indent=1) + "\n")
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print(f"wrote {out.with_suffix('.md')} and {out.with_suffix('.json')}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("table", choices=("table4", "table3"))
    parser.add_argument("--out", required=True, help="output path without suffix (.md and .json are written)")
    parser.add_argument("--eval", default=str(HERE / "eval"), help="the folder of the evaluation JSONs")
    args = parser.parse_args()
    (table4 if args.table == "table4" else table3)(pathlib.Path(args.out), pathlib.Path(args.eval))


if __name__ == "__main__":
    main()
