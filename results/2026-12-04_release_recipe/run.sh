#!/usr/bin/env bash
# The release model from one command, then everything measured of it. Stages (each resumable: a finished
# output is kept):
#   train      bin/train --config lafan1_cpu_release (20000 steps from scratch)
#   export     the float16 release folder, precision-checked
#   validation the validation split at the paper's sampling, and the sampling grid the default is chosen on
#   choose     the default sampling (choose_sampling.py), exported into model.json
#   test       the subject5 test table: paper sampling at L = 10, 30, 50 (diversity protocol) and 5, 15, 45
#              (official protocol), the default sampling at L = 10, 30, 50
#   DATA=/path/to/lafan1 RUNS=/path/to/runs bash results/2026-12-04_release_recipe/run.sh [STAGE ...]
set -euo pipefail
cd "$(dirname "$0")/../.."
HERE=results/2026-12-04_release_recipe
DATA=${DATA:?set DATA to the LAFAN1 folder}
RUNS=${RUNS:?set RUNS to a folder for the run}
RUN=$RUNS/release20k
MODEL=stitchjax/pretrained/lafan1_cpu_release
STAGES=("$@"); [ ${#STAGES[@]} -eq 0 ] && STAGES=(train export validation choose test)
log() { echo "$(date -u +%FT%T) $*" | tee -a "$HERE/log.txt"; }
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
  timed train bin/train --config lafan1_cpu_release --workdir "$RUN" --data "$DATA" --no-progress ;;
export)
  timed export bin/export --run "$RUN" --out "$MODEL" --check-data "$DATA" ;;
validation)
  [ -f $HERE/validation_paper.json ] || timed validation_paper bin/evaluate model --checkpoint "$MODEL" --data "$DATA" \
      --split validation --samples 10 --lengths 30,50 --noise-scales '' --json $HERE/validation_paper.json
  for setting in "0 0" "0.9 0" "0.95 0" "0.95 4" "0.98 4"; do
    set -- $setting; out=$HERE/grid_rho$1_ramp$2.json
    [ -f "$out" ] && continue
    timed "grid rho $1 ramp $2" bin/evaluate model --checkpoint "$MODEL" --data "$DATA" --split validation --samples 10 \
        --lengths 30,50 --noise-correlation "$1" --noise-ramp "$2" --noise-scales 1.5,2,2.5,3 --json "$out"
    with_sampling "$out" "$1" "$2"
  done ;;
choose)
  python $HERE/choose_sampling.py $HERE/grid_rho*_ramp*.json --out $HERE/sampling_choice.json | tee $HERE/sampling_choice.txt
  read -r S R K < <(python -c "import json; c=json.load(open('$HERE/sampling_choice.json'))['chosen']; print(c['noise_scale'], c['noise_correlation'], c['noise_ramp_steps'])")
  timed export_sampling bin/export --run "$RUN" --out "$MODEL" --check-data "$DATA" --sampling "$S,$R,$K" \
      --sampling-note "chosen on the validation split: results/2026-12-04_release_recipe/sampling_choice.json" ;;
test)
  read -r S R K < <(python -c "import json; c=json.load(open('$MODEL/model.json'))['sampling']; print(c['noise_scale'], c['noise_correlation'], c['noise_ramp_steps'])")
  [ -f $HERE/test_paper_L10_30_50.json ] || timed test_paper bin/evaluate model --checkpoint "$MODEL" --data "$DATA" \
      --samples 10 --lengths 10,30,50 --noise-scales '' --json $HERE/test_paper_L10_30_50.json
  [ -f $HERE/test_default_L10_30_50.json ] || timed test_default bin/evaluate model --checkpoint "$MODEL" --data "$DATA" \
      --samples 10 --lengths 10,30,50 --noise-scales "$S" --noise-correlation "$R" --noise-ramp "$K" \
      --json $HERE/test_default_L10_30_50.json
  [ -f $HERE/test_official_L5_15_45.json ] || timed test_official bin/evaluate model --checkpoint "$MODEL" --data "$DATA" \
      --samples 10 --lengths 5,15,45 --noise-scales '' --json $HERE/test_official_L5_15_45.json ;;
*) echo "unknown stage $stage"; exit 2 ;;
esac; done
