#!/usr/bin/env bash
# Foot locking's defaults (version 6, chosen on the 25000-step model: experiments/2026-12-06_footlock_v6) checked on
# the 64000-step release model by version 6's rule, on non-test windows only, with its scripts:
#   validation  tune.py: the validation split at L = 10, 15, 30, 50, the paper's sampling (costs, slide, jumps, knees)
#   default     tune.py: the same at the release model's default sampling (its model.json), cached for choose
#   artefacts   jumps.py: the artefact set of training takes, the paper's and the default sampling
#   choose      choose.py: version 6's six rules on the one candidate, the defaults
#   hover       hover.py: how often a foot is left hovering, validation, the paper's sampling
#   grid        tune.py: version 6's 15 candidates (its candidates.json and candidates_second.json) on the
#               validation split's transitions (CACHE, shared with the validation stage; sampled when missing)
#   grid_artefacts  jumps.py: the same candidates on the artefact set, both samplings
#   grid_choose     choose.py: version 6's rule over them (grid_choice.json)
#   bash experiments/2026-12-07_footlock_64k/run.sh [STAGE ...]   (from the repository root)
# DATA: the LAFAN1 folder (default ../shared/data/lafan1); CACHE: where the transitions are kept.
set -euo pipefail
HERE=experiments/2026-12-07_footlock_64k
V6=experiments/2026-12-06_footlock_v6
DATA=${DATA:-../shared/data/lafan1}
CACHE=${CACHE:-/tmp/footlock_64k_validation.npz}
DEFAULT=$(python -c "import json; s=json.load(open('stitchjax/pretrained/lafan1_cpu_release/model.json'))['sampling']; print(json.dumps({k: s[k] for k in ('noise_scale', 'noise_correlation', 'noise_ramp_steps')}))")
log() { echo "$(date -u +%FT%T) $*" | tee -a "$HERE/log.txt"; }
timed() { local name=$1; shift; local start; start=$(date +%s); "$@"; log "$name: $(( $(date +%s) - start )) s: $* (commit $(git rev-parse --short HEAD))"; }
tune() {  # tune NAME CANDIDATES OUT [tune.py args]: the candidates on the validation split at L = 10, 15, 30, 50
  local name=$1 candidates=$2 out=$3; shift 3
  timed "$name" python $V6/tune.py --data "$DATA" --lengths 10,15,30,50 \
      --variants "$(cat "$candidates")" --json "$out" "$@"
}
jumps() {  # jumps NAME CANDIDATES OUT: the candidates on the artefact set, the paper's and the default sampling
  timed "$1" python $V6/jumps.py --data "$DATA" --cache "${CACHE%.npz}_artefacts.npz" --candidates "$2" \
      --default-sampling "$DEFAULT" --json "$3"
}
STAGES=("$@"); [ ${#STAGES[@]} -eq 0 ] && STAGES=(validation default artefacts choose hover)
for stage in "${STAGES[@]}"; do case $stage in
  validation) tune validation $HERE/candidates.json $HERE/validation.json --cache "$CACHE" ;;
  default) tune default $HERE/candidates.json $HERE/validation_default_sampling.json \
      --cache "${CACHE%.npz}_default_sampling.npz" --sampling "$DEFAULT" ;;
  artefacts) jumps artefacts $HERE/candidates.json $HERE/artefact_jumps.json ;;
  choose) timed choose python $V6/choose.py --data "$DATA" --validation $HERE/validation.json \
      --artefacts $HERE/artefact_jumps.json --default-cache "${CACHE%.npz}_default_sampling.npz" --json $HERE/choice.json ;;
  grid) for list in candidates candidates_second; do
      tune "grid $list" $V6/$list.json $HERE/grid_$list.json --cache "$CACHE"
    done ;;
  grid_artefacts) for list in candidates candidates_second; do
      jumps "grid_artefacts $list" $V6/$list.json $HERE/grid_artefact_jumps_$list.json
    done ;;
  grid_choose) timed grid_choose python $V6/choose.py --data "$DATA" \
      --validation $HERE/grid_candidates.json $HERE/grid_candidates_second.json \
      --artefacts $HERE/grid_artefact_jumps_candidates.json $HERE/grid_artefact_jumps_candidates_second.json \
      --default-cache "${CACHE%.npz}_default_sampling.npz" --json $HERE/grid_choice.json ;;
  hover) timed hover python $V6/hover.py --data "$DATA" --cache "$CACHE" \
      --json $HERE/hover_validation.json ;;
  *) echo "usage: $0 [validation|default|artefacts|choose|hover|grid|grid_artefacts|grid_choose ...]" >&2; exit 2 ;;
esac; done
