#!/usr/bin/env python3
"""Diversity against quality: every sampling of every model as one point, at one transition length.

    S=results/lafan1_cpu/scratch_mixed
    python results/frontier.py --length 50 --out $S/frontier_L50.png \
        "posterior=$S/scratch_mixed_all_lengths.json+$S/scratch_mixed_noise_sweep_L50.json" \
        "none=$S/scratch_mixed_none_all_lengths.json+$S/scratch_mixed_none_noise_sweep_L50.json"

Each argument is LABEL=FILE[+FILE...], files written by `bin/evaluate model --json` (or the scripts beside
this one). Every model row of a file at that length ("model", "model_noise2", ...) is a point: x = the
samples' mean pairwise distance per joint at mid-transition (cm), y = ADE, SLDE, NPSS or foot slide, one panel
each; a label's points are joined in order of spread. Interpolation's value is the dashed line: a point under
it beats interpolation on that figure. The points are printed as a table too, and for each label the widest
sampling that is below interpolation on ADE, and on all four figures: the spread a model buys at no loss to
interpolation.
"""
from __future__ import annotations

import argparse
import json
import pathlib

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

PANELS = (("ade", "ADE (m)"), ("slde", "SLDE (m)"), ("npss", "NPSS"), ("foot_slide", "foot slide (cm/frame)"))


def points(files: list[str], length: str) -> tuple[list[tuple[str, dict]], dict | None]:
    """[(setting, metrics)] of every model row at ``length`` in ``files`` (a setting once), sorted by mid
    spread; and the interpolation row of the first file that has one (None if none does)."""
    out, interp = [], None
    for path in files:
        results = json.loads(pathlib.Path(path).read_text())
        if length not in results["lengths"]:
            raise SystemExit(f"{path} has no results at L = {length} (it has {', '.join(results['lengths'])})")
        entry, settings = results["lengths"][length], results.get("settings", {})
        seen = {setting for setting, _ in out}  # a setting in two files (x1, usually) counts once
        out += [(settings.get(name, name), values) for name, values in entry.items()
                if name.startswith("model") and settings.get(name, name) not in seen]
        if interp is None and "interp" in entry:
            interp = entry["interp"]
    return sorted(out, key=lambda item: item[1]["spread_mid"]), interp


def widest_below(rows: list[tuple[str, dict]], interp: dict, keys) -> tuple[str, float] | None:
    """(setting, mid spread in cm) of the widest point in ``rows`` (:func:`points`) whose every figure in
    ``keys`` is below interpolation's; None when no point is."""
    below = [(setting, r["spread_mid"]) for setting, r in rows if all(r[key] < interp[key] for key in keys)]
    return max(below, key=lambda item: item[1]) if below else None


def _widest_text(rows, interp, keys) -> str:
    widest = widest_below(rows, interp, keys)
    return "none" if widest is None else f"{widest[1]:.2f} cm ({widest[0]})"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("series", nargs="+", help="LABEL=FILE[+FILE...]")
    parser.add_argument("--length", type=int, default=50, help="transition length L (default 50)")
    parser.add_argument("--out", required=True, help="PNG to write")
    args = parser.parse_args(argv)
    fig = Figure(figsize=(12, 8), dpi=100)
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 2).ravel()
    interp, widest = None, []
    print(f"| series | setting | mid spread (cm) | {' | '.join(title for _, title in PANELS)} |")
    print("|---|---|---|" + "---|" * len(PANELS))
    for item in args.series:
        label, _, files = item.partition("=")
        if not files:
            raise SystemExit(f"{item!r}: expected LABEL=FILE[+FILE...]")
        rows, series_interp = points(files.split("+"), str(args.length))
        interp = interp or series_interp
        for ax, (key, _) in zip(axes, PANELS):
            ax.plot([r["spread_mid"] for _, r in rows], [r[key] for _, r in rows], "o-", label=label)
        for setting, r in rows:
            print(f"| {label} | {setting} | {r['spread_mid']:.2f} | "
                  + " | ".join(f"{r[key]:.4g}" for key, _ in PANELS) + " |")
        if series_interp is not None:
            widest.append(f"| {label} | {_widest_text(rows, series_interp, ('ade',))} | "
                          f"{_widest_text(rows, series_interp, [key for key, _ in PANELS])} |")
    if widest:
        print("\n| series | widest spread below interpolation on ADE | ... on ADE, SLDE, NPSS and foot slide |")
        print("|---|---|---|")
        print("\n".join(widest))
    for ax, (key, title) in zip(axes, PANELS):
        if interp is not None:
            ax.axhline(interp[key], color="0.3", linestyle="--", label="interpolation")
        ax.set_xlabel("samples' mean distance per joint at mid-transition (cm)")
        ax.set_ylabel(title)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"Diversity against quality at L = {args.length} (lower is better; under the dashed line beats "
                 "interpolation)")
    fig.tight_layout()
    pathlib.Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
