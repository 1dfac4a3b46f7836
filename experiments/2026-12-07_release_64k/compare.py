"""Does the second release recipe's model replace the first? Decided on the validation split only.

    python experiments/2026-12-07_release_64k/compare.py FIRST.json SECOND.json --out decision.json

FIRST and SECOND are `bin/evaluate model --split validation --samples 10 --lengths 30,50 --noise-scales ''`
outputs (the paper's sampling) of the two models. The rule, fixed before SECOND was computed: SECOND replaces
FIRST when the mean of its ADE and NPSS ratios to interpolation at L = 30 and 50 is lower than FIRST's, and its
foot-slide ratio at each length is at most FIRST's + 0.05 (accuracy not bought with the feet). Both ratios are
taken against interpolation on the same 376 validation windows.
"""
import argparse
import json

LENGTHS = ("30", "50")
FOOT_SLIDE_SLACK = 0.05


def ratios(path):
    """{metric_L: model / interp} for ADE, NPSS and foot slide at L = 30 and 50 of one evaluation JSON."""
    lengths = json.load(open(path))["lengths"]
    return {f"{m}_L{n}": lengths[n]["model"][m] / lengths[n]["interp"][m]
            for n in LENGTHS for m in ("ade", "npss", "foot_slide")}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("first")
    parser.add_argument("second")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    first, second = ratios(args.first), ratios(args.second)
    accuracy = {name: sum(r[f"{m}_L{n}"] for n in LENGTHS for m in ("ade", "npss")) / 4
                for name, r in (("first", first), ("second", second))}
    feet_ok = all(second[f"foot_slide_L{n}"] <= first[f"foot_slide_L{n}"] + FOOT_SLIDE_SLACK for n in LENGTHS)
    replace = accuracy["second"] < accuracy["first"] and feet_ok
    decision = {"replace": replace, "mean_ade_npss_ratio": accuracy, "feet_within_slack": feet_ok,
                "foot_slide_slack": FOOT_SLIDE_SLACK, "first": first, "second": second,
                "first_file": args.first, "second_file": args.second}
    json.dump(decision, open(args.out, "w"), indent=1)
    for key in first:
        print(f"{key:14s} first {first[key]:.3f}  second {second[key]:.3f}")
    print(f"mean ADE/NPSS ratio: first {accuracy['first']:.3f}, second {accuracy['second']:.3f}; "
          f"feet within +{FOOT_SLIDE_SLACK}: {feet_ok} -> {'replace' if replace else 'keep the first'}")


if __name__ == "__main__":
    main()
