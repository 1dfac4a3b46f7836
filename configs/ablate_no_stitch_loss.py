"""Ablation (paper Table 4): no stitching loss (alpha2 = 0).

The lafan1 reference config with exactly one field changed: loss.stitch_weight = 0.0.
"""
import dataclasses
import pathlib

from stitchjax.config import Config, load_config


def get_config() -> Config:
    base = load_config(str(pathlib.Path(__file__).with_name("lafan1.py")))
    loss = dataclasses.replace(base.loss, stitch_weight=0.0)
    return dataclasses.replace(base, name="ablate_no_stitch_loss", loss=loss)
