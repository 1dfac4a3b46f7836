"""Ablation (paper Table 4): no bidirectional scheme: the forward generator alone generates the whole transition.

The lafan1 reference config with exactly one field changed: model.bidirectional = False.
"""
import dataclasses
import pathlib

from stitchjax.config import Config, load_config


def get_config() -> Config:
    base = load_config(str(pathlib.Path(__file__).with_name("lafan1.py")))
    model = dataclasses.replace(base.model, bidirectional=False)
    return dataclasses.replace(base, name="ablate_no_bidirectional", model=model)
