"""--length auto (issue 57, item 2): a transition length proposed from the two keyframes, with a plausible
range; the shipped length model, the take-level API (length="auto") and bin/inbetween's flag.

Rollouts use the tiny model (trained length 8, so the proposals of 10 frames or more need extrapolation)."""
import dataclasses
import json

import numpy as np
import pytest

from stitchjax.data import bundled, bvh, conform
from stitchjax.sample import inbetween, length, takes, trained_model
from stitchjax.skeleton import LAFAN1_JOINTS

from bin_scripts import load_cli

SAMPLES = 2
A, B = 300, 331  # keyframes of the bundled subject5 take (30 frames between them)


@pytest.fixture(scope="module")
def take():
    return bvh.load(bundled.sample_files(["subject5"])[0])


@pytest.fixture(scope="module")
def poses(take):
    """(global positions (T, J, 3), root rotations (T, 4)) of the bundled take."""
    rotations, positions = take.global_transforms()
    return positions, rotations[:, 0]


@pytest.fixture(scope="module")
def model(tiny_run, take):
    """The tiny model, with the training skeleton's offsets a trained run saves (for the units check)."""
    loaded = trained_model.load_model(tiny_run)
    offsets = np.array(take.skeleton.offsets)
    offsets[0] = 0.0
    return dataclasses.replace(loaded, stats={**loaded.stats, "offsets": offsets})


def _placed_pose(take, frame, offset, turn):
    """(positions (J, 3), root rotation (4,)) of ``take``'s frame turned about its root and moved."""
    placed = conform.place(take, offset, turn, pivot=frame)[frame]
    rotations, positions = placed.global_transforms()
    return positions[0], rotations[0, 0]


def test_features_of_a_pose_moved_and_turned(take, poses):
    positions, roots = poses
    moved = _placed_pose(take, 200, (300.0, 0.0, 400.0), 90.0)
    f = length.pair_features(positions[200], roots[200], *moved)
    distance, turn, pose, rise, height = f
    assert distance == pytest.approx(500.0, abs=1e-6) and turn == pytest.approx(90.0, abs=1e-6)
    assert pose == pytest.approx(0.0, abs=1e-6) and rise == pytest.approx(0.0, abs=1e-9)  # the same pose
    assert height == pytest.approx(positions[200, 0, 1])
    # turned the other way round: the same turn; another frame: the pose differs, the root rises or falls
    other = length.pair_features(positions[200], roots[200], *_placed_pose(take, 200, (0.0, 0.0, 0.0), -90.0))
    assert other[1] == pytest.approx(90.0, abs=1e-6) and other[0] == pytest.approx(0.0, abs=1e-6)
    later = length.pair_features(positions[200], roots[200], positions[230], roots[230])
    assert later[2] > 1.0 and later[3] == pytest.approx(positions[230, 0, 1] - positions[200, 0, 1])
    # batched pairs give the pairs' own features
    batch = length.pair_features(positions[[200, 210]], roots[[200, 210]], positions[[230, 240]], roots[[230, 240]])
    np.testing.assert_allclose(batch[0], later, atol=1e-12)


