#!/usr/bin/env bash
# Foot locking version 5: lifts out of the ground, a lower clearance next to keyframes, a jump guard; the
# settings chosen on the validation split at L = 10, 15, 30 and 50, then the subject5 test windows once.
#   bash results/2026-12-06_footlock_v5/run.sh grid|choose|default_sampling|test|benchmark|hover|grid_first   (from the repository root)
# DATA: the LAFAN1 folder (default ../shared/data/lafan1); CACHE: where the validation transitions are kept.
# default_sampling, test, benchmark and hover measure the package's defaults of the checkout: version 5's are
# those of `git checkout 1a3cbb1` (version 6 changed correction_step, jump_guard and jump_floor).
set -euo pipefail
HERE=results/2026-12-06_footlock_v5
DATA=${DATA:-../shared/data/lafan1}
CACHE=${CACHE:-/tmp/footlock_v5_validation.npz}
case "${1:-}" in
  grid)    # the release model's transitions on the 376 validation windows, every candidate scored on them
    python results/2026-12-04_footlock/tune.py --data "$DATA" --cache "$CACHE" --lengths 10,15,30,50 \
      --variants "$(cat $HERE/candidates.json)" --json $HERE/validation_grid.json ;;
  grid_first)  # the first grid, before max_lift (its choice made a 52 cm knee jump at the default sampling)
    python results/2026-12-04_footlock/tune.py --data "$DATA" --cache "$CACHE" --lengths 10,15,30,50 \
      --variants "$(cat $HERE/candidates_first.json)" --json $HERE/validation_grid_first.json
    python $HERE/choose.py --data "$DATA" --validation $HERE/validation_grid_first.json --candidates $HERE/candidates_first.json \
      --default-cache "${CACHE%.npz}_default_sampling.npz" --json $HERE/choice_first.json ;;
  choose)  # the rule of choose.py
    python $HERE/choose.py --data "$DATA" --validation $HERE/validation_grid.json --default-cache "${CACHE%.npz}_default_sampling.npz" \
      --json $HERE/choice.json ;;
  default_sampling)  # the package's defaults (the choice) at the release model's default sampling, validation
    python results/2026-12-04_footlock/tune.py --data "$DATA" --cache "${CACHE%.npz}_default_sampling.npz" \
      --lengths 10,15,30,50 --sampling '{"noise_scale": 2.0, "noise_correlation": 0.95, "noise_ramp_steps": 4}' \
      --variants '{"chosen": {}}' --json $HERE/validation_default_sampling.json ;;
  test)    # the package's defaults (the choice) on the 376 subject5 test windows, every length, read once
    python results/2026-12-04_footlock/measure.py --data "$DATA" --windows test --json $HERE/test_subject5.json ;;
  hover)   # how often a foot is left hovering, validation, the defaults and version 4 (needs the grid's cache)
    python $HERE/hover.py --data "$DATA" --cache "$CACHE" --json $HERE/hover_validation.json
    python $HERE/hover.py --data "$DATA" --cache "$CACHE" --fields "$(python -c "import json; print(json.dumps(json.load(open('$HERE/candidates.json'))['v4']))")" \
      --json $HERE/hover_validation_v4.json ;;
  benchmark)  # the pass's time against sampling's, 64 transitions of 50 frames
    python benchmarks/footlock.py --runs 5 --json $HERE/benchmark_cpu.json ;;
  *) echo "usage: $0 grid|choose|default_sampling|test|benchmark|hover|grid_first" >&2; exit 2 ;;
esac
