#!/usr/bin/env bash
# Same training: two checkouts train the same config for a few steps; every logged metric must be equal, float for
# float (the counterpart of sample_check.py for the train step, where benchmarks/same_program.py finds the
# optimised programs different but the change should alter no number).
#   bash experiments/same_samples/same_training.sh BEFORE_CHECKOUT AFTER_CHECKOUT [CONFIG ...]
# CONFIG default: lafan1_cpu lafan1_cpu_release; DATA: the LAFAN1 folder (default ../shared/data/lafan1); STEPS: 12.
set -euo pipefail
before=$(cd "$1" && pwd); after=$(cd "$2" && pwd); shift 2
DATA=$(cd "${DATA:-../shared/data/lafan1}" && pwd)
STEPS=${STEPS:-12}
work=$(mktemp -d)
for config in "${@:-lafan1_cpu lafan1_cpu_release}"; do for c in $config; do
  for side in before after; do
    repo=${!side}
    (cd "$repo" && PYTHONPATH="$repo" STITCHJAX_CACHE_DIR="$work/cache_$side" python bin/train --config "$c" \
      --data "$DATA" --workdir "$work/${c}_$side" --max-steps "$STEPS" --no-progress train.log_every=1 \
      train.eval_every=0 > "$work/${c}_$side.log" 2>&1)
  done
  python - "$work/${c}_before/metrics.jsonl" "$work/${c}_after/metrics.jsonl" "$c" <<'PY'
import json, sys
a, b = ([json.loads(line) for line in open(path)] for path in sys.argv[1:3])
timing = {"time_s", "windows_per_s"}
diff = [(r["step"], k) for r, s in zip(a, b) for k in r.keys() | s.keys() if k not in timing and r.get(k) != s.get(k)]
print(f"{sys.argv[3]}: {len(a)} / {len(b)} logged steps, {len(diff)} differing values {diff[:8]}")
sys.exit(1 if diff or len(a) != len(b) else 0)
PY
done; done
