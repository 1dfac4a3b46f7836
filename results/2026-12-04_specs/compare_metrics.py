"""Are two training runs' logged metrics identical? Compares two metrics.jsonl files record by record.

    python results/2026-12-04_specs/compare_metrics.py BEFORE/metrics.jsonl AFTER/metrics.jsonl [--json OUT]

Every field but the timings (time_s, windows_per_s) must be equal as written (float bits, not a tolerance).
Prints one line per record; exit status 0 when all are identical, 1 otherwise.
"""
from __future__ import annotations

import argparse
import json
import sys

TIMINGS = ("time_s", "windows_per_s")


def records(path: str) -> list:
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def compare(before: list, after: list) -> list:
    """One row per logged record: step, loss before / after, identical (every non-timing field equal)."""
    rows = []
    for a, b in zip(before, after):
        same = ({k: v for k, v in a.items() if k not in TIMINGS} == {k: v for k, v in b.items() if k not in TIMINGS})
        rows.append({"step": a.get("step"), "loss_before": a.get("loss"), "loss_after": b.get("loss"),
                     "identical": same})
    if len(before) != len(after):
        rows.append({"step": None, "identical": False, "note": f"{len(before)} records against {len(after)}"})
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("before")
    parser.add_argument("after")
    parser.add_argument("--json", help="write the rows to this file")
    args = parser.parse_args(argv)
    rows = compare(records(args.before), records(args.after))
    for row in rows:
        print(row)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0 if rows and all(row["identical"] for row in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
