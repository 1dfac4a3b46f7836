#!/usr/bin/env bash
# The release recipe at 64000 steps (lafan1_cpu_release_64k.py here), trained across stops: run the train stage
# again with the same RUNS to resume. Every stage is in stages.sh here: compare holds it against the 40000-step
# release model's validation figures (baseline_40k_validation_paper.json, the README's rule), curve makes its
# times cumulative over the run's parts (cumulative_time.py), and test, grid, choose, test_default, release and
# picture run only when compare said replace.
#   DATA=/path/to/lafan1 RUNS=/path/to/runs bash experiments/2026-12-07_release_64k/run.sh [STAGE ...]
set -euo pipefail
cd "$(dirname "$0")/../.."
HERE=experiments/2026-12-07_release_64k
RUNS=${RUNS:?set RUNS to a folder for the run}
export HERE CONFIG=$HERE/lafan1_cpu_release_64k.py RUN=$RUNS/release_64k MODEL=$RUNS/release_64k_model \
    BASELINE=$HERE/baseline_40k_validation_paper.json \
    CUMULATIVE=$HERE/cumulative_time.py
export GATED="test grid choose test_default release picture"  # the test set too is read only for a replacing model
exec bash $HERE/stages.sh "$@"
