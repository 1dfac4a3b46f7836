"""results/foot_motion.py: foot slide beside how far the feet and the root move, whatever the feet's height."""
import pathlib
import sys

import numpy as np

SCRIPT = pathlib.Path(__file__).resolve().parent.parent / "foot_motion.py"
sys.path.insert(0, str(SCRIPT.parent))
import foot_motion  # noqa: E402

from stitchjax.skeleton import LAFAN1_FEET as FEET  # noqa: E402


def _walk(height_cm: float, step_cm: float, frames: int = 5) -> np.ndarray:
    """(1, 1, frames, 9, 3) positions in LAFAN1 units (cm): every joint at ``height_cm``, moving ``step_cm``
    along x per frame."""
    positions = np.zeros((1, 1, frames, 9, 3))
    positions[..., 1] = height_cm
    positions[..., 0] = step_cm * np.arange(frames)[None, None, :, None]
    return positions


def test_planted_moving_feet_slide_and_lifted_ones_only_move():
    ground = np.zeros(1)
    on_ground = foot_motion.motion_figures(_walk(0.0, 2.0), ground, FEET)
    assert np.isclose(on_ground["foot_slide"], 2.0) and np.isclose(on_ground["weighed_share"], 1.0)
    assert np.isclose(on_ground["foot_movement_cm"], 2.0) and np.isclose(on_ground["root_movement_cm"], 2.0)
    assert np.isclose(on_ground["slide_per_step_cm"], on_ground["foot_slide"] * on_ground["weighed_share"])
    lifted = foot_motion.motion_figures(_walk(50.0, 2.0), ground, FEET)  # far above the contact height
    assert lifted["foot_slide"] == 0.0 and lifted["weighed_share"] == 0.0 and lifted["slide_per_step_cm"] == 0.0
    assert np.isclose(lifted["foot_movement_cm"], 2.0)
    still = foot_motion.motion_figures(_walk(0.0, 0.0), ground, FEET)
    assert still["foot_slide"] == 0.0 and still["root_movement_cm"] == 0.0


def test_the_share_of_feet_near_the_ground_divides_the_foot_slide():
    """Half the feet lifted: the weighted sliding per joint-step halves, the protocol's foot slide does not."""
    half = _walk(0.0, 2.0)
    half[..., [7, 8], 1] = 50.0  # the right foot and toe far above the contact height
    got = foot_motion.motion_figures(half, np.zeros(1), FEET)
    assert np.isclose(got["weighed_share"], 0.5) and np.isclose(got["foot_slide"], 2.0)
    assert np.isclose(got["slide_per_step_cm"], 1.0)


def test_middle_third_and_the_feet_movement_along_the_transition():
    """A walk that stands for 4 steps, moves 3 cm per step for 4, and stands for 4: the middle third holds the
    moving steps alone, and the movement along the transition is 3 cm there and 0 elsewhere."""
    x = np.concatenate([np.zeros(5), 3.0 * np.arange(1, 5), np.full(4, 12.0)])  # 13 frames, 12 steps
    positions = np.zeros((1, 1, 13, 9, 3))
    positions[..., 0] = x[None, None, :, None]
    middle = foot_motion.middle_third(positions)
    assert middle.shape[2] == 5 and np.allclose(np.diff(middle[0, 0, :, 0, 0]), 3.0)
    along = foot_motion.foot_movement_along(positions, FEET)
    assert along.shape == (12,) and np.allclose(along, np.diff(x))
    figures = foot_motion.motion_figures(middle, np.zeros(1), FEET)
    assert np.isclose(figures["foot_slide"], 3.0) and np.isclose(figures["foot_movement_cm"], 3.0)
