"""Reference configuration: the paper's full model on LAFAN1 (section 4.4 hyperparameters)."""
from stitchjax.config import Config, DataConfig


def get_config() -> Config:
    return Config(name="lafan1", data=DataConfig(dataset="lafan1"))
