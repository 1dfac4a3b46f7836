"""Make the validation curve's times cumulative over the run's two parts (bin/train's time_s restarts at 0 on
each resume), then redraw the curve: the 25000-step study's script with this run's parts.

    python results/2026-12-06_release_40k/cumulative_time.py results/2026-12-06_release_40k/summary_validation.json

The parts (log.txt): steps 0-26000 in 10441 s (time_s at the checkpoint the second part resumed from; it counts
the pauses and the shared cores of README), 26000-40000 in the second part.
"""
import importlib.util
import sys

spec = importlib.util.spec_from_file_location("cumulative_25k", "results/2026-12-05_release_25k/cumulative_time.py")
cumulative = importlib.util.module_from_spec(spec)
spec.loader.exec_module(cumulative)
cumulative.PARTS = ((26000, 10440.8),)  # (the step a part ended at, its loop time in s)

if __name__ == "__main__":
    cumulative.main(sys.argv[1])
