"""The paper on a 2-core CPU: the lafan1 model and loss (Eq. 9 with its weights), narrower, trained up to L = 50.

    bin/train --config lafan1_cpu --workdir runs/lafan1_cpu --data ../shared/data/lafan1

3000 steps, roughly 20 minutes of training loop on 2 CPU cores. Everything the paper fixes stays and no
extension is on; the widths are cut for the CPU, the learning rate is raised for the short run and the length
grows faster (5 -> 50 by half of the run). Three training takes are held out as the validation split that
`train.eval_every` scores, so no choice reads the subject5 test windows. The paper-size `lafan1` is for GPUs.
"""
from stitchjax.config import variant

# The validation split: whole training takes (~14 % of the frames of subjects 1-4), a fall, floor work and
# obstacle locomotion, so that it holds both locomotion and other motion.
VALIDATION_TAKES = ("fallAndGetUp1_subject1", "ground1_subject4", "obstacles1_subject2")

get_config = variant(
    "lafan1",
    "data.validation_files=" + ",".join(VALIDATION_TAKES),
    # model: the 2-core CPU budget
    "model.encoder_widths=128,128,128",
    "model.lstm_size=256",
    "model.latent_dim=32",
    "model.decoder_widths=256,256",
    "model.gating_widths=32,32",
    "model.disc_widths=128,64",
    # train
    "train.learning_rate=5e-4",  # reason: a narrower model and a short run: larger steps than the paper's 1e-4
    "train.min_length=5",  # paper
    "train.max_length=50",
    "train.length_step=5",  # reason: 5 -> 50 in 9 increments
    "train.epochs_per_length=1",
    "train.length_buckets=15,30,50",  # reason: three compiles instead of one full-window masked step
    "train.max_steps=3000",
    "train.log_every=25",
    "train.checkpoint_every_steps=250",
    "train.eval_every=250",  # reason: validation (32 windows of the validation takes, 4 samples, L = 30 and 50)
    "train.eval_lengths=30,50",
    "phase.steps=2000",  # reason: converges in a couple of thousand steps
    name="lafan1_cpu",
)
