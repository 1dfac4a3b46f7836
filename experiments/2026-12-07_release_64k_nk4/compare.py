"""Does the near-keyframe model replace the 64000-step release model? Decided on the validation split only.

    python experiments/2026-12-07_release_64k_nk4/compare.py RELEASE_L30_50.json RELEASE_L5.json \
        CANDIDATE_L30_50.json CANDIDATE_L5.json --out decision.json

Each file is a `bin/evaluate model --split validation --samples 10 --noise-scales ''` output (the paper's
sampling): the L30_50 ones at --lengths 30,50, the L5 ones at --lengths 5,15,45. The rule, fixed before the
candidate was trained: the candidate is there to lower SLDE (the last generated frame's error), so it replaces
the release model when all three hold:
- SLDE: its SLDE ratio to interpolation is lower than the release model's at L = 5, 30 and 50;
- accuracy: the mean of its ADE and NPSS ratios at L = 30 and 50 is at most the release model's + 0.003;
- feet: its foot-slide ratio at L = 30 and 50 is at most the release model's + 0.05 (the release rule's margin).
Every ratio is taken against interpolation on the same 376 validation windows.
"""
import argparse
import json

SLDE_LENGTHS = ("5", "30", "50")
ACCURACY_LENGTHS = ("30", "50")
ACCURACY_SLACK = 0.003
FOOT_SLIDE_SLACK = 0.05


def ratios(*paths):
    """{metric_L: model / interp} for every length and metric of the evaluation JSONs."""
    out = {}
    for path in paths:
        for n, methods in json.load(open(path))["lengths"].items():
            for m in ("ade", "npss", "foot_slide", "slde"):
                out[f"{m}_L{n}"] = methods["model"][m] / methods["interp"][m]
    return out


def decide(release: dict, candidate: dict) -> dict:
    """The rule of the module docstring on two ratio dicts of :func:`ratios`."""
    accuracy = {name: sum(r[f"{m}_L{n}"] for n in ACCURACY_LENGTHS for m in ("ade", "npss")) / 4
                for name, r in (("release", release), ("candidate", candidate))}
    slde_lower = {n: candidate[f"slde_L{n}"] < release[f"slde_L{n}"] for n in SLDE_LENGTHS}
    accuracy_ok = accuracy["candidate"] <= accuracy["release"] + ACCURACY_SLACK
    feet_ok = all(candidate[f"foot_slide_L{n}"] <= release[f"foot_slide_L{n}"] + FOOT_SLIDE_SLACK
                  for n in ACCURACY_LENGTHS)
    return {"replace": all(slde_lower.values()) and accuracy_ok and feet_ok, "slde_lower": slde_lower,
            "mean_ade_npss_ratio": accuracy, "accuracy_within_slack": accuracy_ok, "accuracy_slack": ACCURACY_SLACK,
            "feet_within_slack": feet_ok, "foot_slide_slack": FOOT_SLIDE_SLACK}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("release_long")
    parser.add_argument("release_short")
    parser.add_argument("candidate_long")
    parser.add_argument("candidate_short")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    release = ratios(args.release_long, args.release_short)
    candidate = ratios(args.candidate_long, args.candidate_short)
    decision = decide(release, candidate)
    decision.update({"release": release, "candidate": candidate,
                     "files": [args.release_long, args.release_short, args.candidate_long, args.candidate_short]})
    json.dump(decision, open(args.out, "w"), indent=1)
    for key in sorted(release):
        print(f"{key:14s} release {release[key]:.3f}  candidate {candidate[key]:.3f}")
    print(f"SLDE lower at L = {', '.join(SLDE_LENGTHS)}: {decision['slde_lower']}; mean ADE/NPSS ratio: release "
          f"{decision['mean_ade_npss_ratio']['release']:.3f}, candidate {decision['mean_ade_npss_ratio']['candidate']:.3f} "
          f"(within +{ACCURACY_SLACK}: {decision['accuracy_within_slack']}); feet within +{FOOT_SLIDE_SLACK}: "
          f"{decision['feet_within_slack']} -> {'replace' if decision['replace'] else 'keep the release model'}")


if __name__ == "__main__":
    main()
