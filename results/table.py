#!/usr/bin/env python3
"""Markdown tables of `bin/evaluate model --json` results, for results/README.md and the README.

    python results/table.py posterior=results/lafan1_cpu/posterior.json none=results/lafan1_cpu/none.json

Each argument is LABEL=FILE; the model rows of every file (method "model", and "model_noise<s>" with the
noise scale) are shown under their label, the baselines and the ground truth's foot slide once (from the
first file). Units: APD, ADE, SLDE in m; spread in cm per joint and frame; foot slide in cm/frame.
"""
from __future__ import annotations

import json
import pathlib
import sys

COLUMNS = (("apd", "APD (m)", 3), ("spread", "spread (cm)", 1), ("spread_mid", "mid spread (cm)", 1),
           ("ade", "ADE (m)", 4), ("ade_best", "best ADE (m)", 4), ("slde", "SLDE (m)", 4),
           ("npss", "NPSS", 4), ("foot_slide", "foot slide (cm/f)", 2))
BASELINES = (("interp", "interpolation"), ("zerov", "zero velocity"))


def rows(label: str, results: dict, with_baselines: bool) -> dict:
    """{L: [(row name, setting, {metric: value})]} for one results file."""
    out = {}
    settings = results.get("settings", {})
    for length, entry in results["lengths"].items():
        lines = []
        for name, values in entry.items():
            if name.startswith("model"):
                lines.append((label + name[len("model"):].replace("_noise", " noise x"), settings.get(name, ""),
                              values))
        if with_baselines:
            for key, title in BASELINES:
                if key in entry:
                    lines.append((title, "", entry[key]))
            gt = entry.get("ground_truth", {})
            if "foot_slide" in gt:
                lines.append(("ground truth", "", {"foot_slide": gt["foot_slide"]}))
        out[length] = lines
    return out


def table(files: list[tuple[str, dict]]) -> str:
    merged: dict = {}
    for index, (label, results) in enumerate(files):
        for length, lines in rows(label, results, index == 0).items():
            merged.setdefault(length, []).extend(lines)
    # baselines last within each length
    header = "| L | method | setting | " + " | ".join(title for _, title, _ in COLUMNS) + " |"
    lines = [header, "|" + "---|" * (3 + len(COLUMNS))]
    for length in sorted(merged, key=int):
        ordered = sorted(merged[length], key=lambda r: r[0] in {t for _, t in BASELINES} | {"ground truth"})
        for name, setting, values in ordered:
            cells = [f"{values[k]:.{digits}f}" if k in values else "" for k, _, digits in COLUMNS]
            lines.append(f"| {length} | {name} | {setting} | " + " | ".join(cells) + " |")
    n = files[0][1]
    return (f"{n['n_windows']} windows, {n['samples']} samples per window\n\n" + "\n".join(lines))


def main(argv: list[str]) -> int:
    if not argv or any("=" not in a for a in argv):
        print(__doc__, file=sys.stderr)
        return 2
    files = []
    for arg in argv:
        label, path = arg.split("=", 1)
        files.append((label, json.loads(pathlib.Path(path).read_text())))
    print(table(files))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
