"""Ablation (paper Table 4): no phase modulation: plain MLP decoder, no phase network.

The lafan1 reference config with exactly one field changed: model.phase_modulation = False.
"""
import dataclasses
import pathlib

from stitchjax.config import Config, load_config


def get_config() -> Config:
    base = load_config(str(pathlib.Path(__file__).with_name("lafan1.py")))
    model = dataclasses.replace(base.model, phase_modulation=False)
    return dataclasses.replace(base, name="ablate_no_phase", model=model)
