"""Ablation (paper Table 4): no bidirectional aligning: each generator targets the given end keyframe.

The lafan1 reference config with exactly one field changed: model.bidirectional_aligning = False.
"""
import dataclasses
import pathlib

from stitchjax.config import Config, load_config


def get_config() -> Config:
    base = load_config(str(pathlib.Path(__file__).with_name("lafan1.py")))
    model = dataclasses.replace(base.model, bidirectional_aligning=False)
    return dataclasses.replace(base, name="ablate_no_aligning", model=model)
