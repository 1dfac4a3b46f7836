"""Plots: every figure writes a non-empty PNG of the size it announces; a stick figure has J-1 bones."""
import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.image import imread

from stitchjax.eval import animation, drawing, plots
from stitchjax.skeleton import LAFAN1_PARENTS, forward_kinematics

J = len(LAFAN1_PARENTS)


def _walk(num_frames=21, seed=0, heading=(1.0, 0.0)):
    """(T, J, 3) global positions of a made-up LAFAN1-like skeleton walking along ``heading`` (x, z)."""
    rng = np.random.default_rng(seed)
    offsets = rng.normal(size=(J, 3)) * 3.0
    offsets[1:, 1] -= 10.0  # bones roughly hanging down so the figure has some height
    rot = np.zeros((num_frames, J, 4))
    rot[..., 0] = 1.0
    rot[..., 1:] = rng.normal(size=(num_frames, J, 3)) * 0.1
    rot /= np.linalg.norm(rot, axis=-1, keepdims=True)
    pos = np.broadcast_to(offsets, (num_frames, J, 3)).copy()
    t = np.arange(num_frames)
    pos[:, 0] = np.stack([heading[0] * 5.0 * t, np.full(num_frames, 90.0), heading[1] * 5.0 * t], -1)
    return forward_kinematics(rot, pos, LAFAN1_PARENTS)[1]


def _check_png(path, fig):
    assert isinstance(fig, Figure)
    assert path.is_file() and path.stat().st_size > 1000
    image = imread(path)
    width, height = np.round(fig.get_size_inches() * fig.dpi).astype(int)
    assert image.shape[:2] == (height, width)
    # Something was drawn: not a blank white page.
    assert (image[..., :3] < 0.9).any()


def test_stick_figure_draws_one_line_per_bone(tmp_path):
    pose = _walk()[0]
    fig = Figure()
    ax = fig.add_subplot(1, 1, 1)
    lines = drawing.draw_skeleton(ax, pose, LAFAN1_PARENTS)
    assert len(lines) == J - 1
    # Each line joins a joint to its parent (projected on the side view x-y).
    for line, j in zip(lines, range(1, J)):
        np.testing.assert_allclose(line.get_xdata(), pose[[LAFAN1_PARENTS[j], j], 0])
        np.testing.assert_allclose(line.get_ydata(), pose[[LAFAN1_PARENTS[j], j], 1])
    path = tmp_path / "stick.png"
    _check_png(path, plots.stick_figure(pose, LAFAN1_PARENTS, figsize=(2.0, 3.0), dpi=50, path=path))
    assert imread(path).shape[:2] == (150, 100)


def test_stick_figure_rejects_wrong_shape():
    with pytest.raises(ValueError, match="global positions"):
        plots.stick_figure(np.zeros((5, 3)), LAFAN1_PARENTS)


def test_filmstrip_png_and_colours(tmp_path):
    motions = [_walk(seed=s) for s in range(3)]
    path = tmp_path / "film.png"
    fig = plots.filmstrip(motions, LAFAN1_PARENTS, every=5, titles=["a", "b", "c"], title="t", path=path)
    _check_png(path, fig)
    assert len(fig.axes) == 3
    # frames 0, 5, 10, 15, 20 drawn: 5 figures x 21 bones per row; the first and last in black.
    bones = [line for line in fig.axes[0].lines if line.get_gid() != "ground"]
    assert len(bones) == 5 * (J - 1)
    assert all(line.get_color() == "black" for line in bones[: J - 1] + bones[-(J - 1):])
    assert all(line.get_color() != "black" for line in bones[J - 1: -(J - 1)])
    fixed = plots.filmstrip(motions[:1], LAFAN1_PARENTS, figsize=(4.0, 1.5), dpi=80)
    np.testing.assert_allclose(fixed.get_size_inches() * fixed.dpi, (320, 120))


def test_filmstrip_wraps_a_long_title_instead_of_widening_the_figure():
    motions = [_walk(seed=0)]
    short = plots.filmstrip(motions, LAFAN1_PARENTS, every=5, title="t")
    long = plots.filmstrip(motions, LAFAN1_PARENTS, every=5, title="model " * 60)
    assert long.get_size_inches()[0] == short.get_size_inches()[0]  # the data sets the width
    assert long.get_size_inches()[1] > short.get_size_inches()[1]  # the title's lines add height
    assert long._suptitle.get_text().count("\n") >= 2


