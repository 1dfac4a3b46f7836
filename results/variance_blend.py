#!/usr/bin/env python3
"""Sampling a trained model with either latent-interpolation variance blend (model.variance_blend).

    python results/variance_blend.py --checkpoint runs/lafan1_cpu --data ../shared/data/lafan1 \
        --json results/lafan1_cpu/variance_blend.json

The model is evaluated with the paper's protocol twice, once with each blend of the prior's standard
deviations ("std": sigma = (1-g) s + g s_t; "var": sigma^2 = (1-g)^2 s^2 + g^2 s_t^2), everything else
equal (same weights, seed and windows). Only the spread of the prior changes, most at mid-direction
(g = 1/2, where "var" shrinks a unit sigma to 0.71).
"""
from __future__ import annotations

import dataclasses
import pathlib
import sys

REPO = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

import sampling_protocol  # noqa: E402  (results/, beside this script)
from stitchjax import config as config_lib  # noqa: E402
from stitchjax.eval import evaluate  # noqa: E402
from stitchjax.sample import trained_model


def main(argv=None) -> int:
    parser = sampling_protocol.parser(__doc__)
    args = parser.parse_args(argv)
    model = trained_model.load_model(args.checkpoint)
    methods, settings = {}, {}
    for blend in config_lib.CHOICES[("model", "variance_blend")]:
        config = config_lib.apply_overrides(model.config, [f"model.variance_blend={blend}"])
        name = f"model_{blend}"
        methods[name] = evaluate.model_method(dataclasses.replace(model, config=config))
        settings[name] = f"variance_blend={blend}" + (" (trained)" if blend == model.config.model.variance_blend
                                                        else " (at sampling only)")
    sampling_protocol.evaluate_and_write(methods, settings, args.data, args.lengths, args.samples, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
