#!/usr/bin/env bash
# The release studies' stages (first written for the 25000-step recipe, 2026-12-05_release_25k): a release
# recipe's run, then what is measured of it. The stages train, export, validation, curve, grid, choose, test and
# test_default are recipe_stages.sh's, writing to HERE; the test stage scores L = 10, 30, 50 with and without
# foot locking. The stages of this script:
#   compare  compare.py: does it replace the release model? (validation figures only, against BASELINE)
#   grid     the sampling grid on the validation split, one family (noise correlation 0.95, ramp 4), and the
#            paper's sampling (validation_paper.json) as a candidate
#   release  export it into stitchjax/pretrained/lafan1_cpu_release, named lafan1_cpu_release (the config it
#            equals), with the default sampling the choose stage picked
#   picture  the README picture and its spread (picture.py)
#   curve    the recipe's, then CUMULATIVE (the run was trained in parts)
# A study's run.sh sets HERE (its folder), CUMULATIVE (the curve stage's script), CONFIG, RUN, MODEL, BASELINE
# (the release model's validation_paper.json that compare holds it against) and GATED (the stages that run
# only when compare said replace); run.sh in this folder does.
#   DATA=/path/to/lafan1 RUNS=/path/to/runs bash experiments/2026-12-07_release_64k/run.sh [STAGE ...]
set -euo pipefail
cd "$(dirname "$0")/../.."
TOOLS=experiments/2026-12-07_release_64k  # the scripts of the stages
HERE=${HERE:?set HERE to the study's folder}
RUNS=${RUNS:?set RUNS to a folder for the run}
BASELINE=${BASELINE:?set BASELINE to the release model's validation_paper.json}
export OUT=$HERE CONFIG=${CONFIG:?set CONFIG} RUN=${RUN:?set RUN} \
    MODEL=${MODEL:?set MODEL} FOOT_LOCK=both
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
  bash $TOOLS/recipe_stages.sh curve
  python "${CUMULATIVE:-$TOOLS/cumulative_time.py}" $HERE/summary_validation.json ;;
compare)
  python $TOOLS/compare.py "$BASELINE" $HERE/validation_paper.json --out $HERE/decision.json ;;
grid)  # the recipe's grid stage on one family
  GRID="0.95 4" bash $TOOLS/recipe_stages.sh grid
  # the paper's sampling is a candidate too (in the release recipe's grid it was the x1 row of "rho 0, ramp 0"),
  # and choose_sampling.py's fallback rule compares foot slide with it
  python -c "import json; d=json.load(open('$HERE/validation_paper.json')); d['sampling']={'noise_correlation': 0.0, 'noise_ramp_steps': 0}; json.dump(d, open('$HERE/grid_rho0_ramp0_paper_only.json', 'w'), indent=1)" ;;
release)
  read -r S R K < <(python -c "import json; c=json.load(open('$MODEL/model.json'))['sampling']; print(c['noise_scale'], c['noise_correlation'], c['noise_ramp_steps'])")
  bin/export --run "$RUN" --out stitchjax/pretrained/lafan1_cpu_release --check-data "$DATA" --config-name lafan1_cpu_release \
      --sampling "$S,$R,$K" --sampling-note "chosen on the validation split"
  log "release: bin/export --run $RUN --out stitchjax/pretrained/lafan1_cpu_release --config-name lafan1_cpu_release --sampling $S,$R,$K" ;;
picture)
  python $TOOLS/picture.py --out $HERE/picture_spread.json --figure docs/images/samples.png ;;
*) bash $TOOLS/recipe_stages.sh "$stage" ;;
esac; done
