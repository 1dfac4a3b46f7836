"""Ablation (paper Table 4): no latent interpolation: z sampled from the current-frame Gaussian only.

The lafan1 reference config with exactly one field changed: model.latent_interpolation = False.
"""
import dataclasses
import pathlib

from stitchjax.config import Config, load_config


def get_config() -> Config:
    base = load_config(str(pathlib.Path(__file__).with_name("lafan1.py")))
    model = dataclasses.replace(base.model, latent_interpolation=False)
    return dataclasses.replace(base, name="ablate_no_latent_interpolation", model=model)