def test_shipped_model_proposes_more_frames_for_more_change_and_a_range_around_it(take, poses):
    lm = length.load_length_model()
    assert lm.joint_names == LAFAN1_JOINTS and lm.fps == 30.0 and lm.min_frames < lm.max_frames
    assert np.all(lm.coefficients[:, 1:5] >= 0)  # distance, turn, pose, rise never shorten a proposal
    positions, roots = poses
    still = length.propose_length(lm, positions[200], roots[200], positions[200], roots[200])
    by_distance = [length.propose_length(lm, positions[200], roots[200],
                                         *_placed_pose(take, 200, (d, 0.0, 0.0), 0.0))
                   for d in (0.0, 100.0, 200.0, 400.0)]
    frames = [p.frames for p in by_distance]
    assert frames == sorted(frames) and frames[-1] > frames[0]
    turned = length.propose_length(lm, positions[200], roots[200], *_placed_pose(take, 200, (0.0, 0.0, 0.0), 150.0))
    assert turned.frames >= still.frames and turned.high > still.high
    for p in by_distance + [turned, still]:
        assert lm.min_frames <= p.low <= p.frames <= p.high <= lm.max_frames
    # real pairs of the take: every proposal inside its range, and not one length for all
    a = np.arange(0, 700, 25)
    feats = length.pair_features(positions[a], roots[a], positions[a + 40], roots[a + 40])
    proposed = length.propose_lengths(lm, feats)
    assert np.all(proposed[:, 0] <= proposed[:, 1]) and np.all(proposed[:, 1] <= proposed[:, 2])
    assert len(np.unique(proposed[:, 1])) > 3
    # the same pose twice, in place: the fewest frames and the lowest range of all (nothing to travel)
    assert still.distance == 0.0 and still.turn == 0.0
    assert np.all(proposed >= [still.low, still.frames, still.high])
    assert all(p.frames >= still.frames and p.low >= still.low for p in by_distance + [turned])
    # a floor (the root speed limit) lifts all three numbers
    floored = length.propose_lengths(lm, feats, min_frames=lm.max_frames + 5)
    assert np.all(floored == lm.max_frames + 5)
    assert "frames (plausible" in by_distance[-1].describe() and "4.0 m" in by_distance[-1].describe()


def test_length_model_round_trips_and_refuses_another_skeleton(tmp_path):
    lm = length.load_length_model()
    path = length.save_length_model(lm, tmp_path / "lm.json")
    again = length.load_length_model(path)
    np.testing.assert_array_equal(again.coefficients, lm.coefficients)
    assert again.scales == lm.scales and again.joint_names == lm.joint_names
    assert length.length_model_for(LAFAN1_JOINTS, (0.0, 1.0, 0.0)).joint_names == LAFAN1_JOINTS
    with pytest.raises(length.LengthModelError, match="no length model for this model's skeleton.*instead of auto"):
        length.length_model_for(LAFAN1_JOINTS[:-1] + ("Skull",), (0.0, 1.0, 0.0))
    with pytest.raises(length.LengthModelError, match="no length model"):
        length.length_model_for(None, (0.0, 1.0, 0.0))
    broken = tmp_path / "broken.json"
    broken.write_text(json.dumps({**json.loads(path.read_text()), "coefficients": [[1.0, 2.0]]}))
    with pytest.raises(length.LengthModelError, match="coefficients of shape"):
        length.load_length_model(broken)


def test_take_proposal_follows_the_placed_target_the_speed_limit_and_the_take_rate(model, take):
    near = takes.propose_take_length(model, take, A, take, B)
    lm = length.load_length_model()
    rotations, positions = take.global_transforms()
    direct = length.propose_length(lm, positions[A], rotations[A, 0], positions[B], rotations[B, 0])
    assert (near.frames, near.low, near.high) == (direct.frames, direct.low, direct.high) and near.fps == 30.0
    # the same target put 12 m away: at least the frames that keep the root under the speed limit
    far = takes.propose_take_length(model, take, A, take, B, offset=(1200.0, 0.0, 0.0))
    limit, _ = takes.root_speed_limit(model)
    assert far.distance == pytest.approx(1200.0) and far.frames == int(takes.fewest_frames(1200.0, limit, 30.0))
    assert far.frames > lm.max_frames and far.low == far.frames
    # the take at 60 fps: the same duration in its own frames
    fast, a60 = conform.resample(take, 60.0, A)
    b60 = a60 + 2 * (B - A)
    at60 = takes.propose_take_length(model, fast, a60, fast, b60)
    assert at60.fps == 60.0 and at60.frames == 2 * (near.frames + 1) - 1
    assert at60.low == 2 * (near.low + 1) - 1 and at60.high == 2 * (near.high + 1) - 1


