"""The candidate release recipe of about 2 h: lafan1_cpu_release with interpolation-anchored updates, 30000 steps
(the learning-rate decay over steps 12000-28500: the release recipe's 40 % -> 95 %), validation every 3000 steps.
On the 2-core machine alone: about 30000 x 0.22 s = 1.8 h of training loop (estimate).

    bin/train --config experiments/quality_per_hour/configs/release_2h.py --workdir runs/qph_release_2h --data ../shared/data/lafan1
"""
from stitchjax.config import variant

get_config = variant(
    "lafan1_cpu_release",
    "model.update_anchor=interpolation",
    "train.max_steps=30000",
    "train.lr_decay_from_step=12000",
    "train.lr_decay_until_step=28500",
    "train.eval_every=3000",
    name="qph_release_2h",
)
