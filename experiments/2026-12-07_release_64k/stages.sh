#!/usr/bin/env bash
# The release recipe at 25000 steps (lafan1_cpu_release_25k.py here) from one command, then what was measured
# of it. The stages train, export, validation, curve, grid, choose, test and test_default are the release
# recipe's (results/2026-12-04_release_recipe/run.sh), writing here; the test stage scores L = 10, 30, 50 with
# and without foot locking. This study's own stages:
#   compare  results/2026-12-05_release_v2/compare.py: does it replace the release model? (the same rule as the
#            second recipe's, validation figures only)
#   grid     the sampling grid on the validation split, one family (noise correlation 0.95, ramp 4), and the
#            paper's sampling (validation_paper.json) as a candidate
#   release  export it into stitchjax/pretrained/lafan1_cpu_release, named lafan1_cpu_release (the config it
#            equals), with the default sampling the choose stage picked
#   picture  the README picture and its spread (picture.py)
#   curve    the recipe's, then cumulative_time.py (the run was trained in three parts)
# grid, choose, test_default, release and picture run only when compare said replace.
#   DATA=/path/to/lafan1 RUNS=/path/to/runs bash results/2026-12-05_release_25k/run.sh [STAGE ...]
# A later, longer run reuses these stages with HERE (its folder), CUMULATIVE (the curve stage's script, default
# $HERE/cumulative_time.py), CONFIG, RUN, MODEL
# and BASELINE (the release model's validation_paper.json that compare holds it against) set, and GATED (the
# stages that run only when compare said replace) if it differs: results/2026-12-06_release_40k/run.sh does.
set -euo pipefail
cd "$(dirname "$0")/../.."
HERE=${HERE:-results/2026-12-05_release_25k}
RUNS=${RUNS:?set RUNS to a folder for the run}
BASELINE=${BASELINE:-results/2026-12-04_release_recipe/validation_paper.json}
export OUT=$HERE CONFIG=${CONFIG:-$HERE/lafan1_cpu_release_25k.py} RUN=${RUN:-$RUNS/release_25k} \
    MODEL=${MODEL:-$RUNS/release_25k_model} FOOT_LOCK=both
GATED=${GATED:-grid choose test_default release picture}  # the stages that run only when compare said replace
STAGES=("$@"); [ ${#STAGES[@]} -eq 0 ] && STAGES=(train export validation curve compare test grid choose test_default release picture)
log() { echo "$(date -u +%FT%T) $*" | tee -a "$HERE/log.txt"; }
replace() { python -c "import json, sys; sys.exit(0 if json.load(open('$HERE/decision.json'))['replace'] else 1)"; }
for stage in "${STAGES[@]}"; do
if [[ " $GATED " == *" $stage "* ]]; then
  replace || { log "$stage: skipped, the release model stays (decision.json)"; continue; }
fi
case $stage in
curve)  # the recipe's curve, then its times made cumulative over the run's three parts
  bash results/2026-12-04_release_recipe/run.sh curve
  python "${CUMULATIVE:-$HERE/cumulative_time.py}" $HERE/summary_validation.json ;;
compare)
  python results/2026-12-05_release_v2/compare.py "$BASELINE" $HERE/validation_paper.json --out $HERE/decision.json ;;
grid)  # the recipe's grid stage on one family
  GRID="0.95 4" bash results/2026-12-04_release_recipe/run.sh grid
  # the paper's sampling is a candidate too (in the release recipe's grid it was the x1 row of "rho 0, ramp 0"),
  # and choose_sampling.py's fallback rule compares foot slide with it
  python -c "import json; d=json.load(open('$HERE/validation_paper.json')); d['sampling']={'noise_correlation': 0.0, 'noise_ramp_steps': 0}; json.dump(d, open('$HERE/grid_rho0_ramp0_paper_only.json', 'w'), indent=1)" ;;
release)
  read -r S R K < <(python -c "import json; c=json.load(open('$MODEL/model.json'))['sampling']; print(c['noise_scale'], c['noise_correlation'], c['noise_ramp_steps'])")
  bin/export --run "$RUN" --out stitchjax/pretrained/lafan1_cpu_release --check-data "$DATA" --config-name lafan1_cpu_release \
      --sampling "$S,$R,$K" --sampling-note "chosen on the validation split: $HERE/sampling_choice.json"
  log "release: bin/export --run $RUN --out stitchjax/pretrained/lafan1_cpu_release --config-name lafan1_cpu_release --sampling $S,$R,$K" ;;
picture)
  python results/2026-12-05_release_25k/picture.py --out $HERE/picture_spread.json --figure docs/images/samples.png ;;
*) bash results/2026-12-04_release_recipe/run.sh "$stage" ;;
esac; done
