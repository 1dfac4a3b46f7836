#!/usr/bin/env bash
# The second release recipe (lafan1_cpu_release_v2.py here: the release recipe without the foot-skate term and
# contact gradients) from one command, then everything measured of it. Stages (each resumable: a finished output is kept):
#   train      bin/train --config $HERE/lafan1_cpu_release_v2.py (20000 steps from scratch)
#   curve      the run's validation curve (summary_validation.json, validation_curve.png)
#   export     the float16 model folder, precision-checked, into $RUNS/release_v2_model (a candidate)
#   validation the validation split at the paper's sampling, and the sampling grid the default is chosen on
#   choose     the default sampling (the first recipe's choose_sampling.py, same margin), exported into the candidate
#   compare    compare.py: does the candidate replace the first release model? (validation figures only)
#   test       the subject5 test table of the candidate: paper sampling at L = 10, 30, 50 (with and without foot
#              locking) and 5, 15, 45, the
#              default sampling at L = 10, 30, 50 (read only after every choice above)
#   release    copy the candidate into stitchjax/pretrained/lafan1_cpu_release when compare said so
#   DATA=/path/to/lafan1 RUNS=/path/to/runs bash results/2026-12-05_release_v2/run.sh [STAGE ...]
set -euo pipefail
cd "$(dirname "$0")/../.."
HERE=results/2026-12-05_release_v2
V1=results/2026-12-04_release_recipe
DATA=${DATA:?set DATA to the LAFAN1 folder}
RUNS=${RUNS:?set RUNS to a folder for the run}
RUN=$RUNS/release_v2
MODEL=$RUNS/release_v2_model
STAGES=("$@"); [ ${#STAGES[@]} -eq 0 ] && STAGES=(train curve export validation choose compare test release)
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
  timed train bin/train --config $HERE/lafan1_cpu_release_v2.py --workdir "$RUN" --data "$DATA" --no-progress ;;
curve)
  python results/2026-12-04_release_run/summarise.py --metrics "$RUN/metrics.jsonl" \
      --evaluation $HERE/validation_paper.json --out $HERE/summary_validation.json > /dev/null
  python $V1/curve_figure.py $HERE/summary_validation.json $HERE/validation_curve.png ;;
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
  python $V1/choose_sampling.py $HERE/grid_rho*_ramp*.json --out $HERE/sampling_choice.json | tee $HERE/sampling_choice.txt
  read -r S R K < <(python -c "import json; c=json.load(open('$HERE/sampling_choice.json'))['chosen']; print(c['noise_scale'], c['noise_correlation'], c['noise_ramp_steps'])")
  timed export_sampling bin/export --run "$RUN" --out "$MODEL" --check-data "$DATA" --sampling "$S,$R,$K" \
      --sampling-note "chosen on the validation split: results/2026-12-05_release_v2/sampling_choice.json" ;;
compare)
  python $HERE/compare.py $V1/validation_paper.json $HERE/validation_paper.json --out $HERE/decision.json ;;
test)
  read -r S R K < <(python -c "import json; c=json.load(open('$MODEL/model.json'))['sampling']; print(c['noise_scale'], c['noise_correlation'], c['noise_ramp_steps'])")
  [ -f $HERE/test_paper_L10_30_50.json ] || timed test_paper bin/evaluate model --checkpoint "$MODEL" --data "$DATA" \
      --samples 10 --lengths 10,30,50 --noise-scales '' --foot-lock both --json $HERE/test_paper_L10_30_50.json
  [ -f $HERE/test_default_L10_30_50.json ] || timed test_default bin/evaluate model --checkpoint "$MODEL" --data "$DATA" \
      --samples 10 --lengths 10,30,50 --noise-scales "$S" --noise-correlation "$R" --noise-ramp "$K" \
      --json $HERE/test_default_L10_30_50.json
  [ -f $HERE/test_official_L5_15_45.json ] || timed test_official bin/evaluate model --checkpoint "$MODEL" --data "$DATA" \
      --samples 10 --lengths 5,15,45 --noise-scales '' --json $HERE/test_official_L5_15_45.json ;;
release)
  if python -c "import json, sys; sys.exit(0 if json.load(open('$HERE/decision.json'))['replace'] else 1)"; then
    cp "$MODEL/model.json" "$MODEL/params.msgpack" stitchjax/pretrained/lafan1_cpu_release/
    log "release: $MODEL copied into stitchjax/pretrained/lafan1_cpu_release"
  else
    log "release: the first release model stays (decision.json)"
  fi ;;
*) echo "unknown stage $stage"; exit 2 ;;
esac; done
