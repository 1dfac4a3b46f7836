"""The bundled LAFAN1 excerpt."""
import gzip

import numpy as np

from stitchjax.data import bvh, bundled
from stitchjax.skeleton import LAFAN1_JOINTS, LAFAN1_PARENTS


def test_sample_has_training_and_test_clips():
    folder = bundled.sample_dir()
    assert folder.is_dir() and (folder / "LICENSE.txt").is_file() and (folder / "README.md").is_file()
    files = bundled.sample_files()
    names = [f.name for f in files]
    assert len(files) == len(bundled.SAMPLE_CLIPS)
    assert all(n.endswith(".bvh.gz") for n in names)
    train = bundled.sample_files(["subject1", "subject2", "subject3", "subject4"])
    test = bundled.sample_files(["subject5"])
    assert len(train) >= 3 and len(test) == 1
    assert sorted(train + test) == files
    total = sum(f.stat().st_size for f in files)
    assert total < 4e6, f"sample is {total / 1e6:.1f} MB"


def test_sample_clips_load_as_lafan1():
    for path, (stem, start, stop) in zip(bundled.sample_files(), sorted(bundled.SAMPLE_CLIPS)):
        assert path.name == f"{stem}.bvh.gz"
        motion = bvh.load(path)
        assert motion.skeleton.names == LAFAN1_JOINTS
        assert motion.skeleton.parents == LAFAN1_PARENTS
        assert motion.fps == 30.0
        assert motion.num_frames == stop - start
        q = motion.rotations
        np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-9)
        assert np.all(np.sum(q[1:] * q[:-1], axis=-1) >= 0)
        assert 50 < motion.global_positions()[:, 13, 1].mean() < 250  # head height in cm
    test = bvh.load(bundled.sample_files(["subject5"])[0])
    assert (test.num_frames - 65) // 40 + 1 >= 5  # several test windows of 65 frames, offset 40


def test_sample_is_an_unmodified_excerpt(shared_data, tmp_path):
    """The bundled bytes are the release's hierarchy and frame lines (only ``Frames:`` differs)."""
    for path, (stem, start, stop) in zip(bundled.sample_files(), sorted(bundled.SAMPLE_CLIPS)):
        excerpt = gzip.decompress(path.read_bytes())
        original = (shared_data / "lafan1" / f"{stem}.bvh").read_bytes()
        assert excerpt == bundled.excerpt_text(shared_data / "lafan1" / f"{stem}.bvh", start, stop)
        lines, source = excerpt.splitlines(keepends=True), original.splitlines(keepends=True)
        motion = lines.index(b"MOTION\r\n") if b"MOTION\r\n" in lines else lines.index(b"MOTION\n")
        assert lines[: motion + 1] == source[: motion + 1]
        assert lines[motion + 1].strip() == b"Frames: %d" % (stop - start)
        assert lines[motion + 3:] == source[motion + 3 + start: motion + 3 + stop]
        full = bvh.load(shared_data / "lafan1" / f"{stem}.bvh")
        part = bvh.load(path)
        np.testing.assert_array_equal(part.positions, full.positions[start:stop])
