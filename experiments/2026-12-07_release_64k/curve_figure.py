"""The release run's validation curve as a picture: ratios to interpolation against minutes of training loop.

    python experiments/2026-12-07_release_64k/curve_figure.py experiments/2026-12-07_release_64k/summary_validation.json \
        experiments/2026-12-07_release_64k/validation_curve.png
"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(summary_path, out_path):
    curve = json.load(open(summary_path))["curve"]
    points = curve["points"]
    minutes = [p["time_s"] / 60 for p in points]
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4), sharey=True)
    for ax, length in zip(axes, curve["lengths"]):
        for metric, label in (("ade", "ADE"), ("npss", "NPSS"), ("foot_slide", "foot slide"), ("slde", "SLDE")):
            ax.plot(minutes, [p[f"{metric}_L{length}_ratio"] for p in points], marker=".", label=label)
        ax.axhline(1.0, color="black", lw=0.8, ls="--")
        ax.set_title(f"L = {length}")
        ax.set_xlabel("training loop (min, 2 CPU cores)")
        ax.grid(alpha=0.3)
    first = curve["first_below_interpolation_on_ade_and_npss"]
    if first:
        for ax in axes:
            ax.axvline(first["time_s"] / 60, color="grey", lw=0.8)
    axes[0].set_ylabel("model / interpolation (validation)")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_path, dpi=90)


if __name__ == "__main__":
    main(*sys.argv[1:3])
