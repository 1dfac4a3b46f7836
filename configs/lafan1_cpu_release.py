"""The release model's recipe: lafan1_cpu's model on a 2-core CPU, trained from scratch in one command.

    bin/train --config lafan1_cpu_release --workdir runs/release --data ../shared/data/lafan1

64000 steps, about 4.4 h of training loop on 2 CPU cores; run the command again to resume. Beside lafan1_cpu it
uses the training subjects' data as the paper does not (a validation split of whole takes that
`train.eval_every` scores, the 72 extra clips of ../lafan1_filtered60 conformed on load, random window starts,
left/right mirroring) and keeps the extensions listed below, each value pinned; `bin/train` names them.
"""
from stitchjax.config import variant

VALIDATION_TAKES = "fallAndGetUp1_subject1,ground1_subject4,obstacles1_subject2"

get_config = variant(
    "lafan1_cpu",
    # data
    f"data.validation_files={VALIDATION_TAKES}",
    "data.extra_train_dirs=../lafan1_filtered60",
    "data.random_starts=true",
    "data.mirror=true",
    # extensions, each value pinned
    "model.contact_input_gradient=true",
    "loss.kl_weight=0.1",
    "loss.free_bits=1.0",
    "loss.kl_warmup_steps=500",
    "loss.prior_sample_fraction=0.5",
    "loss.foot_skate_contacts=height_either",
    "loss.foot_skate_weight=128",
    "loss.foot_velocity_weight=16",
    "train.length_after_schedule=uniform",
    # schedule: 64000 steps, the learning rate decayed over steps 25600-60800
    "train.learning_rate=5e-4",
    "train.lr_decay_to=0.05",
    "train.lr_decay_from_step=25600",
    "train.lr_decay_until_step=60800",
    "train.max_steps=64000",
    "train.checkpoint_every_steps=500",
    "train.eval_every=1000",
    "train.eval_windows=64",
    "train.eval_lengths=30,50",
    name="lafan1_cpu_release",
)
