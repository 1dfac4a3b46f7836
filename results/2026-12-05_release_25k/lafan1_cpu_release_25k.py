"""The release recipe trained 1.25 times as long: `lafan1_cpu_release` with 25000 steps and its learning-rate decay
stretched with it (steps 10000-23750 instead of 8000-19000); nothing else changes. The release run's validation
curve was still falling at step 20000 (ADE at L = 50: 0.186 m at step 9000, 0.166 at step 20000), and the recipe
may use up to about 8 h of training loop; this one is about 2 h on 2 CPU cores.

    bin/train --config results/2026-12-05_release_25k/lafan1_cpu_release_25k.py --workdir runs/release_25k --data ../shared/data/lafan1
"""
from stitchjax.config import variant

get_config = variant(
    "lafan1_cpu_release",
    "train.max_steps=25000",
    "train.lr_decay_from_step=10000",
    "train.lr_decay_until_step=23750",
    name="lafan1_cpu_release_25k",
)
