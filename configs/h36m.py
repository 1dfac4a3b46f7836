"""Human3.6M (paper section 5.2): the lafan1 model and training settings on the walking actions of H3.6M.

Subjects S1, S5, S6, S7, S8 train (S9, S11 test), windows of 50 frames with offset 20 as for LAFAN1
(paper section 4.1). stitchjax.data.h36m reads the files in centimetres at 25 Hz on its 21 moving joints, so
the LAFAN1 scales (cm) carry over. Train with:
    bin/train --config h36m --workdir runs/h36m --data ../shared/data/h36m
"""
from stitchjax.data import h36m
from stitchjax.config import Config, DataConfig


def get_config() -> Config:
    return Config(
        name="h36m",
        data=DataConfig(
            dataset="h36m",
            train_subjects=("S1", "S5", "S6", "S7", "S8"),  # paper: standard H3.6M training subjects
            # window and offset as for LAFAN1 (L up to 50 generated frames + 2 keyframes, offset 20: paper)
            fps=25.0,  # stitchjax.data.h36m keeps every second frame of the 50 Hz files
            parents=tuple(h36m.PARENTS),  # the 21 joints stitchjax.data.h36m keeps
        ),
    )
