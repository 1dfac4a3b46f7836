#!/usr/bin/env bash
# The reproduction on a 2-core CPU: the commands that made results/lafan1_cpu, in order.
# Usage: bash results/lafan1_cpu/run.sh train|evaluate|figures   (from the repository root)
set -euo pipefail
DATA=${DATA:-../shared/data/lafan1}
OUT=results/lafan1_cpu
case "${1:-}" in
  train)  # the three runs went side by side on the same 2 cores (nice -n 10); see results/README.md
    bin/train --config lafan1_cpu --workdir runs/cvae_noprior --data "$DATA" --no-progress  # the reproduction model
    bin/train --config lafan1_cpu --workdir runs/none --data "$DATA" --no-progress model.posterior=none
    bin/train --config lafan1_cpu --workdir runs/cvae --data "$DATA" --no-progress loss.prior_rollout=true
    ;;
  evaluate)
    for run in cvae_noprior none; do
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --json $OUT/$run.json
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --search 4 --noise-scales "" \
        --json $OUT/${run}_search4.json
    done
    bin/evaluate model --checkpoint runs/cvae --data "$DATA" --samples 10 --json $OUT/cvae.json
    python results/variance_blend.py --checkpoint runs/cvae_noprior --data "$DATA" --json $OUT/variance_blend.json
    ;;
  figures)
    python results/figures.py --checkpoint runs/cvae_noprior --data "$DATA" --out $OUT/figures
    python results/placed_target.py --checkpoint runs/cvae_noprior --data "$DATA" --out $OUT/placed_target || true
    ;;
  *) echo "usage: bash results/lafan1_cpu/run.sh train|evaluate|figures" >&2; exit 2 ;;
esac
