"""The issue's test-set targets for the release model, checked from a study's test JSON files (the paper's
sampling, 10 samples, 376 subject5 windows): ADE and NPSS at most 0.85x interpolation's at L = 30 and 50; L2P at
most 0.85x at L = 15, 30 and 45; SLDE at most interpolation's and foot slide below it at every L; APD above 0 and
rising with L. Prints one line per target and writes them as JSON.

    python experiments/2026-12-07_release_64k/targets.py experiments/2026-12-07_release_64k [--out FILE]
"""
import argparse
import json
import pathlib


def checks(diversity, official):
    """[(name, model, interpolation, ratio or None, met)] from the two files' "lengths"."""
    rows = []
    lengths = {**official, **diversity}  # L = 5, 15, 45 (official) and 10, 30, 50 (diversity, one context frame too)

    def ratio(metric, n, bound, strict=False):
        m, i = lengths[n]["model"][metric], lengths[n]["interp"][metric]
        rows.append((f"{metric} L{n} <{'' if strict else '='} {bound} x interpolation", m, i, m / i,
                     m / i < bound if strict else m / i <= bound))

    for n in ("30", "50"):
        ratio("ade", n, 0.85)
        ratio("npss", n, 0.85)
    for n in ("15", "30", "45"):
        ratio("l2p", n, 0.85)
    order = sorted(lengths, key=int)
    for n in order:
        ratio("slde", n, 1.0)
    for n in order:
        ratio("foot_slide", n, 1.0, strict=True)
    apd = [lengths[n]["model"]["apd"] for n in order]
    rows.append((f"APD > 0 and rising over L = {', '.join(order)}", apd, None, None,
                 apd[0] > 0 and all(b > a for a, b in zip(apd, apd[1:]))))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folder")
    parser.add_argument("--out")
    args = parser.parse_args()
    folder = pathlib.Path(args.folder)
    diversity = json.loads((folder / "test_paper_L10_30_50.json").read_text())["lengths"]
    official = json.loads((folder / "test_official_L5_15_45.json").read_text())["lengths"]
    rows = checks(diversity, official)
    for name, m, i, r, met in rows:
        figures = f"{m:.4f} / {i:.4f} = {r:.3f}" if r is not None else " ".join(f"{x:.3f}" for x in m)
        print(f"{'met ' if met else 'MISS'}  {name:40s} {figures}")
    print(f"{sum(r[-1] for r in rows)} of {len(rows)} met")
    if args.out:
        pathlib.Path(args.out).write_text(json.dumps(
            [{"target": n, "model": m, "interpolation": i, "ratio": r, "met": bool(ok)} for n, m, i, r, ok in rows],
            indent=1) + "\n")


if __name__ == "__main__":
    main()
