#!/usr/bin/env bash
# The second release recipe (lafan1_cpu_release_v2.py here: the release recipe without the foot-skate term and
# contact gradients) from one command, then what was measured of it. The stages train, export, validation,
# curve and test are the release recipe's (results/2026-12-04_release_recipe/run.sh), writing here; the test
# stage scores L = 10, 30, 50 with and without foot locking. Two stages are this study's own:
#   compare  compare.py: does the candidate replace the release model? (validation figures only)
#   release  copy the candidate into stitchjax/pretrained/lafan1_cpu_release when compare said so
# No default sampling was chosen for it (the release recipe's grid and choose stages were not run).
#   DATA=/path/to/lafan1 RUNS=/path/to/runs bash results/2026-12-05_release_v2/run.sh [STAGE ...]
set -euo pipefail
cd "$(dirname "$0")/../.."
HERE=results/2026-12-05_release_v2
RUNS=${RUNS:?set RUNS to a folder for the run}
export OUT=$HERE CONFIG=$HERE/lafan1_cpu_release_v2.py RUN=$RUNS/release_v2 MODEL=$RUNS/release_v2_model FOOT_LOCK=both
STAGES=("$@"); [ ${#STAGES[@]} -eq 0 ] && STAGES=(train export validation curve compare test release)
log() { echo "$(date -u +%FT%T) $*" | tee -a "$HERE/log.txt"; }
for stage in "${STAGES[@]}"; do case $stage in
compare)
  python $HERE/compare.py results/2026-12-04_release_recipe/validation_paper.json $HERE/validation_paper.json \
      --out $HERE/decision.json ;;
release)
  if python -c "import json, sys; sys.exit(0 if json.load(open('$HERE/decision.json'))['replace'] else 1)"; then
    cp "$MODEL/model.json" "$MODEL/params.msgpack" stitchjax/pretrained/lafan1_cpu_release/
    log "release: $MODEL copied into stitchjax/pretrained/lafan1_cpu_release"
  else
    log "release: the release model stays (decision.json)"
  fi ;;
*) bash results/2026-12-04_release_recipe/run.sh "$stage" ;;
esac; done
