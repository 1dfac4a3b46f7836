"""Do two checkouts compile to the same programs? The refactoring check behind "not slower".

    git worktree add /tmp/before <commit>
    python benchmarks/same_program.py --other /tmp/before            # this checkout against /tmp/before
    python benchmarks/same_program.py --other /tmp/before train.scan_remat=taped   # with config overrides

Compiles, in each checkout (one subprocess each), the lafan1_cpu train step at the full 52-frame window and
the sampler of 64 samples x 50 frames, and compares XLA's optimised HLO after removing what only names the
source: op metadata, the stack-frame tables, instruction numbering and the names of the Python functions.
Identical programs run at the same speed on the same machine, so a pure refactoring that prints "same" here
needs no timing run. Prints one line per program; exit status 0 when both are the same, 1 otherwise.
"""
from __future__ import annotations

import argparse
import hashlib
import pathlib
import re
import subprocess
import sys

REPO = pathlib.Path(__file__).resolve().parent.parent

_DUMP = r'''
import inspect, sys
sys.path.insert(0, sys.argv[1])
import jax, jax.numpy as jnp
from stitchjax import config as C, parallel
import os
if os.path.isdir(os.path.join(sys.argv[1], "stitchjax", "sample")):  # the stage subpackages
    from stitchjax.sample import inbetween
    from stitchjax.train import loop as train
    from stitchjax.sample.trained_model import random_model
else:  # before the stage subpackages
    from stitchjax import inbetween, train
    if os.path.exists(os.path.join(sys.argv[1], "stitchjax", "trained_model.py")):
        from stitchjax.trained_model import random_model
    else:  # checkouts from before the model-loading module
        random_model = inbetween.random_model
cfg = C.apply_overrides(C.load_config(sys.argv[1] + "/configs/lafan1_cpu.py"), sys.argv[4:])
mesh = parallel.make_mesh()
run = cfg
if "spec" in inspect.signature(train.make_train_step).parameters:  # the train step takes the run's TrainSpec
    from stitchjax import specs
    run = specs.train_spec(cfg)
update = train.make_train_step(run, mesh, 52).update
B, T, J = 32, 52, 22
C4 = getattr(cfg.data, "num_contacts", 4)  # checkouts since the contacts became features.NUM_CONTACTS: 4
shapes = {"rotations": (B, T, J, 4), "root_positions": (B, T, 3), "contacts": (B, T, 4),
          "offsets": (B, 1, J, 3), "global_positions": (B, T, J, 3), "phase": (B, T, 2 * C4)}
batch = {k: jax.ShapeDtypeStruct(s, jnp.float32) for k, s in shapes.items()}
step = update.lower(train.abstract_train_state(run, mesh), batch, jnp.int32(50)).compile().as_text()
model = random_model(cfg)
key = {"rotations": jnp.zeros((1, J, 4)), "root_position": jnp.zeros((1, 3)), "contacts": jnp.zeros((1, 4))}
spec = getattr(model, "rollout_spec", cfg)  # checkouts before the rollout took a spec: the Config
sampler = inbetween._compiled_sampler(spec, 50, 64, 1.0).lower(
    model.params, model.phase_params, key, key, jnp.zeros((1, J, 3)), jax.random.PRNGKey(0)).compile().as_text()
open(sys.argv[2], "w").write(step)
open(sys.argv[3], "w").write(sampler)
'''


def normalised(text: str, function_names: tuple) -> list:
    """The HLO lines without source names: metadata, frame tables, numbering, Python function names."""
    text = re.sub(r", metadata=\{[^}]*\}", "", text)
    for name in function_names:
        text = text.replace(name, "fn")
    lines = []
    for line in text.splitlines():
        if line.startswith("HloModule") or re.match(r'^\d+ ("|\{)', line) or "file_location_id" in line:
            continue
        lines.append(re.sub(r"\.\d+", "", line))
    return sorted(lines)


def dump(checkout: pathlib.Path, folder: pathlib.Path, tag: str, overrides: tuple = ()) -> tuple:
    paths = (folder / f"{tag}_step.txt", folder / f"{tag}_sampler.txt")
    proc = subprocess.run([sys.executable, "-c", _DUMP, str(checkout), *map(str, paths), *overrides],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"same_program: error: compiling in {checkout} failed: {proc.stderr.strip()[-600:]}")
    return tuple(p.read_text() for p in paths)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="same_program", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--other", required=True, help="the other checkout (e.g. a git worktree of the old commit)")
    parser.add_argument("--names", default="generator_loss,generator_rollouts",
                        help="Python function names that may differ between the checkouts (comma separated)")
    parser.add_argument("overrides", nargs="*",
                        help="config overrides on lafan1_cpu for both checkouts, e.g. train.scan_remat=taped")
    args = parser.parse_args(argv)
    other = pathlib.Path(args.other).resolve()
    if not (other / "stitchjax").is_dir():
        parser.error(f"--other {other}: not a stitchjax checkout (no stitchjax/ folder)")
    import tempfile

    names = tuple(n for n in args.names.split(",") if n)
    with tempfile.TemporaryDirectory() as tmp:
        ours = dump(REPO, pathlib.Path(tmp), "this", tuple(args.overrides))
        theirs = dump(other, pathlib.Path(tmp), "other", tuple(args.overrides))
    same = True
    for program, a, b in zip(("train step (lafan1_cpu, window 52, batch 32)", "sampler (64 x 50 frames)"),
                             ours, theirs):
        na, nb = normalised(a, names), normalised(b, names)
        equal = na == nb
        same &= equal
        digest = hashlib.sha256("\n".join(na).encode()).hexdigest()[:12]
        print(f"{program}: {'same' if equal else 'DIFFERENT'} optimised HLO ({len(na)} lines, {digest})")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
