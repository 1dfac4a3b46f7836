#!/usr/bin/env bash
# The release recipe at 40000 steps (lafan1_cpu_release_40k.py here), trained across stops: run the train stage
# again with the same RUNS to resume. The stages train, export, validation, test, test_default and choose are the
# release recipe's (results/2026-12-04_release_recipe/run.sh), writing here. This study's own stages:
#   curve    the recipe's, then cumulative_time.py (bin/train's time_s restarts at 0 on each resume)
#   compare  the rule of the README (the 25000-step study's compare.py against the release model's validation
#            figures)
#   grid     the sampling grid on the validation split (noise correlation 0.95, ramp 4) and the paper's
#            sampling as a candidate, as in the 25000-step study
#   release  export it into stitchjax/pretrained/lafan1_cpu_release with the default sampling choose picked
#   picture  the README picture and its spread (the 25000-step study's picture.py)
# test, grid, choose, test_default, release and picture run only when compare said replace.
#   DATA=/path/to/lafan1 RUNS=/path/to/runs bash results/2026-12-06_release_40k/run.sh [STAGE ...]
set -euo pipefail
cd "$(dirname "$0")/../.."
HERE=results/2026-12-06_release_40k
RUNS=${RUNS:?set RUNS to a folder for the run}
export OUT=$HERE CONFIG=$HERE/lafan1_cpu_release_40k.py RUN=$RUNS/release_40k MODEL=$RUNS/release_40k_model FOOT_LOCK=both
STAGES=("$@"); [ ${#STAGES[@]} -eq 0 ] && STAGES=(train export validation curve compare test grid choose test_default release picture)
log() { echo "$(date -u +%FT%T) $*" | tee -a "$HERE/log.txt"; }
replace() { python -c "import json, sys; sys.exit(0 if json.load(open('$HERE/decision.json'))['replace'] else 1)"; }
for stage in "${STAGES[@]}"; do
case $stage in test|grid|choose|test_default|release|picture)
  replace || { log "$stage: skipped, the release model stays (decision.json)"; continue; } ;; esac
case $stage in
curve)
  bash results/2026-12-04_release_recipe/run.sh curve
  python $HERE/cumulative_time.py $HERE/summary_validation.json ;;
compare)
  python results/2026-12-05_release_v2/compare.py results/2026-12-05_release_25k/validation_paper.json \
      $HERE/validation_paper.json --out $HERE/decision.json ;;
grid)
  GRID="0.95 4" bash results/2026-12-04_release_recipe/run.sh grid
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
