#!/usr/bin/env bash
# The release recipe at 40000 steps (lafan1_cpu_release_40k.py here), trained across stops: run the train stage
# again with the same RUNS to resume. The stages train, export, validation and curve are the release recipe's
# (results/2026-12-04_release_recipe/run.sh), writing here; compare applies the rule of the README (the
# 25000-step study's: results/2026-12-05_release_v2/compare.py against the release model's validation figures).
# The sampling grid, the test tables and the release export follow the 25000-step study's stages
# (results/2026-12-05_release_25k/run.sh) once compare says replace.
#   DATA=/path/to/lafan1 RUNS=/path/to/runs bash results/2026-12-06_release_40k/run.sh [STAGE ...]
set -euo pipefail
cd "$(dirname "$0")/../.."
HERE=results/2026-12-06_release_40k
RUNS=${RUNS:?set RUNS to a folder for the run}
export OUT=$HERE CONFIG=$HERE/lafan1_cpu_release_40k.py RUN=$RUNS/release_40k MODEL=$RUNS/release_40k_model
STAGES=("$@"); [ ${#STAGES[@]} -eq 0 ] && STAGES=(train export validation curve compare)
for stage in "${STAGES[@]}"; do case $stage in
compare)
  python results/2026-12-05_release_v2/compare.py results/2026-12-05_release_25k/validation_paper.json \
      $HERE/validation_paper.json --out $HERE/decision.json ;;
*) bash results/2026-12-04_release_recipe/run.sh "$stage" ;;
esac; done
