#!/usr/bin/env bash
# The commands that wrote benchmarks/results (from the repository root); figures in benchmarks/README.md.
# Usage: bash benchmarks/results/run.sh full|quick|quick_idle|quick_zen3|copies|quick_taped|full_taped
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
  copies)  # copies and stacking per call of the generator loss + grad (step_parts.py --profile), one checkout
    # after the other on the idle machine: the commit before the step-major probes (841979d^), the commit before
    # the taped scan (a06f3fd), then this checkout with train.scan_remat none and taped
    for pair in before_step_major:841979d^ before_taped:a06f3fd; do
      dir=$(mktemp -d)
      git worktree add --detach "$dir" "${pair#*:}" >/dev/null
      (cd "$dir" && PYTHONPATH="$dir" python benchmarks/step_parts.py --dtypes float32 --scan-remat none \
        --profile "$dir/trace") | tee "$OUT/copies_${pair%%:*}.txt"
      git worktree remove --force "$dir"
    done
    python benchmarks/step_parts.py --dtypes float32 --scan-remat none,taped --profile /tmp/copies_trace \
      | tee "$OUT/copies_taped.txt"
    ;;
  quick_taped)  # --quick with stitchjax's train step taped, then with the default, one after the other
    time python benchmarks/run_all.py --quick --scan-remat taped --json "$OUT/run_all_quick_taped.json"
    time python benchmarks/run_all.py --quick --json "$OUT/run_all_quick_none.json"
    ;;
  full_taped)  # all repetitions of train and infer on the idle machine, stitchjax's train step taped
    time python benchmarks/run_all.py --only train,infer --torch-threads faster --scan-remat taped \
      --json "$OUT/run_all_train_infer_taped.json"
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
