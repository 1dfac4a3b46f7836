"""Human3.6M (paper section 5.2): the lafan1 model and training settings on the walking actions of H3.6M.

Subjects S1, S5, S6, S7, S8 train (S9, S11 test), windows of 50 frames with offset 20 as for LAFAN1
(paper section 4.1). Train with: bin/train --config h36m --workdir runs/h36m --data ../shared/data/h36m
"""
import dataclasses
import pathlib

from stitchjax.config import Config, load_config


def get_config() -> Config:
    base = load_config(str(pathlib.Path(__file__).with_name("lafan1.py")))
    data = dataclasses.replace(
        base.data,
        dataset="h36m",
        train_subjects=("S1", "S5", "S6", "S7", "S8"),  # paper: standard H3.6M training subjects
        window=50,  # paper: same windowing as LAFAN1
        offset=20,  # paper
        fps=50.0,  # H3.6M exponential-map files are 50 Hz
        parents=(-1, 0, 1, 2, 3, 4, 0, 6, 7, 8, 9, 0, 11, 12, 13, 14, 12, 16, 17, 18, 19, 20, 19, 22, 12, 24, 25,
                 26, 27, 28, 27, 30),  # H3.6M's 32-joint skeleton (shared/data/h36m/SKELETON.md)
        position_scale=1000.0,  # reason: mm -> m, as cm -> m for LAFAN1
        velocity_scale=50.0,  # reason: walking at 50 Hz moves ~25 mm/frame -> ~0.5 scaled, as on LAFAN1
    )
    return dataclasses.replace(base, name="h36m", data=data)
