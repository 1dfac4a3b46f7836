"""Make the validation curve's times cumulative over a run's parts, then redraw the curve: the 25000-step study's
script, with the parts read from the run's metrics.jsonl instead of written in (bin/train's time_s restarts at 0
on each resume; a part ends at the last step it logged before the next part's first).

    RUN=runs/release_40k python results/2026-12-06_release_40k/cumulative_time.py SUMMARY_JSON

Later release studies use it too (their run.sh sets CUMULATIVE to it). For this run the parts are
((26000, 10440.8),): steps 0-26000 in 10441 s (it counts the pauses and the shared cores of README), then the
second part.
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
    spec = importlib.util.spec_from_file_location("cumulative_25k", "results/2026-12-05_release_25k/cumulative_time.py")
    cumulative = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cumulative)
    cumulative.PARTS = parts(os.path.join(os.environ["RUN"], "metrics.jsonl"))
    print("parts:", cumulative.PARTS)
    cumulative.main(sys.argv[1])
