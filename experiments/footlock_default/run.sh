#!/usr/bin/env bash
# Foot locking's defaults: chosen on non-test windows by the rule of README.md, then read once on the test windows.
#   bash experiments/footlock_default/run.sh [STAGE ...]    (from the repository root; default: all four)
#   sample  the model's transitions of the validation split and the artefact set at the default and the paper's
#           sampling, cached in CACHE (the pass is not run: the grid re-runs only the pass)
#   grid    every candidate of candidates.json on the cached transitions (grid.json)
#   choose  the rule of README.md over the grid (choice.json)
#   test    bin/evaluate on the subject5 test windows, L = 10, 30, 50, 10 samples, the default sampling, with and
#           without foot locking (test_subject5.json); stops first unless the chosen settings are the package's defaults
# MODEL: the model folder (default: the release model); DATA: the LAFAN1 folder (default ../shared/data/lafan1);
# CACHE: the cached transitions (default /tmp/footlock_default); OUT: the JSONs (default: this folder).
set -euo pipefail
HERE=experiments/footlock_default
OUT=${OUT:-$HERE}
DATA=${DATA:-../shared/data/lafan1}
CACHE=${CACHE:-/tmp/footlock_default}
MODEL=${MODEL:-stitchjax/pretrained/lafan1_cpu_release}
export JAX_COMPILATION_CACHE_DIR=${JAX_COMPILATION_CACHE_DIR:-$CACHE/jax}
mkdir -p "$OUT" "$CACHE"
study() { nice -n 19 python $HERE/study.py "$@"; }
log() { echo "$(date -u +%FT%T) $*" | tee -a "$OUT/log.txt"; }
timed() {  # timed NAME COMMAND...: run it, log its wall time and commit
  local name=$1; shift; local start; start=$(date +%s); "$@"
  log "$name: $(( $(date +%s) - start )) s: $* (commit $(git rev-parse --short HEAD))"
}
STAGES=("$@"); [ ${#STAGES[@]} -eq 0 ] && STAGES=(sample grid choose test)
for stage in "${STAGES[@]}"; do case $stage in
  sample) for set in validation artefacts; do for sampling in default paper; do
      timed "sample $set $sampling" study sample --set $set --sampling $sampling --cache "$CACHE" --data "$DATA" \
          --checkpoint "$MODEL"
    done; done ;;
  grid) timed grid study grid --candidates $HERE/candidates.json --cache "$CACHE" --data "$DATA" --checkpoint "$MODEL" \
      --json "$OUT/grid.json" ;;
  choose) timed choose study choose --grid "$OUT/grid.json" --json "$OUT/choice.json" ;;
  test) study check-defaults --choice "$OUT/choice.json"
      timed test nice -n 19 python bin/evaluate model --checkpoint "$MODEL" --data "$DATA" --lengths 10,30,50 \
          --samples 10 --foot-lock both --default-sampling --noise-scales "" --json "$OUT/test_subject5.json" ;;
  *) echo "usage: $0 [sample|grid|choose|test ...]" >&2; exit 2 ;;
esac; done
