"""The second release recipe: `lafan1_cpu_release` with the two changes the validation ablation found
(results/2026-12-04_validation_ablation, rows recipe_no_foot_skate, recipe_no_contact_gradient, recipe_next):
the foot-skate term off and contact outputs fed back without gradient, both the paper's values. Trained once,
20000 steps from scratch (this folder's README); its model did not replace the release model (decision.json).

    bin/train --config results/2026-12-05_release_v2/lafan1_cpu_release_v2.py --workdir runs/release_v2 --data ../shared/data/lafan1
"""
from stitchjax.config import variant

get_config = variant(
    "lafan1_cpu_release",
    "loss.foot_skate_weight=0",
    "loss.foot_skate_contacts=truth",  # inert at weight 0; the value the run had
    "model.contact_input_gradient=false",
    # the release recipe's schedule when this ran (it trains longer since: results/2026-12-05_release_25k)
    "train.max_steps=20000",
    "train.lr_decay_from_step=8000",
    "train.lr_decay_until_step=19000",
    name="lafan1_cpu_release_v2",
)
