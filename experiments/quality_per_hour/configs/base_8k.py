"""The release recipe (lafan1_cpu_release) with its schedule cut to 8000 steps (about 30 min of training loop on
2 CPU cores): the reference row of the quality-per-hour levers. Decay over steps 3200-7600 (the release
recipe's 40 % -> 95 %), validation every 1000 steps.

    bin/train --config experiments/quality_per_hour/configs/base_8k.py --workdir runs/qph_base_8k --data ../shared/data/lafan1
"""
from stitchjax.config import variant

get_config = variant(
    "lafan1_cpu_release",
    "train.max_steps=8000",
    "train.lr_decay_from_step=3200",
    "train.lr_decay_until_step=7600",
    "train.eval_every=1000",
    name="qph_base_8k",
)
