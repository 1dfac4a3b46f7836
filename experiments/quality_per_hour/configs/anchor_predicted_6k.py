"""base_6k with one lever: model.update_anchor=interpolation, loss.foot_skate_contacts=predicted.

    bin/train --config experiments/quality_per_hour/configs/anchor_predicted_6k.py --workdir runs/qph_anchor_predicted_6k --data ../shared/data/lafan1
"""
from stitchjax.config import variant

get_config = variant(
    "base_6k",
    "model.update_anchor=interpolation",
    "loss.foot_skate_contacts=predicted",
    name="qph_anchor_predicted_6k",
)
