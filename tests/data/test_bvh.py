"""BVH reading and writing: real files round trip, synthetic hierarchies, malformed files."""
import gzip

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from stitchjax.data import bvh
from stitchjax.skeleton import LAFAN1_JOINTS, LAFAN1_PARENTS, Skeleton

# A custom hierarchy: different rotation orders, a non-root joint with position channels (after its
# rotation channels), a joint with two rotation channels, a joint with no channels, End Sites.
CUSTOM = """HIERARCHY
ROOT Pelvis
{
\tOFFSET 1.0 2.0 3.0
\tCHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation
\tJOINT Chest
\t{
\t\tOFFSET 0.0 10.0 0.5
\t\tCHANNELS 3 Yrotation Xrotation Zrotation
\t\tJOINT Slider
\t\t{
\t\t\tOFFSET 0.0 8.0 0.0
\t\t\tCHANNELS 6 Zrotation Xrotation Yrotation Xposition Yposition Zposition
\t\t\tEnd Site
\t\t\t{
\t\t\t\tOFFSET 0.0 5.0 0.0
\t\t\t}
\t\t}
\t\tJOINT Hinge
\t\t{
\t\t\tOFFSET 4.0 0.0 0.0
\t\t\tCHANNELS 2 Xrotation Zrotation
\t\t\tJOINT Fixed
\t\t\t{
\t\t\t\tOFFSET 3.0 0.0 1.0
\t\t\t\tCHANNELS 0
\t\t\t\tEnd Site
\t\t\t\t{
\t\t\t\t\tOFFSET 2.0 0.0 0.0
\t\t\t\t}
\t\t\t}
\t\t}
\t}
\tJOINT Leg
\t{
\t\tOFFSET -2.0 -9.0 0.0
\t\tCHANNELS 3 Xrotation Yrotation Zrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0.0 -7.0 0.0
\t\t}
\t}
}
MOTION
Frames: {frames}
Frame Time: 0.04
"""
CUSTOM_CHANNELS = 6 + 3 + 6 + 2 + 0 + 3  # 20
HEADER_LINES = CUSTOM.count("\n")  # the first frame is on line HEADER_LINES + 1


def custom_values(num_frames=7, seed=0):
    rng = np.random.default_rng(seed)
    values = rng.uniform(-170, 170, size=(num_frames, CUSTOM_CHANNELS))
    values[:, 0:3] = rng.normal(0, 50, size=(num_frames, 3))     # root position
    values[:, 12:15] = rng.normal(0, 5, size=(num_frames, 3))    # Slider position
    values[:, 10] = rng.uniform(-80, 80, size=num_frames)        # middle angles away from gimbal lock
    values[:, 1 + 3 + 1] = rng.uniform(-80, 80, size=num_frames)
    return np.round(values, 6)


def custom_text(values, newline="\n"):
    lines = CUSTOM.replace("{frames}", str(len(values))).splitlines()
    lines += [" ".join(f"{v:.6f}" for v in row) for row in values]
    return newline.join(lines) + newline


def write(path, text, compress=False):
    data = text.encode()
    path.write_bytes(gzip.compress(data) if compress else data)
    return path


def scipy_quat(angles_deg, order):
    """BVH convention q = q_a * q_b * q_c is scipy's intrinsic (uppercase) sequence; scipy is xyzw."""
    xyzw = Rotation.from_euler(order.upper(), angles_deg, degrees=True).as_quat()
    return np.concatenate([xyzw[..., 3:], xyzw[..., :3]], axis=-1)


def assert_same_rotation(q, expected, atol=1e-9):
    dots = np.abs(np.sum(q * expected, axis=-1))
    np.testing.assert_allclose(dots, 1.0, atol=atol)


def test_file_stem_drops_the_bvh_and_gz_endings_only():
    assert bvh.file_stem("data/walk1_subject1.bvh.gz") == "walk1_subject1"
    assert bvh.file_stem("Take.BVH") == "Take" and bvh.file_stem("take.gz") == "take"
    assert bvh.file_stem("take.v2.bvh") == "take.v2" and bvh.file_stem("notes.txt") == "notes.txt"


