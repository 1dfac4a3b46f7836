"""Tiny: the lafan1 model shrunk until it compiles in seconds — for tests and smoke runs, not for results.

    bin/train --config tiny --workdir /tmp/smoke --max-steps 5
"""
import dataclasses
import pathlib

from stitchjax.config import Config, load_config


def get_config() -> Config:
    base = load_config(str(pathlib.Path(__file__).with_name("lafan1.py")))
    model = dataclasses.replace(
        base.model,
        encoder_widths=(16, 16, 16), lstm_size=16, latent_dim=4, decoder_widths=(16, 16),
        gating_widths=(8, 8), disc_widths=(16, 16), disc_long_window=4, stitch_buffer=2,
    )
    train = dataclasses.replace(
        base.train,
        batch_size=4, learning_rate=3e-3, min_length=4, max_length=8, length_buckets=(),
        log_every=1, checkpoint_every_steps=100,
    )
    phase = dataclasses.replace(base.phase, steps=20, batch_size=64, hidden_dim=16, num_layers=1)
    return dataclasses.replace(base, name="tiny", model=model, train=train, phase=phase)
