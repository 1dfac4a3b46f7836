"""Tiny: the lafan1 model shrunk until it compiles in seconds — for tests and smoke runs, not for results.

    bin/train --config tiny --workdir /tmp/smoke --max-steps 5
"""
from stitchjax.config import Config, ModelConfig, PhaseConfig, TrainConfig


def get_config() -> Config:
    return Config(
        name="tiny",
        model=ModelConfig(
            encoder_widths=(16, 16, 16), lstm_size=16, latent_dim=4, decoder_widths=(16, 16),
            gating_widths=(8, 8), disc_widths=(16, 16), disc_long_window=4, stitch_buffer=2,
        ),
        train=TrainConfig(
            batch_size=4, learning_rate=3e-3, min_length=4, max_length=8, length_buckets=(),
            log_every=1, checkpoint_every_steps=100,
        ),
        phase=PhaseConfig(steps=20, batch_size=64, hidden_dim=16, num_layers=1),
    )
