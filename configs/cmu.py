"""CMU mocap (cgspeed BVH conversion, 31 joints, 120 fps) through the generic BVH-folder dataset.

    bin/train --config cmu --workdir runs/cmu --data ../shared/data/cmu      # any folder of CMU .bvh files

The quickstart config (a small model: the point is that any skeleton trains) on CMU files. The files are
resampled from 120 to 30 fps, rescaled to centimetres, and the contacts come from the CMU feet (LeftFoot,
LeftToeBase, RightFoot, RightToeBase), found by name.
"""
from stitchjax.config import variant

CMU_PARENTS = (-1, 0, 1, 2, 3, 4, 0, 6, 7, 8, 9, 0, 11, 12, 13, 14, 15, 13, 17, 18, 19, 20, 21, 20, 13, 24, 25,
               26, 27, 28, 27)

get_config = variant(
    "quickstart",
    "data.dataset=bvh_folder",  # reason: the generic loader (stitchjax/data/bvh_folder.py)
    "data.parents=" + ",".join(map(str, CMU_PARENTS)),  # reason: FK in the losses needs the files' hierarchy
    "data.train_subjects=",  # reason: every file trains unless data.train_files / test_files split them
    "data.feet=LeftFoot,LeftToeBase,RightFoot,RightToeBase",  # reason: CMU's names (also inferred)
    "data.unit_scale=5.6444",  # reason: CMU units are 1/0.45 inch = 5.6444 cm (the ASF's "length 0.45")
    "data.up_axis=+y",  # reason: the cgspeed conversion is Y-up
    name="cmu",
)
