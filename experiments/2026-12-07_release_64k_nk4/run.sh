#!/usr/bin/env bash
# The 64000-step release recipe with the near-keyframe weight (lafan1_cpu_release_64k_nk4.py here), trained across
# stops: run the train stage again with the same RUNS to resume. This study's own stages:
#   baseline          the 64000-step release model (RELEASE_MODEL, default runs/release_64k_model: its export by
#                     experiments/2026-12-07_release_64k/run.sh export) on the validation split at L = 5, 15, 45
#   validation_short  the candidate on the validation split at L = 5, 15, 45
#   compare           compare.py here: the rule fixed before the run (SLDE lower at L = 5, 30, 50, ADE/NPSS and
#                     feet within their margins)
# Every other stage is the release studies' (experiments/2026-12-07_release_64k/stages.sh), writing here; test, grid,
# choose, test_default, release and picture run only when compare said replace. The release stage exports with
# --config-name lafan1_cpu_release, which bin/export refuses unless configs/lafan1_cpu_release.py equals this
# config: set loss.near_keyframe_weight=4 there first.
#   DATA=/path/to/lafan1 RUNS=/path/to/runs bash experiments/2026-12-07_release_64k_nk4/run.sh [STAGE ...]
set -euo pipefail
cd "$(dirname "$0")/../.."
HERE=experiments/2026-12-07_release_64k_nk4
RUNS=${RUNS:?set RUNS to a folder for the run}
DATA=${DATA:?set DATA to the LAFAN1 folder}
RELEASE_MODEL=${RELEASE_MODEL:-runs/release_64k_model}
export HERE CONFIG=$HERE/lafan1_cpu_release_64k_nk4.py RUN=$RUNS/release_64k_nk4 MODEL=$RUNS/release_64k_nk4_model \
    BASELINE=experiments/2026-12-07_release_64k/validation_paper.json \
    CUMULATIVE=experiments/2026-12-07_release_64k/cumulative_time.py
export GATED="test grid choose test_default release picture"  # the test set too is read only for a replacing model
log() { echo "$(date -u +%FT%T) $*" | tee -a "$HERE/log.txt"; }
short() {  # short MODEL OUT: the validation split at L = 5, 15, 45, the paper's sampling
  [ -f "$2" ] && return
  local start; start=$(date +%s)
  bin/evaluate model --checkpoint "$1" --data "$DATA" --split validation --samples 10 --lengths 5,15,45 \
      --noise-scales '' --json "$2"
  log "$(basename "$2" .json): $(( $(date +%s) - start )) s: bin/evaluate model --checkpoint $1 --data $DATA --split validation --samples 10 --lengths 5,15,45 --noise-scales '' --json $2 (commit $(git rev-parse --short HEAD))"
}
STAGES=("$@"); [ ${#STAGES[@]} -eq 0 ] && STAGES=(baseline train export validation validation_short curve compare test grid choose test_default release picture)
for stage in "${STAGES[@]}"; do case $stage in
baseline) short "$RELEASE_MODEL" $HERE/release_validation_L5_15_45.json ;;
validation_short) short "$MODEL" $HERE/validation_L5_15_45.json ;;
compare)
  python $HERE/compare.py "$BASELINE" $HERE/release_validation_L5_15_45.json $HERE/validation_paper.json \
      $HERE/validation_L5_15_45.json --out $HERE/decision.json ;;
*) bash experiments/2026-12-07_release_64k/stages.sh "$stage" ;;
esac; done
