#!/usr/bin/env bash
# The paper's Table 4 (ablations, LAFAN1) and Table 3 (Human3.6M) at CPU scale, from one command. Every stage is
# resumable: a finished run or output is skipped, an interrupted training run resumes from its newest checkpoint.
#
#   DATA=/path/to/lafan1 H36M=/path/to/h36m RUNS=/path/to/runs bash experiments/paper_ablations/run.sh [STAGE ...]
#
# Stages (default: all, in this order):
#   train       bin/train each LAFAN1 run of runs.py in turn (the base from two seeds, then each ablation)
#   validation  bin/evaluate each trained run on the validation split (L = 30, 50; 10 samples; direction ends)
#   test        the same on the 376 subject5 test windows, once, after every validation figure exists
#   table4      tables.py table4: table4.md / table4.json from the two
#   h36m        bin/train the Human3.6M run, then bin/evaluate it on S9 and S11 at L = 50 beside Slerp and zero
#               velocity
#   table3      tables.py table3: table3.md / table3.json
# ONLY="base no_phase" restricts train, validation and test to those runs.
set -euo pipefail
cd "$(dirname "$0")/../.."
HERE=experiments/paper_ablations
DATA=${DATA:?set DATA to the LAFAN1 folder (e.g. ../shared/data/lafan1)}
RUNS=${RUNS:?set RUNS to a folder for the training runs}
H36M=${H36M:-$(dirname "$DATA")/h36m}
ONLY=${ONLY:-}
mkdir -p "$HERE/eval" "$HERE/records"
STAGES=("$@"); [ ${#STAGES[@]} -eq 0 ] && STAGES=(train validation test table4 h36m table3)

log() { echo "$(date -u +%FT%T) $*" | tee -a "$HERE/log.txt"; }
wanted() { [ -z "$ONLY" ] || [[ " $ONLY " == *" $1 "* ]]; }
runs() { python $HERE/runs.py "$@"; }  # NAME CONFIG OVERRIDES..., one run a line (tab-separated)
final_step() {  # final_step CONFIG OVERRIDES...: the run's train.max_steps
  python - "$@" <<'PY'
import sys
from stitchjax import config as C
print(C.apply_overrides(C.load_config(sys.argv[1]), sys.argv[2:]).train.max_steps)
PY
}
record() {  # record NAME COMMAND START_S END_S: one training part of a run, appended to records/NAME.json
  python - "$@" "$RUNS" <<'PY'
import json, pathlib, platform, subprocess, sys, datetime
name, command, start, end, runs = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
path = pathlib.Path("experiments/paper_ablations/records") / f"{name}.json"
record = json.loads(path.read_text()) if path.exists() else {"run": name, "command": command, "parts": []}
metrics = pathlib.Path(runs) / "paper_ablations" / name / "metrics.jsonl"
rows = [json.loads(line) for line in metrics.read_text().splitlines() if line.strip()] if metrics.exists() else []
train_rows = [r for r in rows if "loss" in r]
cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".", ":!experiments/paper_ablations"], capture_output=True, text=True).stdout
record["parts"].append({
    "started_utc": datetime.datetime.fromtimestamp(start, datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%S"),
    "wall_s": end - start, "commit": commit + ("+changes" if dirty.strip() else ""),
    "machine": f"{cpu}, {subprocess.run(['nproc'], capture_output=True, text=True).stdout.strip()} cores, "
               f"{platform.platform()}, Python {platform.python_version()}",
    "last_step": train_rows[-1]["step"] if train_rows else None,
    "loop_s": train_rows[-1].get("time_s") if train_rows else None})
path.write_text(json.dumps(record, indent=1) + "\n")
PY
}
train_run() {  # train_run NAME CONFIG DATA OVERRIDES...: train (or resume) until train.max_steps, then skip
  local name=$1 config=$2 data=$3; shift 3
  local workdir=$RUNS/paper_ablations/$name steps; steps=$(final_step "$config" "$@")
  if [ -d "$workdir/checkpoints/$steps" ]; then log "train $name: done (step $steps)"; return; fi
  local command="bin/train --config $config --workdir $workdir --data $data --no-progress $*" start; start=$(date +%s)
  log "train $name: $command"
  mkdir -p "$workdir"
  local status=0
  bin/train --config "$config" --workdir "$workdir" --data "$data" --no-progress "$@" >> "$workdir.log" 2>&1 || status=$?
  record "$name" "$command" "$start" "$(date +%s)"
  log "train $name: $(( $(date +%s) - start )) s, exit status $status (log: $workdir.log)"
  [ "$status" -eq 0 ] || exit "$status"  # stopped (130 / 143: saved, run again to resume) or failed
}
evaluate_run() {  # evaluate_run NAME SPLIT: bin/evaluate of a finished run on the split, once
  local name=$1 split=$2 out=$HERE/eval/$1_$2.json
  [ -f "$out" ] && return
  local workdir=$RUNS/paper_ablations/$name steps
  steps=$(final_step paper_cpu)
  [ -d "$workdir/checkpoints/$steps" ] || { log "evaluate $name $split: not trained to step $steps yet, skipped"; return; }
  if [ "$split" = test ] && [ ! -f "$HERE/eval/${name}_validation.json" ]; then
    log "evaluate $name test: skipped, its validation figures come first"; return
  fi
  local start; start=$(date +%s)
  bin/evaluate model --checkpoint "$workdir" --data "$DATA" --split "$split" --samples 10 --lengths 30,50 \
      --noise-scales '' --direction-ends --json "$out" >> "$workdir.eval.log" 2>&1
  log "evaluate $name $split: $(( $(date +%s) - start )) s: bin/evaluate model --checkpoint $workdir --data $DATA --split $split --samples 10 --lengths 30,50 --noise-scales '' --direction-ends --json $out"
}

for stage in "${STAGES[@]}"; do case $stage in
train)
  while IFS=$'\t' read -r name config overrides; do
    wanted "$name" || continue
    # shellcheck disable=SC2086
    train_run "$name" "$config" "$DATA" $overrides
  done < <(runs) ;;
validation|test)
  while IFS=$'\t' read -r name _; do wanted "$name" && evaluate_run "$name" "$stage"; done < <(runs) ;;
table4)
  python $HERE/tables.py table4 --out $HERE/table4 ;;
h36m)
  while IFS=$'\t' read -r name config overrides; do
    # shellcheck disable=SC2086
    train_run "$name" "$config" "$H36M" $overrides
    out=$HERE/eval/${name}_test.json
    if [ ! -f "$out" ]; then
      start=$(date +%s)
      bin/evaluate model --checkpoint "$RUNS/paper_ablations/$name" --data "$H36M" --dataset h36m --samples 10 \
          --lengths 50 --noise-scales '' --direction-ends --json "$out" >> "$RUNS/paper_ablations/$name.eval.log" 2>&1
      log "evaluate $name test: $(( $(date +%s) - start )) s: bin/evaluate model --checkpoint $RUNS/paper_ablations/$name --data $H36M --dataset h36m --samples 10 --lengths 50 --noise-scales '' --direction-ends --json $out"
    fi
  done < <(runs --h36m) ;;
table3)
  python $HERE/tables.py table3 --out $HERE/table3 ;;
*) echo "unknown stage $stage (train, validation, test, table4, h36m, table3)"; exit 2 ;;
esac; done