def test_custom_hierarchy_channels_and_orders(tmp_path):
    values = custom_values()
    motion = bvh.load(write(tmp_path / "custom.bvh", custom_text(values)))
    skel = motion.skeleton
    assert skel.names == ("Pelvis", "Chest", "Slider", "Hinge", "Fixed", "Leg")
    assert skel.parents == (-1, 0, 1, 1, 3, 0)
    np.testing.assert_allclose(skel.offsets[3], [4.0, 0.0, 0.0])
    assert motion.num_frames == 7 and motion.fps == 25.0
    assert motion.channels[2] == ("Zrotation", "Xrotation", "Yrotation",
                                  "Xposition", "Yposition", "Zposition")
    assert motion.channels[4] == ()
    assert motion.end_sites == ((2, (0.0, 5.0, 0.0)), (4, (2.0, 0.0, 0.0)), (5, (0.0, -7.0, 0.0)))

    rot = motion.rotations
    assert_same_rotation(rot[:, 0], scipy_quat(values[:, 3:6], "xyz"))
    assert_same_rotation(rot[:, 1], scipy_quat(values[:, 6:9], "yxz"))
    assert_same_rotation(rot[:, 2], scipy_quat(values[:, 9:12], "zxy"))
    assert_same_rotation(rot[:, 3], scipy_quat(values[:, 15:17], "xz"))
    assert_same_rotation(rot[:, 4], np.tile([1.0, 0, 0, 0], (7, 1)))
    assert_same_rotation(rot[:, 5], scipy_quat(values[:, 17:20], "xyz"))
    # Animated positions on the root and on Slider; offsets elsewhere.
    np.testing.assert_allclose(motion.positions[:, 0], values[:, 0:3])
    np.testing.assert_allclose(motion.positions[:, 2], values[:, 12:15])
    np.testing.assert_allclose(motion.positions[:, 1], np.tile([0.0, 10.0, 0.5], (7, 1)))

    # Global positions agree with an independent scipy forward kinematics.
    g = motion.global_positions()
    r_root = Rotation.from_euler("XYZ", values[:, 3:6], degrees=True)
    r_chest = r_root * Rotation.from_euler("YXZ", values[:, 6:9], degrees=True)
    chest = values[:, 0:3] + r_root.apply([0.0, 10.0, 0.5])
    np.testing.assert_allclose(g[:, 1], chest, atol=1e-9)
    np.testing.assert_allclose(g[:, 2], chest + r_chest.apply(values[:, 12:15]), atol=1e-9)


@pytest.mark.parametrize("compress", [False, True])
def test_custom_round_trip(tmp_path, compress):
    values = custom_values(seed=1)
    motion = bvh.load(write(tmp_path / "in.bvh", custom_text(values)))
    out = tmp_path / ("out.bvh.gz" if compress else "out.bvh")
    bvh.save(out, motion)
    if compress:
        assert out.read_bytes()[:2] == b"\x1f\x8b"
    again = bvh.load(out)
    assert again.skeleton == motion.skeleton
    assert again.channels == motion.channels
    assert again.end_sites == motion.end_sites
    assert again.fps == motion.fps
    np.testing.assert_allclose(again.global_positions(), motion.global_positions(), atol=1e-4)
    assert_same_rotation(again.global_rotations(), motion.global_rotations(), atol=1e-10)


def test_crlf_tabs_and_gzip_read_the_same(tmp_path):
    values = custom_values(seed=2)
    plain = bvh.load(write(tmp_path / "a.bvh", custom_text(values)))
    crlf = bvh.load(write(tmp_path / "b.bvh", custom_text(values, "\r\n").replace(" ", "\t")))
    zipped = bvh.load(write(tmp_path / "c.bvh.gz", custom_text(values, "\r\n"), compress=True))
    for other in (crlf, zipped):
        assert other.skeleton == plain.skeleton
        np.testing.assert_array_equal(other.rotations, plain.rotations)
        np.testing.assert_array_equal(other.positions, plain.positions)


def test_quaternions_are_sign_continuous(tmp_path):
    values = custom_values(num_frames=5, seed=3)
    values[:, 6:9] = [[0, 170, 0], [0, 179, 0], [0, -179, 0], [0, -170, 0], [0, 175, 0]]  # Chest Y
    motion = bvh.load(write(tmp_path / "flip.bvh", custom_text(values)))
    q = motion.rotations
    assert np.all(np.sum(q[1:] * q[:-1], axis=-1) >= 0)
    assert_same_rotation(q[:, 1], scipy_quat(values[:, 6:9], "yxz"))


def test_motion_slicing_and_defaults(tmp_path):
    values = custom_values(num_frames=9, seed=4)
    motion = bvh.load(write(tmp_path / "m.bvh", custom_text(values)))
    part = motion[2:6]
    assert part.num_frames == 4 and len(part) == 4
    np.testing.assert_array_equal(part.rotations, motion.rotations[2:6])
    assert motion[3].num_frames == 1
    assert part.global_positions().shape == (4, 6, 3)
    # A Motion built from arrays (no channel layout, no End Sites) is written in the LAFAN1 layout.
    plain = bvh.Motion(motion.rotations, motion.positions, motion.skeleton, fps=30.0)
    bvh.save(tmp_path / "plain.bvh", plain)
    again = bvh.load(tmp_path / "plain.bvh")
    assert again.channels[0] == bvh.ROOT_CHANNELS and again.channels[1] == bvh.JOINT_CHANNELS
    np.testing.assert_allclose(again.global_positions()[:, 0], motion.global_positions()[:, 0],
                               atol=1e-5)
    # Non-root joints lose their animated position (only the root keeps position channels).
    np.testing.assert_allclose(again.positions[:, 1:], np.broadcast_to(
        motion.skeleton.offsets[1:], again.positions[:, 1:].shape), atol=1e-6)
    with pytest.raises(ValueError, match="joints"):
        bvh.Motion(motion.rotations[:, :3], motion.positions[:, :3], motion.skeleton, fps=30.0)


