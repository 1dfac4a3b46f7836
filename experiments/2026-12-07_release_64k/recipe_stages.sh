#!/usr/bin/env bash
# The stages of a release recipe's run (first written for the 20000-step recipe, 2026-12-04_release_recipe),
# each resumable (a finished output is kept):
#   train        bin/train --config CONFIG
#   export       the float16 release folder, precision-checked
#   validation   the validation split at the paper's sampling
#   curve        the run's validation curve (summary_validation.json, validation_curve.png)
#   grid         the sampling grid on the validation split that the default is chosen on
#   choose       the default sampling (choose_sampling.py), exported into model.json
#   test         the subject5 test table at the paper's sampling: L = 10, 30, 50 (diversity protocol) and 5, 15,
#                45 (official protocol)
#   test_default the subject5 test table at the default sampling, L = 10, 30, 50
# stages.sh here runs them with OUT (the study's folder), CONFIG, RUN, MODEL, FOOT_LOCK (--foot-lock of the test
# stage's L = 10, 30, 50 run) and GRID set.
set -euo pipefail
cd "$(dirname "$0")/../.."
HERE=experiments/2026-12-07_release_64k  # the scripts of the stages
OUT=${OUT:?set OUT to the study's folder}
DATA=${DATA:?set DATA to the LAFAN1 folder}
RUNS=${RUNS:?set RUNS to a folder for the run}
CONFIG=${CONFIG:-lafan1_cpu_release}
RUN=${RUN:?set RUN to the run's folder}
MODEL=${MODEL:-stitchjax/pretrained/lafan1_cpu_release}
FOOT_LOCK=${FOOT_LOCK:-off}
GRID=${GRID:-0 0,0.9 0,0.95 0,0.95 4,0.98 4}  # the grid stage's "RHO RAMP" settings, comma-separated
STAGES=("$@"); [ ${#STAGES[@]} -eq 0 ] && STAGES=(train export validation curve grid choose test test_default)
log() { echo "$(date -u +%FT%T) $*" | tee -a "$OUT/log.txt"; }
timed() {  # timed NAME COMMAND...: run, log the command and its wall time
  local name=$1; shift; local start; start=$(date +%s)
  "$@"; log "$name: $(( $(date +%s) - start )) s: $*"
}
with_sampling() {  # with_sampling FILE RHO RAMP: record the row-wide sampling in an evaluation JSON
  python - "$@" <<'PY'
import json, sys
path, rho, ramp = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
d = json.load(open(path)); d["sampling"] = {"noise_correlation": rho, "noise_ramp_steps": ramp}
json.dump(d, open(path, "w"), indent=1)
PY
}
for stage in "${STAGES[@]}"; do case $stage in
train)
  timed train bin/train --config "$CONFIG" --workdir "$RUN" --data "$DATA" --no-progress ;;
export)
  timed export bin/export --run "$RUN" --out "$MODEL" --check-data "$DATA" ;;
validation)
  [ -f $OUT/validation_paper.json ] || timed validation_paper bin/evaluate model --checkpoint "$MODEL" --data "$DATA" \
      --split validation --samples 10 --lengths 30,50 --noise-scales '' --json $OUT/validation_paper.json ;;
curve)
  python $HERE/summarise.py --metrics "$RUN/metrics.jsonl" \
      --evaluation $OUT/validation_paper.json --out $OUT/summary_validation.json > /dev/null
  python $HERE/curve_figure.py $OUT/summary_validation.json $OUT/validation_curve.png ;;
grid)
  IFS=, read -ra settings <<< "$GRID"
  for setting in "${settings[@]}"; do
    set -- $setting; out=$OUT/grid_rho$1_ramp$2.json
    [ -f "$out" ] && continue
    timed "grid rho $1 ramp $2" bin/evaluate model --checkpoint "$MODEL" --data "$DATA" --split validation --samples 10 \
        --lengths 30,50 --noise-correlation "$1" --noise-ramp "$2" --noise-scales 1.5,2,2.5,3 --json "$out"
    with_sampling "$out" "$1" "$2"
  done ;;
choose)
  python $HERE/choose_sampling.py $OUT/grid_rho*_ramp*.json --out $OUT/sampling_choice.json | tee $OUT/sampling_choice.txt
  read -r S R K < <(python -c "import json; c=json.load(open('$OUT/sampling_choice.json'))['chosen']; print(c['noise_scale'], c['noise_correlation'], c['noise_ramp_steps'])")
  timed export_sampling bin/export --run "$RUN" --out "$MODEL" --check-data "$DATA" --sampling "$S,$R,$K" \
      --sampling-note "chosen on the validation split" ;;
test)
  [ -f $OUT/test_paper_L10_30_50.json ] || timed test_paper bin/evaluate model --checkpoint "$MODEL" --data "$DATA" \
      --samples 10 --lengths 10,30,50 --noise-scales '' --foot-lock "$FOOT_LOCK" --json $OUT/test_paper_L10_30_50.json
  [ -f $OUT/test_official_L5_15_45.json ] || timed test_official bin/evaluate model --checkpoint "$MODEL" --data "$DATA" \
      --samples 10 --lengths 5,15,45 --noise-scales '' --json $OUT/test_official_L5_15_45.json ;;
test_default)
  read -r S R K < <(python -c "import json; c=json.load(open('$MODEL/model.json'))['sampling']; print(c['noise_scale'], c['noise_correlation'], c['noise_ramp_steps'])")
  [ -f $OUT/test_default_L10_30_50.json ] || timed test_default bin/evaluate model --checkpoint "$MODEL" --data "$DATA" \
      --samples 10 --lengths 10,30,50 --noise-scales "$S" --noise-correlation "$R" --noise-ramp "$K" \
      --json $OUT/test_default_L10_30_50.json ;;
*) echo "unknown stage $stage"; exit 2 ;;
esac; done
