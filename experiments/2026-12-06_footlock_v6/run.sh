#!/usr/bin/env bash
# Foot locking version 6: the jump guard and a faster correction limit, chosen on non-test windows (the
# validation split at L = 10, 15, 30 and 50, and an artefact set of training takes for joint jumps), then the
# subject5 test windows once.
#   bash experiments/2026-12-06_footlock_v6/run.sh grid|artefacts|choose|default_sampling|test|benchmark|hover   (from the repository root)
# DATA: the LAFAN1 folder (default ../shared/data/lafan1); CACHE: where the validation transitions are kept.
set -euo pipefail
HERE=experiments/2026-12-06_footlock_v6
DATA=${DATA:-../shared/data/lafan1}
CACHE=${CACHE:-/tmp/footlock_v6_validation.npz}
case "${1:-}" in
  grid)    # the release model's transitions on the 376 validation windows, every candidate scored on them (the
           # second list was added after the first choice, see choose.py)
    python experiments/2026-12-06_footlock_v6/tune.py --data "$DATA" --cache "$CACHE" --lengths 10,15,30,50 \
      --variants "$(cat $HERE/candidates.json)" --json $HERE/validation_grid.json
    python experiments/2026-12-06_footlock_v6/tune.py --data "$DATA" --cache "$CACHE" --lengths 10,15,30,50 \
      --variants "$(cat $HERE/candidates_second.json)" --json $HERE/validation_grid_second.json ;;
  artefacts)  # the largest joint jumps of every candidate on the artefact set (training takes)
    python $HERE/jumps.py --data "$DATA" --cache "${CACHE%.npz}_artefacts.npz" --candidates $HERE/candidates.json \
      --json $HERE/artefact_jumps.json
    python $HERE/jumps.py --data "$DATA" --cache "${CACHE%.npz}_artefacts.npz" --candidates $HERE/candidates_second.json \
      --json $HERE/artefact_jumps_second.json ;;
  choose)  # the rule of choose.py, over both candidate lists
    python $HERE/choose.py --data "$DATA" --validation $HERE/validation_grid.json $HERE/validation_grid_second.json \
      --artefacts $HERE/artefact_jumps.json $HERE/artefact_jumps_second.json \
      --default-cache "${CACHE%.npz}_default_sampling.npz" --json $HERE/choice.json ;;
  default_sampling)  # the package's defaults (the choice) at the release model's default sampling, validation
    python experiments/2026-12-06_footlock_v6/tune.py --data "$DATA" --cache "${CACHE%.npz}_default_sampling.npz" \
      --lengths 10,15,30,50 --sampling '{"noise_scale": 2.0, "noise_correlation": 0.95, "noise_ramp_steps": 4}' \
      --variants '{"chosen": {}}' --json $HERE/validation_default_sampling.json ;;
  test)    # the package's defaults (the choice) on the 376 subject5 test windows, every length, read once
    python experiments/2026-12-06_footlock_v6/measure.py --data "$DATA" --windows test --json $HERE/test_subject5.json ;;
  hover)   # how often a foot is left hovering, validation, the defaults (needs the grid's cache)
    python experiments/2026-12-06_footlock_v6/hover.py --data "$DATA" --cache "$CACHE" --json $HERE/hover_validation.json ;;
  benchmark)  # the pass's time against sampling's, 64 transitions of 50 frames
    python benchmarks/footlock.py --runs 5 --json $HERE/benchmark_cpu.json ;;
  *) echo "usage: $0 grid|artefacts|choose|default_sampling|test|benchmark|hover" >&2; exit 2 ;;
esac
