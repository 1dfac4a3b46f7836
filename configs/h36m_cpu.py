"""Human3.6M (paper section 5.2, Table 3) on a 2-core CPU: the h36m data with paper_cpu's model, loss and schedule.

    bin/train --config h36m_cpu --workdir runs/h36m_cpu --data ../shared/data/h36m

paper_cpu with the data section of `h36m` (subjects S1, S5, S6, S7, S8 train, S9 and S11 test; walking,
walking-dog and walking-together at 25 Hz; windows of 52 frames every 20) and no validation during training:
Human3.6M has no held-out training take here (the data options of paper_cpu are LAFAN1's), and validating on
the test subjects would read them while training.
"""
import dataclasses
import pathlib

from stitchjax.config import load_config

_HERE = pathlib.Path(__file__).resolve().parent


def get_config():
    base = load_config(str(_HERE / "paper_cpu.py"))
    data = load_config(str(_HERE / "h36m.py")).data
    return dataclasses.replace(base, data=data, train=dataclasses.replace(base.train, eval_every=0),
                               name="h36m_cpu")
