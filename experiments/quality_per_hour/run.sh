#!/usr/bin/env bash
# The quality-per-hour levers, one after another: train each config from scratch, then score it once on the whole
# validation split at the paper's sampling (10 samples, L = 30 and 50).
#   DATA=../shared/data/lafan1 RUNS=runs bash experiments/quality_per_hour/run.sh [NAME ...]
# NAME: a config of configs/ here (base_6k anchor_6k ...); each stage skips what is done.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
REPO=$(cd "$HERE/../.." && pwd)
DATA=${DATA:-$REPO/../shared/data/lafan1}
RUNS=${RUNS:-$REPO/runs}
cd "$REPO"
log() { echo "$(date -u +%FT%T) $*" >> "$HERE/log.txt"; }
for name in "${@:-base_6k anchor_6k anchor_penetration_6k anchor_predicted_6k}"; do
  for n in $name; do
    work="$RUNS/qph_$n"
    if [ ! -f "$work/report.md" ]; then
      log "train $n: start, commit $(git rev-parse --short HEAD): bin/train --config experiments/quality_per_hour/configs/$n.py --workdir $work --data $DATA --no-progress"
      t0=$(date +%s)
      nice -n "${NICE:-0}" bin/train --config "experiments/quality_per_hour/configs/$n.py" --workdir "$work" --data "$DATA" --no-progress
      log "train $n: done in $(( $(date +%s) - t0 )) s of wall time"
    fi
    out="$HERE/validation/$n.json"
    if [ ! -f "$out" ]; then
      mkdir -p "$HERE/validation"
      t0=$(date +%s)
      bin/evaluate model --checkpoint "$work" --data "$DATA" --split validation --samples 10 --lengths 30,50 \
        --noise-scales '' --json "$out"
      log "validation $n: $(( $(date +%s) - t0 )) s: bin/evaluate model --checkpoint $work --data $DATA --split validation --samples 10 --lengths 30,50 --noise-scales '' --json $out"
    fi
  done
done
