#!/usr/bin/env bash
# The reproduction on a 2-core CPU: the commands that made results/lafan1_cpu, in order.
# Usage: bash results/lafan1_cpu/run.sh train|train_long|evaluate|evaluate_long|figures   (from the repository root)
set -euo pipefail
DATA=${DATA:-../shared/data/lafan1}
OUT=results/lafan1_cpu
case "${1:-}" in
  train)  # the three runs went side by side on the same 2 cores (nice -n 10); see results/README.md
    bin/train --config lafan1_cpu --workdir runs/cvae_noprior --data "$DATA" --no-progress  # the reproduction model
    bin/train --config lafan1_cpu --workdir runs/none --data "$DATA" --no-progress model.posterior=none
    bin/train --config lafan1_cpu --workdir runs/cvae --data "$DATA" --no-progress loss.prior_rollout=true
    ;;
  train_long)  # the reproduction run continued, a learning-rate decay, and two loss changes from step 5566
    # (results/README.md, "Longer training, a learning-rate decay, a foot-skate term"); runs/cvae_noprior
    # must hold its step-3000 checkpoint. Stopping and resuming gives the same state (tests/test_train.py).
    cp -r runs/cvae_noprior runs/cvae_long
    bin/train --config lafan1_cpu --workdir runs/cvae_long --data "$DATA" --no-progress --max-steps 5566
    mkdir -p runs/base5566/checkpoints && cp -r runs/cvae_long/checkpoints/5566 runs/base5566/checkpoints/
    bin/train --config lafan1_cpu --workdir runs/cvae_long --data "$DATA" --no-progress --max-steps 8372
    mkdir -p runs/cvae_8372/checkpoints && cp -r runs/cvae_long/checkpoints/8372 runs/cvae_8372/checkpoints/
    bin/train --config lafan1_cpu --workdir runs/cvae_long --data "$DATA" --no-progress --max-steps "${LONG_STEPS:?}" \
      train.lr_decay_to=0.1 train.lr_decay_from_step=8372 train.lr_decay_until_step=10872
    bin/train --config lafan1_cpu --workdir runs/kl05 --init-from runs/base5566 --data "$DATA" --no-progress \
      --max-steps 6536 loss.kl_weight=0.5
    bin/train --config lafan1_cpu --workdir runs/footskate --init-from runs/base5566 --data "$DATA" --no-progress \
      --max-steps 7079 loss.foot_skate_weight=4
    mkdir -p runs/footskate_7079/checkpoints && cp -r runs/footskate/checkpoints/7079 runs/footskate_7079/checkpoints/
    bin/train --config lafan1_cpu --workdir runs/footskate --data "$DATA" --no-progress --max-steps "${SKATE_STEPS:?}" \
      loss.foot_skate_weight=4 train.lr_decay_to=0.1 train.lr_decay_from_step=7079 train.lr_decay_until_step=9579
    ;;
  evaluate_long)
    bin/evaluate model --checkpoint runs/kl05/checkpoints/6250 --data "$DATA" --samples 10 --lengths 30,50 \
      --json $OUT/kl05_step6250.json
    bin/evaluate model --checkpoint runs/cvae_8372 --data "$DATA" --samples 10 --lengths 30,50 \
      --json $OUT/cvae_step8372.json
    for run in cvae_long footskate; do
      bin/evaluate model --checkpoint runs/$run --data "$DATA" --samples 10 --json $OUT/${run}_final.json
    done
    bin/evaluate model --checkpoint runs/cvae_long --data "$DATA" --samples 10 --search 4 --noise-scales "" \
      --json $OUT/cvae_long_final_search4.json
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
    python results/figures.py --checkpoint runs/cvae_long --data "$DATA" --out $OUT/figures
    python results/placed_target.py --checkpoint runs/cvae_long --data "$DATA" --length 50 --out $OUT/placed_target
    python results/cmu_contacts.py --data ../shared/data/cmu --workdir runs/cmu --out results/cmu
    ;;
  *) echo "usage: bash results/lafan1_cpu/run.sh train|train_long|evaluate|evaluate_long|figures" >&2; exit 2 ;;
esac
