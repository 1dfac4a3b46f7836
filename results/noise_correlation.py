#!/usr/bin/env python3
"""Sampling a trained model with latent noise correlated over frames (``noise.correlated_noise``).

    python results/noise_correlation.py --checkpoint runs/cvae_long --data ../shared/data/lafan1 \
        --json results/lafan1_cpu/noise_correlation.json

The model is evaluated with the paper's protocol once per correlation rho (AR(1) from one step to the next;
0 = independent noise per frame, the paper's sampling; 1 = one draw per transition), everything else equal
(same weights, seed, windows and noise scale 1). Every frame's noise stays standard normal, so the prior's
spread per frame is the same; only how it moves from frame to frame changes.
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
    parser.add_argument("--correlations", default="0,0.5,0.9,0.97,1", help="rho values, comma separated")
    args = parser.parse_args(argv)
    model = trained_model.load_model(args.checkpoint)
    methods, settings = {}, {}
    for rho in (float(x) for x in args.correlations.split(",")):
        name = f"model_rho{rho:g}"
        methods[name] = evaluate.model_method(model, noise_correlation=rho)
        settings[name] = f"noise x1, correlation {rho:g} from frame to frame"
    sampling_protocol.evaluate_and_write(methods, settings, args.data, args.lengths, args.samples, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
