"""Make the validation curve's times cumulative over a run's parts, then redraw the curve: cumulative_curve.py,
with the parts read from the run's metrics.jsonl instead of written in (bin/train's time_s restarts at 0
on each resume; a part ends at the last step it logged before the next part's first).

    RUN=runs/release_64k python experiments/2026-12-07_release_64k/cumulative_time.py SUMMARY_JSON

The release studies use it (their run.sh sets CUMULATIVE to it). For the 64000-step run the parts were
((37000, 9646.8),): steps 0-37000 in 9647 s, then the second part.
"""
import importlib.util
import json
import os
import sys


def parts(metrics_path):
    """((the step a part ended at, its loop time in s), ...) for every part but the last."""
    found, last = [], None
    for line in open(metrics_path):
        row = json.loads(line)
        if "time_s" not in row:
            continue
        if last is not None and row["time_s"] < last["time_s"]:
            found.append((last["step"], last["time_s"]))
        last = row
    return tuple(found)


if __name__ == "__main__":
    spec = importlib.util.spec_from_file_location("cumulative_curve", os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                                  "cumulative_curve.py"))
    cumulative = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cumulative)
    cumulative.PARTS = parts(os.path.join(os.environ["RUN"], "metrics.jsonl"))
    print("parts:", cumulative.PARTS)
    cumulative.main(sys.argv[1])
