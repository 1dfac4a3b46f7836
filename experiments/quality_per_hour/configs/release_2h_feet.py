"""The second 2-hour candidate: lafan1_cpu_release with both levers measured at 6000 steps, interpolation-anchored
updates and the ground-penetration term (weight 64); 28000 steps, the learning-rate decay over steps 11200-26600
(the release recipe's 40 % -> 95 %), validation every 4000 steps. Alone on the 2 cores: about 28000 x 0.245 s = 1.9 h.

    bin/train --config experiments/quality_per_hour/configs/release_2h_feet.py --workdir runs/qph_release_2h_feet --data ../shared/data/lafan1
"""
from stitchjax.config import variant

get_config = variant(
    "lafan1_cpu_release",
    "model.update_anchor=interpolation",
    "loss.ground_penetration_weight=64",
    "train.max_steps=28000",
    "train.lr_decay_from_step=11200",
    "train.lr_decay_until_step=26600",
    "train.eval_every=4000",
    name="qph_release_2h_feet",
)
