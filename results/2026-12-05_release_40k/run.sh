#!/usr/bin/env bash
# The release recipe at 40000 steps (lafan1_cpu_release_40k.py here) from one command, then what was measured
# of it. The stages train, export, validation, curve, grid, choose, test and test_default are the release
# recipe's (results/2026-12-04_release_recipe/run.sh), writing here; the test stage scores L = 10, 30, 50 with
# and without foot locking. Two stages are this study's own:
#   compare  results/2026-12-05_release_v2/compare.py: does it replace the release model? (the same rule as the
#            second recipe's, validation figures only)
#   release  copy the candidate into stitchjax/pretrained/lafan1_cpu_release when compare said so
#   DATA=/path/to/lafan1 RUNS=/path/to/runs bash results/2026-12-05_release_40k/run.sh [STAGE ...]
set -euo pipefail
cd "$(dirname "$0")/../.."
HERE=results/2026-12-05_release_40k
RUNS=${RUNS:?set RUNS to a folder for the run}
export OUT=$HERE CONFIG=$HERE/lafan1_cpu_release_40k.py RUN=$RUNS/release_40k MODEL=$RUNS/release_40k_model FOOT_LOCK=both
STAGES=("$@"); [ ${#STAGES[@]} -eq 0 ] && STAGES=(train export validation curve compare test)
log() { echo "$(date -u +%FT%T) $*" | tee -a "$HERE/log.txt"; }
for stage in "${STAGES[@]}"; do case $stage in
compare)
  python results/2026-12-05_release_v2/compare.py results/2026-12-04_release_recipe/validation_paper.json \
      $HERE/validation_paper.json --out $HERE/decision.json ;;
release)
  if python -c "import json, sys; sys.exit(0 if json.load(open('$HERE/decision.json'))['replace'] else 1)"; then
    cp "$MODEL/model.json" "$MODEL/params.msgpack" stitchjax/pretrained/lafan1_cpu_release/
    log "release: $MODEL copied into stitchjax/pretrained/lafan1_cpu_release"
  else
    log "release: the release model stays (decision.json)"
  fi ;;
*) bash results/2026-12-04_release_recipe/run.sh "$stage" ;;
esac; done
