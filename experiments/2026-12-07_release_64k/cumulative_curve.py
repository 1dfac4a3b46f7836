"""Make the validation curve's times cumulative over a run's parts (bin/train's time_s restarts at 0 on each
resume), then redraw the curve: cumulative_time.py sets PARTS from the run's metrics.jsonl and calls main.

The default PARTS are the 25000-step run's (steps 0-5853 in 1490 s of training loop, 5853-8352 in 866 s). A point
at step s of a later part gets the loop time of the parts before it added. Writes "time_cumulative": true into
the file, so running it twice changes nothing.
"""
import json
import pathlib
import subprocess
import sys

PARTS = ((5853, 1490.0), (8352, 866.0))  # (the step a part ended at, its loop time in s)


def offset(step):
    return sum(seconds for end, seconds in PARTS if step > end)


def main(path):
    path = pathlib.Path(path)
    summary = json.loads(path.read_text())
    curve = summary["curve"]
    if not curve.get("time_cumulative"):
        for point in curve["points"]:
            point["time_s"] += offset(point["step"])
        first = curve["first_below_interpolation_on_ade_and_npss"]
        if first:
            first["time_s"] += offset(first["step"])
        curve["time_cumulative"] = True
        path.write_text(json.dumps(summary, indent=2) + "\n")
    subprocess.run([sys.executable, str(pathlib.Path(__file__).with_name("curve_figure.py")), str(path),
                    str(path.with_name("validation_curve.png"))], check=True)
    print(curve["first_below_interpolation_on_ade_and_npss"])


if __name__ == "__main__":
    main(sys.argv[1])
