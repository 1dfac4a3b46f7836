#!/usr/bin/env bash
# The release recipe at 64000 steps (lafan1_cpu_release_64k.py here), trained across stops: run the train stage
# again with the same RUNS to resume. Every stage is the 25000-step study's (results/2026-12-05_release_25k/run.sh),
# writing here: compare holds it against the 40000-step release model's validation figures (the README's rule),
# curve makes its times cumulative over the run's parts (the 40000-step study's cumulative_time.py), and test,
# grid, choose, test_default, release and picture run only when compare said replace.
#   DATA=/path/to/lafan1 RUNS=/path/to/runs bash results/2026-12-07_release_64k/run.sh [STAGE ...]
set -euo pipefail
cd "$(dirname "$0")/../.."
HERE=results/2026-12-07_release_64k
RUNS=${RUNS:?set RUNS to a folder for the run}
export HERE CONFIG=$HERE/lafan1_cpu_release_64k.py RUN=$RUNS/release_64k MODEL=$RUNS/release_64k_model \
    BASELINE=results/2026-12-06_release_40k/validation_paper.json \
    CUMULATIVE=results/2026-12-06_release_40k/cumulative_time.py
export GATED="test grid choose test_default release picture"  # the test set too is read only for a replacing model
exec bash results/2026-12-05_release_25k/run.sh "$@"
