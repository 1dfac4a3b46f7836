#!/usr/bin/env bash
# The commands that wrote benchmarks/results (from the repository root); figures in benchmarks/README.md.
# Usage: bash benchmarks/results/run.sh full|quick|quick_idle|quick_zen3
set -euo pipefail
OUT=benchmarks/results
case "${1:-}" in
  full)  # all repetitions of the train and infer sections (the scale sections: --only); the eager twin at the
    # faster thread setting only (the machine was shared: 2 threads took 20x longer than 1)
    nice -n 10 python benchmarks/run_all.py --only train,infer --torch-threads faster --json "$OUT/run_all_train_infer.json"
    ;;
  quick)  # the headline figures in under 3 minutes (warm jax and inductor caches)
    time nice -n 10 python benchmarks/run_all.py --quick --json "$OUT/run_all_quick.json"
    ;;
  quick_idle)  # the same on the idle machine (nothing else running)
    time python benchmarks/run_all.py --quick --json "$OUT/run_all_quick_idle.json"
    ;;
  quick_zen3)  # the same on the idle Zen 3 machine (no bfloat16 units): once with cold caches, then timed warm
    python benchmarks/run_all.py --quick --json /tmp/run_all_quick_cold.json
    time python benchmarks/run_all.py --quick --json "$OUT/run_all_quick_zen3.json"
    ;;
  *)
    echo "usage: $0 full|quick|quick_idle|quick_zen3" >&2
    exit 2
    ;;
esac
