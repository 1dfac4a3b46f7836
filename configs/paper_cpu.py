"""The paper's method on a 2-core CPU, and its ablations (paper section 5.3, Table 4; Appendix D).

    bin/train --config paper_cpu --workdir runs/paper_cpu --data ../shared/data/lafan1
    bin/train --config paper_cpu --workdir runs/paper_cpu_no_bidirectional --data ../shared/data/lafan1 \
        model.bidirectional=false name=paper_cpu_no_bidirectional

lafan1_cpu (the paper's model and loss, Eq. 9 with its weights, at CPU widths; the validation split held out)
with the release recipe's data options and none of its other extensions (`config.extensions_on` names only the
four data options): the validation split, the 72 extra clips of subjects 1-4, random window starts and
left/right mirroring. The
learning rate stays constant (lafan1_cpu's 5e-4: lafan1_cpu does not decay it) and the length schedule is
lafan1_cpu's (5 -> 50 in steps of 5, one epoch each, then L = 50 as in the paper); only the run is longer:
10000 steps, about 1.5 h of training loop on the slower of the project's 2-core machines. Validation every 2000 steps on 64
windows of the validation split at L = 30 and 50.

ABLATIONS lists the paper's ablations, each one field of this config (or of the GPU-width `lafan1`, for
`bin/train --config lafan1 ... FIELD=VALUE`); every run of them trains with the same steps and train.seed.
"""
from stitchjax.config import variant

get_config = variant(
    "lafan1_cpu",
    # data: the release recipe's options (lafan1_cpu_release), nothing else of it; the validation split is
    # lafan1_cpu's already
    "data.extra_train_dirs=../lafan1_filtered60",
    "data.random_starts=true",
    "data.mirror=true",
    # schedule: lafan1_cpu's constant learning rate and length schedule, for longer
    "train.max_steps=10000",
    "train.checkpoint_every_steps=1000",
    "train.eval_every=2000",
    "train.eval_windows=64",
    "train.eval_lengths=30,50",
    name="paper_cpu",
)

# name -> (the paper's label, the one field it changes). Section 5.3's five (Table 4), then Appendix D's two.
ABLATIONS = {
    "no_bidirectional": ("w/o BS", "model.bidirectional=false"),  # the forward generator alone, towards the target
    "no_stitch_loss": ("w/o SL", "loss.stitch_weight=0"),  # alpha2 = 0
    "no_latent_interpolation": ("w/o LI", "model.latent_interpolation=false"),  # z from the current frame's latent
    "no_aligning": ("w/o BA", "model.bidirectional_aligning=false"),  # the given target stays each one's target
    "no_phase": ("w/o PM", "model.phase_modulation=false"),  # an MLP decoder instead of the phase-gated experts
    "no_discriminators": ("w/o D", "model.discriminators=false"),  # no L_G, no L_D, no discriminator update
    "no_lstm": ("w/o LSTM", "model.lstm=false"),  # the concatenated embeddings feed the latent heads directly
}

SEEDS = (0, 1)  # train.seed of the base's runs; every ablation trains from the first
