#!/usr/bin/env bash
# Foot locking version 4: the settings chosen on the validation split, then the subject5 test windows once.
#   bash results/2026-12-06_footlock_v4/run.sh grid|choose|default_sampling|test      (from the repository root)
# DATA: the LAFAN1 folder (default ../shared/data/lafan1); CACHE: where the validation transitions are kept.
set -euo pipefail
HERE=results/2026-12-06_footlock_v4
DATA=${DATA:-../shared/data/lafan1}
CACHE=${CACHE:-/tmp/footlock_v4_validation.npz}
case "${1:-}" in
  grid)    # the release model's transitions on the 376 validation windows, every candidate scored on them
    python results/2026-12-04_footlock/tune.py --data "$DATA" --cache "$CACHE" \
      --variants "$(cat $HERE/candidates.json)" --json $HERE/validation_grid.json ;;
  choose)  # the rule of choose.py
    python $HERE/choose.py --data "$DATA" --validation $HERE/validation_grid.json --json $HERE/choice.json ;;
  default_sampling)  # the package's defaults (the choice) at the release model's default sampling, validation
    python results/2026-12-04_footlock/tune.py --data "$DATA" --cache "${CACHE%.npz}_default_sampling.npz" \
      --sampling '{"noise_scale": 2.0, "noise_correlation": 0.95, "noise_ramp_steps": 4}' \
      --variants '{"chosen": {}}' --json $HERE/validation_default_sampling.json ;;
  test)    # the package's defaults (the choice) on the 376 subject5 test windows, every length, read once
    python results/2026-12-04_footlock/measure.py --data "$DATA" --windows test --json $HERE/test_subject5.json ;;
  *) echo "usage: $0 grid|choose|default_sampling|test" >&2; exit 2 ;;
esac
