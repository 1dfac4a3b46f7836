#!/usr/bin/env bash
# The ablation on the validation split: every row trained from scratch for the same steps from the same seed,
# then scored on the whole validation split (10 samples, L = 30 and 50). Resumable: a finished row is skipped.
#
#   DATA=/path/to/lafan1 RUNS=/path/to/runs STEPS=5000 bash experiments/2026-12-04_validation_ablation/run.sh [ROW ...]
set -euo pipefail
cd "$(dirname "$0")/../.."
HERE=experiments/2026-12-04_validation_ablation
DATA=${DATA:?set DATA to the LAFAN1 folder}
RUNS=${RUNS:?set RUNS to a folder for the runs}
STEPS=${STEPS:-5000}
# lafan1_cpu_release decays its learning rate from step 8000 on, so its first STEPS (<= 8000) steps are a constant
# learning rate as in the lafan1_cpu rows; the "recipe" row is therefore the release run's own checkpoint STEPS.
EXTRA="data.extra_train_dirs=../lafan1_filtered60"
declare -A ROWS=(
  [paper]="--config lafan1_cpu"
  [extra]="--config lafan1_cpu $EXTRA"
  [extra_starts]="--config lafan1_cpu $EXTRA data.random_starts=true"
  [extra_starts_mirror]="--config lafan1_cpu $EXTRA data.random_starts=true data.mirror=true"
  [recipe]="--config lafan1_cpu_release"
  [recipe_posterior_none]="--config lafan1_cpu_release model.posterior=none"
  [recipe_no_foot_terms]="--config lafan1_cpu_release loss.foot_skate_weight=0 loss.foot_velocity_weight=0"
  # one extension of the recipe back to the paper's value at a time
  [recipe_paper_kl]="--config lafan1_cpu_release loss.kl_weight=1.0 loss.free_bits=0 loss.kl_warmup_steps=0"
  [recipe_no_prior_samples]="--config lafan1_cpu_release loss.prior_sample_fraction=0"
  [recipe_no_foot_velocity]="--config lafan1_cpu_release loss.foot_velocity_weight=0"
  [recipe_no_foot_skate]="--config lafan1_cpu_release loss.foot_skate_weight=0"
  [recipe_no_contact_gradient]="--config lafan1_cpu_release model.contact_input_gradient=false"
  # the two that won, together (the next recipe), and the foot-skate row again from a second seed
  [recipe_next]="--config lafan1_cpu_release loss.foot_skate_weight=0 model.contact_input_gradient=false"
  [recipe_no_foot_skate_seed1]="--config lafan1_cpu_release loss.foot_skate_weight=0 train.seed=1"
  # the recipe itself from a second seed: how far seed noise moves the row every other row is compared with
  [recipe_seed1]="--config lafan1_cpu_release train.seed=1"
  # the state and FK terms weighted 4x on each direction's first generated frame (the backward one is the frame
  # SLDE scores), from both seeds; loss.near_keyframe_weight left Config after commit 9baff53: run these two there
  [recipe_near_keyframe4]="--config lafan1_cpu_release loss.near_keyframe_weight=4"
  [recipe_near_keyframe4_seed1]="--config lafan1_cpu_release loss.near_keyframe_weight=4 train.seed=1"
  # the width: the recipe at half the CPU widths, and at the widths of the GPU config lafan1 (the paper does not
  # give them; config.py's defaults)
  [recipe_half_width]="--config lafan1_cpu_release model.encoder_widths=64,64,64 model.lstm_size=128 model.decoder_widths=128,128 model.gating_widths=16,16 model.disc_widths=64,32"
  [recipe_lafan1_width]="--config lafan1_cpu_release model.encoder_widths=512,512,256 model.lstm_size=512 model.decoder_widths=512,512 model.gating_widths=64,64 model.disc_widths=512,256"
)
ORDER=(paper extra extra_starts extra_starts_mirror recipe recipe_posterior_none recipe_no_foot_terms recipe_paper_kl
       recipe_no_prior_samples recipe_no_foot_velocity recipe_no_foot_skate recipe_no_contact_gradient
       recipe_next recipe_no_foot_skate_seed1 recipe_seed1 recipe_near_keyframe4 recipe_near_keyframe4_seed1
       recipe_half_width recipe_lafan1_width)
[ $# -gt 0 ] && ORDER=("$@")
for row in "${ORDER[@]}"; do
  out=$HERE/$row.json
  [ -f "$out" ] && { echo "$row: done ($out)"; continue; }
  start=$(date +%s)
  # shellcheck disable=SC2086
  bin/train ${ROWS[$row]} --workdir "$RUNS/$row" --data "$DATA" --no-progress train.max_steps=$STEPS \
      train.eval_every=1000 train.eval_windows=64 train.checkpoint_every_steps=500 > "$RUNS/$row.log" 2>&1
  trained=$(date +%s)
  bin/evaluate model --checkpoint "$RUNS/$row/checkpoints/$STEPS" --data "$DATA" --split validation \
      --samples 10 --lengths 30,50 --noise-scales '' --json "$RUNS/$row.eval.json" >> "$RUNS/$row.log" 2>&1
  python experiments/2026-12-07_release_64k/summarise.py --metrics "$RUNS/$row/metrics.jsonl" \
      --evaluation "$RUNS/$row.eval.json" --out "$RUNS/$row.summary.json" > /dev/null
  python - "$RUNS/$row.eval.json" "$RUNS/$row.summary.json" "$out" "$row" "${ROWS[$row]} train.max_steps=$STEPS" \
      "$((trained - start))" "$(git rev-parse --short HEAD)" <<'PY'
import json, sys
evaluation, summary, out, row, overrides, train_s, commit = sys.argv[1:]
summary = json.loads(open(summary).read())
json.dump({"row": row, "command": f"bin/train {overrides}", "commit": commit, "train_wall_s": int(train_s),
           "ratios": summary["evaluation"], "curve": summary["curve"], "evaluation": json.loads(open(evaluation).read())},
          open(out, "w"), indent=1)
PY
  echo "$row: $(( $(date +%s) - start )) s"
done
