"""Print the top-level README's two results tables from a study's test JSON files.

    python experiments/2026-12-07_release_64k/readme_tables.py experiments/2026-12-07_release_64k

Reads test_paper_L10_30_50.json (the paper's sampling), test_default_L10_30_50.json (the default sampling) and
test_official_L5_15_45.json in FOLDER; the paper's rows are its Tables 1 and 2.
"""
import json
import pathlib
import sys

PAPER_DIVERSITY = {  # Table 1: APD, ADE, SLDE, NPSS, foot slide of "ours / Slerp"
    "10": "| 10 | paper: ours / Slerp | 1.415 / 0 | – | 0.032 / 0.030 | 0.012 / 0.020 | 0.008 / 0.006 | 2.146 / 3.689 |",
    "30": "| 30 | paper: ours / Slerp | 25.123 / 0 | – | 0.099 / 0.135 | 0.015 / 0.029 | 0.121 / 0.178 | 0.863 / 4.743 |",
    "50": "| 50 | paper: ours / Slerp | 63.269 / 0 | – | 0.123 / 0.252 | 0.016 / 0.034 | 0.311 / 0.739 | 0.468 / 3.984 |",
}
PAPER_OFFICIAL = {"5": "–", "15": "0.41 / 0.62 / 0.020", "30": "0.69 / 1.10 / 0.121", "45": "0.92 / 1.81 / 0.305"}


def row(n, name, m):
    spread = "0" if m["spread_mid"] == 0 else f"{m['spread_mid']:.3g}"
    apd = "0" if m["apd"] == 0 else f"{m['apd']:.3f}"
    return (f"| {n} | {name} | {apd} | {spread} | {m['ade']:.4f} | {m['slde']:.4f} | {m['npss']:.4f} | "
            f"{m['foot_slide']:.2f} |")


def main(folder):
    folder = pathlib.Path(folder)
    paper = json.loads((folder / "test_paper_L10_30_50.json").read_text())["lengths"]
    default = json.loads((folder / "test_default_L10_30_50.json").read_text())["lengths"]
    official = json.loads((folder / "test_official_L5_15_45.json").read_text())["lengths"]
    print("| L | method | APD (m) | spread (cm) | ADE (m) | SLDE (m) | NPSS | foot slide (cm/frame) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for n in ("10", "30", "50"):
        scaled = next(k for k in default[n] if k.startswith("model_noise"))
        print(row(n, "release, paper sampling", paper[n]["model"]))
        print(row(n, "release, default", default[n][scaled]))
        print(row(n, "interpolation", paper[n]["interp"]))
        print(PAPER_DIVERSITY[n])
    print()
    print("| n | release model / interpolation: L2Q | L2P | NPSS | paper: L2Q / L2P / NPSS |")
    print("| --- | --- | --- | --- | --- |")
    for n in ("5", "15", "30", "45"):
        lengths = paper if n == "30" else official
        m, i = lengths[n]["model"], lengths[n]["interp"]
        print(f"| {n} | {m['l2q']:.3f} / {i['l2q']:.3f} | {m['l2p']:.3f} / {i['l2p']:.3f} | "
              f"{m['npss']:.4f} / {i['npss']:.4f} | {PAPER_OFFICIAL[n]} |")


if __name__ == "__main__":
    main(sys.argv[1])
