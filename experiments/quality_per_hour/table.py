#!/usr/bin/env python3
"""The levers' validation table: ratios to interpolation on the whole validation split at the paper's sampling.

    python experiments/quality_per_hour/table.py [--json OUT]

Reads validation/*.json here (bin/evaluate --json) and the release model's own
(experiments/2026-12-07_release_64k/validation_paper.json), prints one row per run: ADE, NPSS, SLDE, foot slide
and ground penetration over interpolation's at L = 30 and 50, and "quality", the mean of the four ADE and NPSS
ratios; the replacement rule's three conditions (RULE.md) are checked against the release model's figures.
"""
from __future__ import annotations

import argparse
import json
import pathlib

HERE = pathlib.Path(__file__).resolve().parent
RELEASE = HERE.parent / "2026-12-07_release_64k" / "validation_paper.json"
METRICS = ("ade", "npss", "slde", "foot_slide", "penetration")
LENGTHS = ("30", "50")


def ratios(path: pathlib.Path) -> dict:
    data = json.loads(path.read_text())
    row = {}
    for length in LENGTHS:
        entry = data["lengths"][length]
        for metric in METRICS:
            row[f"{metric}_L{length}"] = entry["model"][metric] / entry["interp"][metric]
    row["quality"] = sum(row[f"{m}_L{n}"] for m in ("ade", "npss") for n in LENGTHS) / 4
    return row


def rule(row: dict, release: dict) -> dict:
    """RULE.md: quality at most the release model's; foot slide at most its ratio at each length; penetration at
    most interpolation's at each length."""
    return {"quality": row["quality"] <= release["quality"],
            "foot_slide": all(row[f"foot_slide_L{n}"] <= release[f"foot_slide_L{n}"] for n in LENGTHS),
            "penetration": all(row[f"penetration_L{n}"] <= 1.0 for n in LENGTHS)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=pathlib.Path)
    args = parser.parse_args()
    release = ratios(RELEASE)
    rows = {"release_64k": release}
    rows.update({p.stem: ratios(p) for p in sorted((HERE / "validation").glob("*.json"))})
    keys = ["quality"] + [f"{m}_L{n}" for m in METRICS for n in LENGTHS]
    print("| run | " + " | ".join(keys) + " | rule |")
    print("|---" * (len(keys) + 2) + "|")
    out = {}
    for name, row in rows.items():
        passed = rule(row, release)
        out[name] = {**row, "rule": passed}
        verdict = "-" if name == "release_64k" else ("passes" if all(passed.values()) else
                                                     "fails: " + ", ".join(k for k, v in passed.items() if not v))
        print(f"| {name} | " + " | ".join(f"{row[k]:.3f}" for k in keys) + f" | {verdict} |")
    if args.json:
        args.json.write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
