"""The release recipe on a 2-core CPU, trained from scratch in one command (resumable: run it again):

    bin/train --config lafan1_cpu_release --workdir runs/release --data ../shared/data/lafan1

lafan1_cpu's model and schedule, with the data of the training subjects used as the paper does not:

- a validation split of whole training takes (`data.validation_files`, ~14 % of the training frames: a fall,
  floor work and obstacle locomotion), held out of training; `train.eval_every` scores it, never the test set;
- the 72 extra clips of subjects 1-4 (`data.extra_train_dirs`, relative to --data: ../lafan1_filtered60, 60 fps
  with a root bone above Hips, conformed on load: every second frame, the root folded into Hips);
- random window starts (`data.random_starts`) and left/right mirroring (`data.mirror`);

and the extensions of the previous from-scratch recipe (`lafan1_cpu_mixed`, now
`results/lafan1_cpu/scratch_mixed/lafan1_cpu_mixed.py`, pinned here value by value): the KL
weight at 0.1 with 1 free nat and a 500-step warm-up, half of each batch rolled out from the prior, the foot-skate
term on either end's height at 128, the foot-velocity term at 16, contact outputs that pass gradients as inputs,
every length drawn after the schedule, and the learning rate decayed. Those were first chosen on test-set
figures. On the validation split (results/2026-12-04_validation_ablation, 5000 steps, one seed) the group is
ahead of the paper's loss; one at a time, prior samples and the foot-velocity term earn their place, the KL
extension is a draw, and the foot-skate term and contact gradients each lose on every figure at 5000 steps.
Trained without those two for the whole 20000 steps (results/2026-12-05_release_v2), the model is more accurate
on validation but its feet slide more at L = 50 (0.92 against 0.82 of interpolation's), past the margin its
rule allowed: this recipe stays the release one. Trained 1.25 times as long (25000 steps, the decay stretched
with them; results/2026-12-05_release_25k), it replaced its 20000-step model by the same rule, and trained 1.6
times as long again (40000 steps; results/2026-12-06_release_40k), it replaced the 25000-step model, and at
64000 steps (results/2026-12-07_release_64k) it replaced the 40000-step model.
At 40000 steps with the state and FK terms 4x on each direction's first generated frame
(loss.near_keyframe_weight=4; results/2026-12-06_release_near_keyframe) its SLDE on validation is 5-6 % lower,
but its foot slide at L = 50 misses that rule's margin by 0.001: not adopted.
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
    # the extensions of the earlier recipe lafan1_cpu_mixed, each value pinned
    "model.contact_input_gradient=true",
    "loss.kl_weight=0.1",
    "loss.free_bits=1.0",
    "loss.kl_warmup_steps=500",
    "loss.prior_sample_fraction=0.5",
    "loss.foot_skate_contacts=height_either",
    "loss.foot_skate_weight=128",
    "loss.foot_velocity_weight=16",
    "train.length_after_schedule=uniform",
    # schedule: 64000 steps, the learning rate decayed over steps 25600-60800; about 4.4 h of training loop on
    # 2 CPU cores (0.245 s a step, validation included), resumable across stops
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