def test_inbetween_takes_with_length_auto(model, take):
    proposal = takes.propose_take_length(model, take, A, take, B)
    out = takes.inbetween_takes(model, take, A, take, B, "auto", SAMPLES, output="transition",
                                allow_extrapolation=True)
    assert len(out) == SAMPLES and all(m.num_frames == proposal.frames + 2 for m in out)
    with pytest.raises(inbetween.InbetweenError, match=r"length 'soon'.*'auto'"):
        takes.inbetween_takes(model, take, A, take, B, "soon", SAMPLES)
    with pytest.raises(inbetween.InbetweenError, match=r"longer than the 8 frames"):  # the tiny model's
        takes.inbetween_clip(model, take, A, B, "auto", SAMPLES)


def _cli_here(capsys, *args):
    """bin/inbetween's main() in this process: (exit status, stderr)."""
    module = load_cli("inbetween")
    try:
        code = module.main([str(a) for a in args])
    except SystemExit as exit_:  # argparse's own errors
        code = exit_.code
    return code, capsys.readouterr().err


def test_cli_length_auto_prints_the_proposal_and_writes_that_many_frames(tiny_run, model, take, tmp_path, capsys):
    source = bundled.sample_files(["subject5"])[0]
    base = ["--checkpoint", tiny_run, "--bvh", source, "--start-frame", A, "--samples", SAMPLES]
    code, err = _cli_here(capsys, *base, "--end-frame", B, "--length", "auto", "--allow-extrapolation",
                          "--out", tmp_path / "clip")
    assert code == 0, err
    proposal = takes.propose_take_length(model, take, A, take, B)
    assert (f"length auto: {proposal.frames} frames (plausible {proposal.low}-{proposal.high}) from "
            f"{proposal.distance / 100:.1f} m" in err and f"the take has {B - A - 1} between" in err)
    written = bvh.load(tmp_path / "clip" / f"{source.name[:-len('.bvh.gz')]}_sample0.bvh")
    assert written.num_frames == take.num_frames - (B - A - 1) + proposal.frames
    # a target from another take placed 3 m ahead: the proposal is for the placed target (and, longer than the
    # tiny model's 8 trained frames, refused after it is printed: no rollout)
    code, err = _cli_here(capsys, *base, "--target-bvh", source, "--target-frame", 500, "--length", "auto",
                          "--target-offset", "300,0,0", "--out", tmp_path / "placed")
    line = next(s for s in err.splitlines() if s.startswith("length auto:"))
    assert "from 3.0 m" in line and "the take has" not in line
    placed = takes.propose_take_length(model, take, A, take, 500, offset=(300.0, 0.0, 0.0))
    assert line.startswith(f"length auto: {placed.frames} frames (plausible {placed.low}-{placed.high})")
    assert code == 2 and f"transition length {placed.frames} is longer than the 8 frames" in err
    assert "--allow-extrapolation" in err and not (tmp_path / "placed").exists()


def test_cli_length_auto_errors(tiny_run, tmp_path, capsys, monkeypatch):
    source = bundled.sample_files(["subject5"])[0]
    base = ["--checkpoint", tiny_run, "--bvh", source, "--start-frame", A, "--end-frame", B, "--out", tmp_path / "o"]
    code, err = _cli_here(capsys, *base, "--length", "soon")
    assert code == 2 and "--length" in err and "whole number of frames, or auto" in err
    code, err = _cli_here(capsys, *base[:-4], "--target-bvh", source, "--target-frame", 500, "--out", tmp_path / "o")
    assert code == 2 and "--length auto" in err
    # a length model fitted on another skeleton: refused, naming the fix
    other = dataclasses.replace(length.load_length_model(), joint_names=("Root",) + LAFAN1_JOINTS[1:])
    monkeypatch.setattr(length, "SHIPPED", length.save_length_model(other, tmp_path / "other.json"))
    code, err = _cli_here(capsys, *base, "--length", "auto", "--allow-extrapolation")
    assert code == 2 and err.startswith("inbetween: error: no length model for this model's skeleton")
    assert "instead of auto" in err and not (tmp_path / "o").exists()


def test_cli_help_names_length_auto(capsys):
    with pytest.raises(SystemExit) as exit_:
        load_cli("inbetween").main(["--help"])
    out = capsys.readouterr().out
    assert exit_.value.code == 0 and "--length L|auto" in out and "plausible range" in out
