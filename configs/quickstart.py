"""Quickstart: a small model trained on the bundled LAFAN1 sample in about a minute on 2 CPU cores.

    bin/train --config quickstart --workdir /tmp/run        # no --data: stitchjax.data.bundled.sample_dir()

The lafan1 model with every width cut to 64 and shorter training windows, so that compilation, phase
pretraining and 800 steps fit in about a minute (two when the cores are shared). It shows the pipeline
working end to end (losses fall, checkpoints, report); it is not a model to evaluate.
"""
from stitchjax.config import Config, DataConfig, ModelConfig, PhaseConfig, TrainConfig


def get_config() -> Config:
    return Config(
        name="quickstart",
        data=DataConfig(
            window=24,  # reason: short windows (transitions up to 22 frames) keep the scan short on CPU
            offset=8,  # reason: more, overlapping windows from the few sample clips
        ),
        model=ModelConfig(
            encoder_widths=(64, 64, 64),  # reason: small = fast on CPU
            lstm_size=64,
            latent_dim=16,
            decoder_widths=(64, 64),
            gating_widths=(16, 16),
            disc_widths=(64, 32),
            stitch_buffer=2,  # reason: short transitions
        ),
        train=TrainConfig(
            batch_size=16,  # reason: CPU
            learning_rate=1e-3,  # reason: a small model and a short run: larger steps than the paper's 1e-4
            min_length=5,  # paper
            max_length=22,  # reason: window 24 - 2 keyframes
            length_buckets=(),  # reason: one compile (traced length, masked): compile time dominates a short run
            epochs_per_length=1,  # reason: reach long transitions within the short run
            max_steps=800,  # reason: the losses fall visibly within the quickstart's minute
            log_every=10,
            checkpoint_every_steps=100,
        ),
        phase=PhaseConfig(steps=500, hidden_dim=64),  # reason: seconds, not minutes
    )
