"""The README's two results tables (diversity and official protocols) from a release model's test JSONs.

    python results/2026-12-05_release_v2/readme_tables.py results/2026-12-05_release_v2

Reads test_paper_L10_30_50.json, test_default_L10_30_50.json and test_official_L5_15_45.json of the folder and
prints the Markdown rows; the paper's figures (Tables 1 and 2 of Ren et al.) are facts, written here once.
"""
import json
import pathlib
import sys

# Table 1 of the paper (diversity protocol): APD, ADE, SLDE, NPSS, foot slide; ours / Slerp.
PAPER_DIVERSITY = {
    "10": ("1.415 / 0", "0.032 / 0.030", "0.012 / 0.020", "0.008 / 0.006", "2.146 / 3.689"),
    "30": ("25.123 / 0", "0.099 / 0.135", "0.015 / 0.029", "0.121 / 0.178", "0.863 / 4.743"),
    "50": ("63.269 / 0", "0.123 / 0.252", "0.016 / 0.034", "0.311 / 0.739", "0.468 / 3.984"),
}
# Table 2 of the paper (official protocol): L2Q / L2P / NPSS.
PAPER_OFFICIAL = {"5": "–", "15": "0.41 / 0.62 / 0.020", "30": "0.69 / 1.10 / 0.121", "45": "0.92 / 1.81 / 0.305"}


def main(folder):
    folder = pathlib.Path(folder)
    paper = json.loads((folder / "test_paper_L10_30_50.json").read_text())["lengths"]
    default_path = folder / "test_default_L10_30_50.json"  # absent where no default sampling was chosen
    default = json.loads(default_path.read_text())["lengths"] if default_path.exists() else None
    official = json.loads((folder / "test_official_L5_15_45.json").read_text())["lengths"]
    print("| L | method | APD (m) | spread (cm) | ADE (m) | SLDE (m) | NPSS | foot slide (cm/frame) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for n in ("10", "30", "50"):
        rows = [("release, paper sampling", paper[n]["model"])]
        if "model+footlock" in paper[n]:
            rows.append(("release + foot locking", paper[n]["model+footlock"]))
        if default:
            rows.append(("release, default", default[n][[k for k in default[n] if k.startswith("model")][-1]]))
        for label, r in rows:
            print(f"| {n} | {label} | {r['apd']:.3f} | {r['spread_mid']:.2f} | {r['ade']:.4f} | {r['slde']:.4f} | "
                  f"{r['npss']:.4f} | {r['foot_slide']:.2f} |")
        i = paper[n]["interp"]
        print(f"| {n} | interpolation | 0 | 0 | {i['ade']:.4f} | {i['slde']:.4f} | {i['npss']:.4f} | {i['foot_slide']:.2f} |")
        apd, ade, slde, npss, slide = PAPER_DIVERSITY[n]
        print(f"| {n} | paper: ours / Slerp | {apd} | – | {ade} | {slde} | {npss} | {slide} |")
    print()
    print("| n | release model / interpolation: L2Q | L2P | NPSS | paper: L2Q / L2P / NPSS |")
    print("| --- | --- | --- | --- | --- |")
    for n in ("5", "15", "30", "45"):
        source = paper if n == "30" else official
        m, i = source[n]["model"], source[n]["interp"]
        print(f"| {n} | {m['l2q']:.3f} / {i['l2q']:.3f} | {m['l2p']:.3f} / {i['l2p']:.3f} | "
              f"{m['npss']:.4f} / {i['npss']:.4f} | {PAPER_OFFICIAL[n]} |")
    print()
    for n in ("10", "30", "50"):
        ratio = {k: paper[n]["model"][k] / paper[n]["interp"][k] for k in ("ade", "npss", "slde", "foot_slide", "l2p")}
        line = f"L{n} ratios paper sampling: " + ", ".join(f"{k} {v:.3f}" for k, v in ratio.items())
        if default:
            d = default[n][[k for k in default[n] if k.startswith("model")][-1]]
            line += " | default: " + ", ".join(f"{k} {d[k] / default[n]['interp'][k]:.3f}" for k in ("ade", "npss", "foot_slide"))
        print(line)
    for n in ("5", "15", "45"):
        m, i = official[n]["model"], official[n]["interp"]
        print(f"L{n} ratios: " + ", ".join(f"{k} {m[k] / i[k]:.3f}" for k in ("l2p", "l2q", "npss")))


if __name__ == "__main__":
    main(sys.argv[1])
