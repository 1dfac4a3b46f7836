"""The release recipe (lafan1_cpu_release) with its schedule cut to 6000 steps: the reference row of the
quality-per-hour levers. Lengths 5 -> 50 in steps of 15 (three epochs instead of nine), the learning-rate decay
over steps 2400-5700 (the release recipe's 40 % -> 95 %), validation every 1000 steps.

    bin/train --config experiments/quality_per_hour/configs/base_6k.py --workdir runs/qph_base_6k --data ../shared/data/lafan1
"""
from stitchjax.config import variant

get_config = variant(
    "lafan1_cpu_release",
    "train.max_steps=6000",
    "train.length_step=15",
    "train.lr_decay_from_step=2400",
    "train.lr_decay_until_step=5700",
    "train.eval_every=1000",
    name="qph_base_6k",
)
