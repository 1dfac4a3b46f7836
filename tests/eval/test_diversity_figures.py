"""Figures that tell samples apart: the filmstrip spaces motion in place instead of stacking it (and keeps real
travel), and samples_overview draws each sample's root path from above beside its middle frame from the side."""
import numpy as np
from matplotlib.colors import to_rgba
from matplotlib.image import imread

from stitchjax.eval import drawing, plots
from stitchjax.skeleton import LAFAN1_PARENTS, forward_kinematics

J = len(LAFAN1_PARENTS)


def _motion(num_frames=21, seed=0, speed=0.0, sway=0.0):
    """(T, J, 3) global positions (cm, Y-up) of a made-up figure about 170 cm tall whose root moves ``speed`` cm
    per frame along x, and ``sway`` cm sideways (z) at the middle frame."""
    rng = np.random.default_rng(seed)
    offsets = rng.normal(size=(J, 3)) * 3.0
    offsets[1:, 1] -= 12.0
    rot = np.zeros((num_frames, J, 4))
    rot[..., 0] = 1.0
    rot[..., 1:] = rng.normal(size=(num_frames, J, 3)) * 0.05
    rot /= np.linalg.norm(rot, axis=-1, keepdims=True)
    pos = np.broadcast_to(offsets, (num_frames, J, 3)).copy()
    t = np.arange(num_frames)
    pos[:, 0] = np.stack([speed * t, np.full(num_frames, 95.0), sway * np.sin(np.pi * t / (num_frames - 1))], -1)
    return forward_kinematics(rot, pos, LAFAN1_PARENTS)[1]


def _pose_spans(ax, poses: int):
    """(left, right) screen x of each drawn pose of a filmstrip row, in drawing order."""
    bones = [line for line in ax.lines if line.get_gid() != "ground"]
    assert len(bones) == poses * (J - 1)
    xs = [np.concatenate([b.get_xdata() for b in bones[k * (J - 1):(k + 1) * (J - 1)]]) for k in range(poses)]
    return [(x.min(), x.max()) for x in xs]


def test_filmstrip_spaces_motion_in_place_by_a_body_width():
    still = _motion(speed=0.0)  # the root stays put: every pose would land on the same spot
    fig = plots.filmstrip([still], LAFAN1_PARENTS, every=5, travel=True)
    spans = _pose_spans(fig.axes[0], 5)
    axis = drawing.horizontal_axis([still], "auto")
    width = plots.body_width(still[::5], axis)
    assert width > 5.0
    roots = drawing.project(still[[0, 5, 10, 15, 20], 0], axis)[:, 0]
    lefts = np.array([s[0] for s in spans])
    placed_roots = lefts + (roots - np.array([drawing.project(p, axis)[:, 0].min() for p in still[::5]]))
    assert np.all(np.diff(placed_roots) >= width - 1e-6)  # each pose a body width further along the strip


def test_filmstrip_keeps_real_travel_when_the_root_moves_further():
    walk = _motion(speed=30.0)  # 150 cm between drawn frames, far more than a body width
    fig = plots.filmstrip([walk], LAFAN1_PARENTS, every=5, travel=True)
    spans = _pose_spans(fig.axes[0], 5)
    axis = drawing.horizontal_axis([walk], "auto")
    shifts = np.diff([s[0] for s in spans])
    real = np.diff([drawing.project(p, axis)[:, 0].min() for p in walk[::5]])
    np.testing.assert_allclose(shifts, real, atol=1e-6)


def test_samples_overview_shows_each_path_from_above_and_each_middle_frame(tmp_path):
    samples = [_motion(seed=0, speed=4.0, sway=s) for s in (-30.0, 0.0, 30.0)]
    reference = _motion(seed=0, speed=4.0)
    path = tmp_path / "overview.png"
    fig = plots.samples_overview(samples, LAFAN1_PARENTS, keyframes=(2, 18), reference=reference, title="t",
                                 path=path, dpi=60)
    assert imread(path).shape[:2] == (360, 600)
    above, side = fig.axes
    for i in range(3):  # each sample's transition path in its own colour, with a dot at the middle frame
        colored = [line for line in above.lines if to_rgba(line.get_color()) == to_rgba(drawing.sample_color(i))]
        path_line = max(colored, key=lambda line: len(line.get_xdata()))
        assert len(path_line.get_xdata()) == 17
        dot = [line for line in colored if len(line.get_xdata()) == 1]
        assert len(dot) == 1
    # turned so the way runs left to right: the sideways sway shows as +-30 cm across the way at the middle
    middles = sorted(float(line.get_ydata()[0]) for line in above.lines if len(line.get_xdata()) == 1)
    np.testing.assert_allclose(np.diff(middles), [30.0, 30.0], atol=1.0)
    # the keyframes from above (2 poses) and the middle frames from the side (input + 3 samples)
    keyframe_bones = [line for line in above.lines if line.get_color() == drawing.KEYFRAME_COLOR
                      and len(line.get_xdata()) == 2]
    assert len(keyframe_bones) == 2 * (J - 1)
    assert len([line for line in side.lines if line.get_gid() != "ground"]) >= 4 * (J - 1)
