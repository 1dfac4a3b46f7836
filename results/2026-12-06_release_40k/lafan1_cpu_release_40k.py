"""The release recipe 1.6 times as long: `lafan1_cpu_release` with 40000 steps and its learning-rate decay
stretched with it (steps 16000-38000 instead of 10000-23750); nothing else changes (data, validation split,
loss, model, seed). The 25000-step release run's validation curve was still falling at its last step (ADE ratio
at L = 30: 0.798 at step 20000, 0.786 at 25000; results/2026-12-05_release_25k), and the recipe may use up to
about 8 h of training loop; this one is about 2.6 h on 2 CPU cores, so it is trained across stops.

    bin/train --config results/2026-12-06_release_40k/lafan1_cpu_release_40k.py --workdir runs/release_40k --data ../shared/data/lafan1
"""
from stitchjax.config import variant

get_config = variant(
    "lafan1_cpu_release",
    "train.max_steps=40000",
    "train.lr_decay_from_step=16000",
    "train.lr_decay_until_step=38000",
    name="lafan1_cpu_release_40k",
)
