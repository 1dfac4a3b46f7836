"""Evaluation results as text: one table layout, with units, for the official benchmark
(``evaluate.benchmark_baselines``) and the paper's protocol (``evaluate.evaluate_protocol``).

One row per (length, method), one column per metric with its unit in the header, the ground truth's foot
slide and ground contact (penetration, toe clearance) as its own row, and a units legend below (``bin/evaluate`` prints these).
"""
from __future__ import annotations

import sys
from typing import Mapping

from stitchjax.eval import evaluate

__all__ = ["format_benchmark_table", "print_benchmark_table", "format_protocol_table"]


def format_benchmark_table(results: Mapping) -> str:
    """The official benchmark in the table layout of :func:`format_protocol_table` (one row per length and
    method, one column per metric with its unit)."""
    return format_protocol_table(results, title=f"LAFAN1 benchmark (official L2Q / L2P / NPSS, float64) on "
                                                f"{results['n_windows']} test windows")


def print_benchmark_table(results: Mapping, file=None) -> None:
    """Print ``format_benchmark_table(results)`` (to stdout by default)."""
    print(format_benchmark_table(results), file=file or sys.stdout)


def format_protocol_table(results: Mapping, title: str | None = None) -> str:
    """One row per (length, method), one column per metric, units in the header (4 decimals), a units
    legend below. ``results``: as :func:`evaluate_protocol` or :func:`benchmark_baselines` return them."""
    units = results.get("units", {})
    short = {"m": "m", "cm/frame": "cm/f", "deg/frame": "deg/f", "cm": "cm", "fraction": "frac"}
    cols = [(k, f"{k} ({short.get(units.get(k, '').split(' ')[0], '-')})") for k in evaluate.METRIC_KEYS if k in _first_row(results)]
    settings = results.get("settings", {})
    width = max([12] + [len(n) for n in settings])
    setting_width = max([7] + [len(v) for v in settings.values()])
    header = f"{'L':>3} {'method':<{width}} {'setting':<{setting_width}}" + "".join(f" {title:>15}" for _, title in cols)
    if title is None:
        title = f"Protocol on {results['n_windows']} windows, {results['samples']} samples per window"
    lines = [title, header, "-" * len(header)]
    for length, entry in results["lengths"].items():
        for name, values in entry.items():
            if name == "ground_truth":
                continue
            lines.append(
                f"{length:>3} {name:<{width}} {settings.get(name, ''):<{setting_width}}"
                + "".join(_cell(values.get(k, float("nan"))) for k, _ in cols)
            )
        gt = entry.get("ground_truth", {})
        if any(k in gt for k, _ in cols):  # foot slide and ground contact of the ground truth
            cells = "".join(_cell(gt[k]) if k in gt else f" {'':>15}" for k, _ in cols)
            lines.append(f"{length:>3} {'ground_truth':<{width}} {'':<{setting_width}}" + cells)
    lines.append("units: " + "; ".join(f"{k} {units[k]}" for k, _ in cols if k in units))
    return "\n".join(lines)


def _cell(value) -> str:
    """One table cell: 4 decimals, "-" for a figure that does not exist (None, e.g. no toe swing)."""
    return f" {'-':>15}" if value is None else f" {value:>15.4f}"


def _first_row(results: Mapping) -> dict:
    for entry in results["lengths"].values():
        for name, values in entry.items():
            if name != "ground_truth":
                return values
    return {}