# ------------------------------------------------------------------------------ malformed files

def _replace_frame_line(text, index, new_line):
    lines = text.split("\n")
    lines[HEADER_LINES + index] = new_line
    return "\n".join(lines)


def _malformed_cases():
    text = custom_text(custom_values(num_frames=6, seed=5))
    first = HEADER_LINES + 1  # line number of frame 0
    frame2 = text.split("\n")[HEADER_LINES + 2]
    yield "truncated", "\n".join(text.split("\n")[:-3]) + "\n", first + 3, "truncated"
    yield "cut mid-line", text[: text.rindex(" ", 0, len(text) - 30)], first + 5, "values"
    yield "short line", _replace_frame_line(text, 2, frame2.rsplit(" ", 1)[0]), first + 2, "19 values"
    yield "non-numeric", _replace_frame_line(text, 2, "abc " + frame2.split(" ", 1)[1]), first + 2, "'abc'"
    yield "nan value", _replace_frame_line(text, 4, "nan " + frame2.split(" ", 1)[1]), first + 4, "nan"
    yield "extra frames", text + text.split("\n")[first] + "\n", first + 6, "more frame lines"
    yield "missing MOTION", text.replace("MOTION", "MOTON"), None, "MOTION"
    yield "bad OFFSET", text.replace("OFFSET 4.0 0.0 0.0", "OFFSET 4.0 x 0.0"), 21, "number"
    yield "bad channel", text.replace("2 Xrotation Zrotation", "2 Xrotation Wrotation"), 22, "Wrotation"
    yield "bad Frames", text.replace("Frames: 6", "Frames: six"), HEADER_LINES - 1, "Frames"
    yield "unbalanced", text.replace("\t}\n}\nMOTION", "\t}\nMOTION"), HEADER_LINES - 3, "'}'"


@pytest.mark.parametrize("name,text,line,words", list(_malformed_cases()),
                         ids=[c[0] for c in _malformed_cases()])
def test_malformed_files_raise_bvherror_naming_the_line(tmp_path, name, text, line, words):
    path = write(tmp_path / "broken.bvh", text)
    with pytest.raises(bvh.BVHError) as info:
        bvh.load(path)
    message = str(info.value)
    assert str(path) in message
    if line is not None:
        assert f"line {line}:" in message
    assert words in message
    assert isinstance(info.value, ValueError)


@pytest.mark.parametrize("content", [b"", b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", b"MOTION\nFrames: 1\n"],
                         ids=["empty", "png", "no hierarchy"])
def test_a_file_without_hierarchy_is_not_a_bvh_file(tmp_path, content):
    path = tmp_path / "picture.bvh"
    path.write_bytes(content)
    with pytest.raises(bvh.BVHError, match="not a BVH file") as info:
        bvh.load(path)
    assert str(path) in str(info.value) and "no MOTION line" not in str(info.value)


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothere.bvh"):
        bvh.load(tmp_path / "nothere.bvh")


# ------------------------------------------------------------------------------ real data

def test_lafan1_skeleton(shared_data):
    motion = bvh.load(shared_data / "lafan1" / "walk4_subject1.bvh")
    assert motion.skeleton.names == LAFAN1_JOINTS
    assert motion.skeleton.parents == LAFAN1_PARENTS
    assert motion.fps == 30.0 and motion.num_frames == 4918
    assert motion.channels[0] == bvh.ROOT_CHANNELS
    assert all(c == bvh.JOINT_CHANNELS for c in motion.channels[1:])
    # The root's local position is the position channels; the others are their OFFSETs.
    np.testing.assert_allclose(motion.positions[0, 0], [-287.536011, 92.468430, 338.071991])
    np.testing.assert_allclose(motion.positions[:, 2], np.tile([43.5, -0.000019, -0.000008], (4918, 1)))


@pytest.mark.slow
def test_round_trip_every_shared_file(shared_data, tmp_path):
    files = sorted((shared_data / "lafan1").glob("*.bvh")) + [shared_data / "cmu" / "01_01.bvh"]
    assert len(files) >= 2
    for path in files:
        motion = bvh.load(path)
        out = tmp_path / "out.bvh"
        bvh.save(out, motion)
        again = bvh.load(out)
        assert isinstance(again.skeleton, Skeleton) and again.skeleton == motion.skeleton, path.name
        assert again.channels == motion.channels and again.end_sites == motion.end_sites, path.name
        assert again.num_frames == motion.num_frames and again.fps == motion.fps, path.name
        err = np.max(np.abs(again.global_positions() - motion.global_positions()))
        assert err < 1e-4, f"{path.name}: global positions differ by {err} cm after a round trip"
