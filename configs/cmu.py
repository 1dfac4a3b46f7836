"""CMU mocap (cgspeed BVH conversion, 31 joints, 120 fps) through the generic BVH-folder dataset.

    bin/train --config cmu --workdir runs/cmu --data ../shared/data/cmu      # any folder of CMU .bvh files

A small model (quickstart sizes): the point is that any skeleton trains. The files are resampled from
120 to 30 fps, rescaled to centimetres, and the contacts come from the CMU feet (LeftFoot, LeftToeBase,
RightFoot, RightToeBase), found by name.
"""
import dataclasses
import pathlib

from stitchjax.config import Config, load_config

CMU_PARENTS = (-1, 0, 1, 2, 3, 4, 0, 6, 7, 8, 9, 0, 11, 12, 13, 14, 15, 13, 17, 18, 19, 20, 21, 20, 13, 24, 25,
               26, 27, 28, 27)


def get_config() -> Config:
    base = load_config(str(pathlib.Path(__file__).with_name("quickstart.py")))
    data = dataclasses.replace(
        base.data,
        dataset="bvh_folder",  # reason: the generic loader (stitchjax/bvh_folder.py)
        parents=CMU_PARENTS,  # reason: FK in the losses needs the static hierarchy of the files
        train_subjects=(),  # reason: every file trains unless data.train_files / test_files split them
        feet=("LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase"),  # reason: CMU's names (also inferred)
        unit_scale=5.6444,  # reason: CMU units are 1/0.45 inch = 5.6444 cm (the ASF's "length 0.45")
        up_axis="+y",  # reason: the cgspeed conversion is Y-up
    )
    return dataclasses.replace(base, name="cmu", data=data)