def test_auto_view_looks_at_the_walk_from_the_side():
    along_z = _walk(heading=(0.0, 1.0))
    axis = drawing.horizontal_axis(along_z, "auto")
    np.testing.assert_allclose(np.abs(axis), [0.0, 1.0], atol=1e-6)
    np.testing.assert_allclose(drawing.horizontal_axis(along_z, 90.0), [0.0, 1.0], atol=1e-12)


def test_root_trajectories_and_error_over_time(tmp_path):
    path = tmp_path / "traj.png"
    fig = plots.root_trajectories([_walk(seed=0), _walk(seed=1, heading=(0.6, 0.8))], labels=["a", "b"],
                                  reference=_walk(seed=2)[:, 0], path=path)
    _check_png(path, fig)
    samples = np.stack([_walk(seed=s) for s in range(4)])
    ade = plots.per_frame_error(samples, _walk(seed=9))
    assert ade.shape == (21,) and (ade > 0).all()
    path = tmp_path / "err.png"
    fig = plots.error_over_time({"model": ade, "interp": ade * 2}, dpi=60, figsize=(4, 3), path=path)
    _check_png(path, fig)
    assert imread(path).shape[:2] == (180, 240)


def test_animate_writes_gif(tmp_path):
    path = animation.animate([_walk(num_frames=6)], LAFAN1_PARENTS, tmp_path / "a.gif", fps=10, dpi=40)
    assert path.is_file() and path.read_bytes()[:6] in (b"GIF89a", b"GIF87a")



def test_loss_curves_one_panel_per_term_parts_shared(tmp_path):
    records = [{"step": s, "loss": 10.0 / s, "fk": 1.0 / s, "fk_forward": 0.6 / s, "fk_backward": 0.4 / s,
                "length": 5, "epoch": s / 4, "windows_per_s": 30.0, "time_s": float(s)} for s in range(1, 9)]
    path = tmp_path / "loss_curves.png"
    fig = plots.loss_curves(records, path=path)
    _check_png(path, fig)
    drawn = [ax for ax in fig.axes if ax.axison]
    assert [ax.get_title() for ax in drawn] == ["loss", "fk", "length"]
    assert len(drawn[1].get_lines()) == 3  # fk with its forward and backward parts
    assert imread(path).shape[:2] == (216, 1296)  # one row of four 3.6 x 2.4 inch panels at 90 dpi


def test_loss_curves_total_loss_first_and_validation_beside_interpolation():
    records = [{"step": s, "adv_d": 1.0, "contact": 2.0 / s, "disc_loss": 0.5, "loss": 10.0 / s} for s in (1, 2, 3)]
    records += [{"step": 3, "val_ade_L30": 0.2, "val_ade_L30_interp": 0.25}]
    fig = plots.loss_curves(records)
    drawn = [ax for ax in fig.axes if ax.axison]
    assert [ax.get_title() for ax in drawn] == ["loss", "disc_loss", "adv_d", "contact", "val_ade_L30"]
    labels = [line.get_label() for line in drawn[-1].get_lines()]
    assert labels == ["val_ade_L30", "interpolation"]


def test_report_says_when_a_model_is_a_smoke_test(tmp_path):
    from stitchjax.train import reporting

    summary = dict(step=5, steps_run=5, start_step=0, setup_s=1.0, wall_s=2.0, compile_s=1.0, windows_per_s=3.0,
                   devices="1 x cpu", num_windows=10, batch_size=4, length=5, stop_reason="reached max_steps",
                   log_every=1)
    for name, smoke in (("quickstart", True), ("configs/tiny.py", True), ("lafan1_cpu", False)):
        reporting.write_report(tmp_path, name, [{"step": 5, "loss": 1.0}], summary)
        assert ("Smoke test" in (tmp_path / "report.md").read_text()) == smoke


def test_gif_figures_are_readable_and_followed_as_they_travel(tmp_path):
    from PIL import Image

    walk = _walk(num_frames=30)  # travels 145 cm, more than the figure's height
    path = animation.animate([walk, walk], LAFAN1_PARENTS, tmp_path / "w.gif", fps=30, keyframes=(0, 29))
    image = Image.open(path)
    assert image.n_frames == 30
    tallest = 0
    for frame in (0, 15, 29):  # keyframes black, the transition coloured: both much darker than the ground
        image.seek(frame)
        pixels = np.asarray(image.convert("L"))
        pixels = pixels[: int(0.95 * pixels.shape[0])]  # above the frame counter
        rows = np.flatnonzero((pixels < 150).sum(axis=1) > 0)
        tallest = max(tallest, rows.max() - rows.min() + 1)
        assert (pixels[:, : pixels.shape[1] // 2] < 150).any()  # the character stays in view (left panel)
    assert tallest >= 200  # pixels
