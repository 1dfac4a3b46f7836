"""base_6k with one lever: model.update_anchor=interpolation, loss.ground_penetration_weight=64.

    bin/train --config experiments/quality_per_hour/configs/anchor_penetration_6k.py --workdir runs/qph_anchor_penetration_6k --data ../shared/data/lafan1
"""
from stitchjax.config import variant

get_config = variant(
    "base_6k",
    "model.update_anchor=interpolation",
    "loss.ground_penetration_weight=64",
    name="qph_anchor_penetration_6k",
)
