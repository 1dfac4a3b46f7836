"""Reference configuration: the paper's full model on LAFAN1 (section 4.4 hyperparameters), sized for a GPU.

    bin/train --config lafan1 --workdir runs/lafan1 --data ../shared/data/lafan1
"""
from stitchjax.config import Config, DataConfig


def get_config() -> Config:
    return Config(name="lafan1", data=DataConfig(dataset="lafan1"))
