"""The earlier from-scratch recipe on a 2-core CPU: lafan1_cpu with the four changes the fine-tunes measured.

    bin/train --config results/lafan1_cpu/scratch_mixed/lafan1_cpu_mixed.py --workdir runs/lafan1_cpu_mixed \
              --data ../shared/data/lafan1

- every length drawn after the schedule (`train.length_after_schedule=uniform`: 14 % less foot slide than L = 50
  alone);
- the foot-skate term on either end's height at 128 (`loss.foot_skate_contacts=height_either`);
- the foot velocity term at 16;
- the learning rate decaying from step 6000 to 0.05 x at 14000, and 16000 steps (~70 min alone on 2 cores).

This is the config of the committed model `results/lafan1_cpu/scratch_mixed/models/scratch_mixed` (exported as the
package's first release model, `lafan1_cpu_mixed`; kept here with its experiments, no longer in configs/): below
interpolation on ADE and NPSS at every length of the protocol (results/README.md, "The recipe from scratch").
Its first lines pin what lafan1_cpu set before it became the paper's loss (2026-12-04): the KL weight at 0.1,
1 free nat, a 500-step warm-up, half of each batch from the prior, contact gradients, no validation split.
"""
from stitchjax.config import variant

get_config = variant(
    "lafan1_cpu",
    # what lafan1_cpu set when this model was trained (it is the paper's loss since)
    "model.contact_input_gradient=true",
    "loss.kl_weight=0.1",
    "loss.free_bits=1.0",
    "loss.kl_warmup_steps=500",
    "loss.prior_sample_fraction=0.5",
    "data.validation_files=",
    "train.length_after_schedule=uniform",
    "loss.foot_skate_contacts=height_either",
    "loss.foot_skate_weight=128",
    "loss.foot_velocity_weight=16",
    "train.lr_decay_to=0.05",
    "train.lr_decay_from_step=6000",
    "train.lr_decay_until_step=14000",
    "train.max_steps=16000",
    name="lafan1_cpu_mixed",
)
