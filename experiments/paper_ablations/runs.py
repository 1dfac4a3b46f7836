"""The runs of the study, one line each: NAME, CONFIG, then the overrides of its one command.

    python experiments/paper_ablations/runs.py            # the LAFAN1 runs (Table 4), in training order
    python experiments/paper_ablations/runs.py --h36m     # the Human3.6M run (Table 3)

The base (configs/paper_cpu.py) once per seed of its SEEDS, then each entry of its ABLATIONS from the first seed:
every run has the same steps and schedule, and differs from the base run of its seed in one field.
"""
from __future__ import annotations

import argparse
import importlib.util
import pathlib

REPO = pathlib.Path(__file__).resolve().parents[2]


def registry():
    """configs/paper_cpu.py as a module (its ABLATIONS and SEEDS)."""
    spec = importlib.util.spec_from_file_location("paper_cpu_registry", REPO / "configs" / "paper_cpu.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def lafan1_runs() -> list:
    """[(name, label, config, [overrides])]: the base per seed, then every ablation."""
    module = registry()
    first, *others = module.SEEDS
    runs = [("base", "Ours (base)", "paper_cpu", [])]
    runs += [(f"base_seed{seed}", f"Ours (base, seed {seed})", "paper_cpu", [f"train.seed={seed}"]) for seed in others]
    runs += [(name, label, "paper_cpu", [override, f"name=paper_cpu_{name}"])
             for name, (label, override) in module.ABLATIONS.items()]
    return runs


def h36m_runs() -> list:
    return [("h36m", "Ours (Human3.6M)", "h36m_cpu", [])]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--h36m", action="store_true", help="the Human3.6M run instead of the LAFAN1 runs")
    args = parser.parse_args()
    for name, _, config, overrides in (h36m_runs() if args.h36m else lafan1_runs()):
        print("\t".join([name, config, *overrides]))


if __name__ == "__main__":
    main()
