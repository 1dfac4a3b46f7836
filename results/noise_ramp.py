#!/usr/bin/env python3
"""Sampling a trained model with its latent noise ramped up from each keyframe (``noise.noise_ramp``).

    python results/noise_ramp.py --checkpoint runs/decay512 --data ../shared/data/lafan1 \
        --ramps 0,4,8 --noise-scales 1,1.5 --json results/lafan1_cpu/from_skate512/noise_ramp.json

The model is evaluated with the paper's protocol once per (ramp, noise scale), everything else equal (same
weights, seed and windows). Ramp 0 is the paper's sampling: full noise from the frame next to each
keyframe. With ramp R, each direction's noise is scaled by i / R at its step i (0-based) until step R, so
the frames next to the keyframes come from the prior's mean and the samples part towards mid-transition.
"""
from __future__ import annotations

import pathlib
import sys

REPO = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

import sampling_protocol  # noqa: E402  (results/, beside this script)
from stitchjax.eval import evaluate  # noqa: E402
from stitchjax.sample import trained_model


def main(argv=None) -> int:
    parser = sampling_protocol.parser(__doc__)
    parser.add_argument("--ramps", default="0,4,8", help="noise ramps in steps, comma separated (0 = none)")
    parser.add_argument("--noise-scales", default="1", help="noise scales, comma separated")
    args = parser.parse_args(argv)
    model = trained_model.load_model(args.checkpoint)
    methods, settings = {}, {}
    for scale in (float(x) for x in args.noise_scales.split(",")):
        for ramp in (int(x) for x in args.ramps.split(",")):
            name = f"model_x{scale:g}_ramp{ramp}"
            methods[name] = evaluate.model_method(model, noise_scale=scale, noise_ramp_steps=ramp)
            settings[name] = f"noise x{scale:g}, ramp {ramp} steps"
    sampling_protocol.evaluate_and_write(methods, settings, args.data, args.lengths, args.samples, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
