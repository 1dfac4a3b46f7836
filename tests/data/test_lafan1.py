"""LAFAN1 listing, windows, statistics and the on-disk cache, on the bundled excerpt and shared data."""
import gzip
import os
import re
import shutil

import numpy as np
import pytest

from stitchjax.data import bvh, cache, lafan1
from stitchjax.data.bundled import sample_dir
from stitchjax.skeleton import LAFAN1_FEET, LAFAN1_PARENTS
from stitchjax.data.windows import foot_contacts, window_starts, window_statistics


def frame_count(path):
    opener = gzip.open if str(path).endswith(".gz") else open
    with opener(path, "rt") as f:
        for line in f:
            if line.strip().startswith("Frames:"):
                return int(line.split(":")[1])


def per_file_counts(windows):
    counts = {}
    for s in windows.sources:
        name = s.rsplit(":", 1)[0]
        counts[name] = counts.get(name, 0) + 1
    return counts


def assert_aligned(windows, frame=9):
    """Root x/z mean zero per window and root forward (local +Y, flattened) == +X at ``frame``."""
    from stitchjax import rotations as R
    root = windows.positions[:, :, 0]
    np.testing.assert_allclose(root[..., [0, 2]].mean(axis=1), 0.0, atol=1e-9)
    fwd = R.quat_rotate(windows.rotations[:, frame, 0], np.array([0.0, 1.0, 0.0]))
    fwd[:, 1] = 0.0
    fwd /= np.linalg.norm(fwd, axis=-1, keepdims=True)
    np.testing.assert_allclose(fwd, np.tile([1.0, 0.0, 0.0], (len(windows), 1)), atol=1e-6)


@pytest.fixture(scope="module")
def sample_test_set(tmp_path_factory):
    return lafan1.test_windows(sample_dir(), cache_dir=tmp_path_factory.mktemp("cache"))


def test_list_files_by_subject():
    files = lafan1.list_files(sample_dir())
    assert set(files) == {"subject1", "subject2", "subject3", "subject5"}
    assert [p.name for p in files["subject1"]] == ["obstacles1_subject1.bvh.gz", "walk4_subject1.bvh.gz"]


def test_test_windows_on_sample(sample_test_set):
    w = sample_test_set
    assert w.rotations.shape == (19, 65, 22, 4) and w.positions.shape == (19, 65, 22, 3)
    assert w.contacts.shape == (19, 65, 4) and w.rotations.dtype == np.float64
    assert w.fps == 30.0 and w.skeleton.parents == LAFAN1_PARENTS
    assert w.sources[0] == "obstacles1_subject5.bvh.gz:0" and w.sources[-1].endswith(":720")
    assert_aligned(w)
    assert set(np.unique(w.contacts)) <= {0.0, 1.0}


def test_contacts_are_those_of_the_raw_windows(sample_test_set):
    path = sample_dir() / "obstacles1_subject5.bvh.gz"
    motion = bvh.load(path)
    for k in (0, 7, 18):
        raw = motion[40 * k: 40 * k + 65]
        expected = foot_contacts(raw.global_positions(), LAFAN1_FEET)
        np.testing.assert_array_equal(sample_test_set.contacts[k], expected)
    # Alignment is a rigid motion of the whole window: joint heights are unchanged.
    raw = motion[40 * 7: 40 * 7 + 65].global_positions()
    np.testing.assert_allclose(sample_test_set[7].global_positions()[0, ..., 1], raw[..., 1], atol=1e-9)


def test_training_windows_counts_and_statistics(tmp_path):
    subjects = ("subject1", "subject2", "subject3", "subject4")
    w = lafan1.load_windows(sample_dir(), subjects, 50, 20, cache_dir=False)
    files = [p for s in subjects for p in lafan1.list_files(sample_dir()).get(s, [])]
    expected = {p.name: len(window_starts(frame_count(p), 50, 20)) for p in files}
    assert per_file_counts(w) == expected
    assert len(w) == sum(expected.values())
    assert_aligned(w)
    stats = lafan1.train_statistics(sample_dir(), cache_dir=tmp_path)
    direct = window_statistics(w)  # FK of every aligned window
    assert stats.mean.shape == (66,) and stats.std.shape == (66,) and stats.offsets.shape == (22, 3)
    np.testing.assert_allclose(stats.mean, direct.mean, atol=1e-9)
    np.testing.assert_allclose(stats.std, direct.std, rtol=1e-10)
    g = w.global_positions().reshape(-1, 66)
    np.testing.assert_allclose(stats.std, g.std(axis=0), rtol=1e-10)  # population std (ddof=0)
    np.testing.assert_allclose(stats.offsets[1:], w.skeleton.offsets[1:], atol=1e-9)
    np.testing.assert_array_equal(stats.offsets[0], 0.0)


def test_missing_folder_and_subjects_give_clear_errors(tmp_path):
    with pytest.raises(lafan1.LAFAN1NotFoundError, match="does not exist"):
        lafan1.test_windows(tmp_path / "nowhere")
    with pytest.raises(lafan1.LAFAN1NotFoundError, match="no LAFAN1 files"):
        lafan1.train_statistics(tmp_path, cache_dir=False)  # empty folder
    shutil.copy(sample_dir() / "walk4_subject1.bvh.gz", tmp_path)
    with pytest.raises(lafan1.LAFAN1NotFoundError, match=r"subject5.*subject1 \(1 files\)"):
        lafan1.test_windows(tmp_path, cache_dir=False)
    only_test = tmp_path / "test_only"
    only_test.mkdir()
    shutil.copy(sample_dir() / "obstacles1_subject5.bvh.gz", only_test)
    with pytest.raises(FileNotFoundError, match="subject1, subject2, subject3, subject4"):
        lafan1.train_statistics(only_test, cache_dir=False)


def short_bvh(src, dst, frames):
    """Write the first ``frames`` frames of a gzipped release file as plain text .bvh."""
    with gzip.open(src, "rt") as f:
        text = f.read()
    head, body = text.split("Frame Time:", 1)
    frame_time, rest = body.split("\n", 1)
    lines = rest.splitlines()[:frames]
    head = re.sub(r"Frames:\s*\d+", f"Frames: {frames}", head)
    dst.write_text(head + "Frame Time:" + frame_time + "\n" + "\n".join(lines) + "\n")


def test_cache_hit_identical_and_changed_content_invalidates(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    path = data / "walk4_subject5.bvh"
    short_bvh(sample_dir() / "walk4_subject1.bvh.gz", path, 200)
    store = tmp_path / "cache"
    first = lafan1.test_windows(data, cache_dir=store)
    assert len(first) == len(window_starts(200, 65, 40)) == 4
    assert len(list(store.glob("*.npz"))) == 1
    second = lafan1.test_windows(data, cache_dir=store)
    for name in ("rotations", "positions", "contacts"):
        np.testing.assert_array_equal(getattr(second, name), getattr(first, name))
    assert second.sources == first.sources and second.skeleton == first.skeleton
    uncached = lafan1.test_windows(data, cache_dir=False)
    np.testing.assert_array_equal(uncached.positions, first.positions)
    # Change one digit of a root position in frame 0: same size, same modification time.
    stat = os.stat(path)
    text = path.read_text()
    start = text.index("Frame Time:")
    line_start = text.index("\n", start) + 1
    digit = line_start + next(i for i, c in enumerate(text[line_start:]) if c.isdigit())
    new_digit = "5" if text[digit] != "5" else "6"
    path.write_text(text[:digit] + new_digit + text[digit + 1:])
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    assert os.stat(path).st_size == stat.st_size
    changed = lafan1.test_windows(data, cache_dir=store)
    assert not np.array_equal(changed.positions[0, 0, 0], first.positions[0, 0, 0])
    np.testing.assert_array_equal(changed.positions, lafan1.test_windows(data, cache_dir=False).positions)
    assert len(list(store.glob("*.npz"))) == 2


def test_gz_and_plain_bvh_give_the_same_windows(tmp_path):
    plain = tmp_path / "walk4_subject5.bvh"
    with gzip.open(sample_dir() / "walk4_subject1.bvh.gz", "rb") as f:
        plain.write_bytes(f.read())
    gz_dir = tmp_path / "gz"
    gz_dir.mkdir()
    shutil.copy(sample_dir() / "walk4_subject1.bvh.gz", gz_dir / "walk4_subject5.bvh.gz")
    a = lafan1.test_windows(tmp_path, cache_dir=False)
    b = lafan1.test_windows(gz_dir, cache_dir=False)
    np.testing.assert_array_equal(a.rotations, b.rotations)
    np.testing.assert_array_equal(a.contacts, b.contacts)


def test_cache_dir_resolution(tmp_path, monkeypatch):
    monkeypatch.setenv("STITCHJAX_CACHE_DIR", str(tmp_path / "env"))
    assert cache.resolve_cache_dir() == tmp_path / "env"
    assert cache.resolve_cache_dir(tmp_path / "arg") == tmp_path / "arg"
    assert cache.resolve_cache_dir(False) is None
    monkeypatch.setenv("STITCHJAX_CACHE_DIR", "off")
    assert cache.resolve_cache_dir() is None
    monkeypatch.delenv("STITCHJAX_CACHE_DIR")
    assert cache.resolve_cache_dir().parts[-2:] == (".cache", "stitchjax")


def test_corrupt_cache_entry_is_recomputed(tmp_path):
    calls = []

    def compute():
        calls.append(1)
        return {"x": np.arange(3.0)}

    out = cache.cached("unit", [], {"a": 1}, compute, cache_dir=tmp_path)
    (entry,) = tmp_path.glob("*.npz")
    entry.write_bytes(b"not a zip file")
    again = cache.cached("unit", [], {"a": 1}, compute, cache_dir=tmp_path)
    np.testing.assert_array_equal(again["x"], out["x"])
    assert len(calls) == 2
    cache.cached("unit", [], {"a": 1}, compute, cache_dir=tmp_path)
    assert len(calls) == 2  # rewritten entry is a hit
    assert not list(tmp_path.glob("*.tmp"))  # no temporary files left behind


def test_shared_test_set_counts(shared_data, tmp_path):
    folder = shared_data / "lafan1"
    w = lafan1.test_windows(folder, cache_dir=tmp_path)
    files = lafan1.list_files(folder)["subject5"]
    expected = {p.name: len(window_starts(frame_count(p), 65, 40)) for p in files}
    assert per_file_counts(w) == expected
    assert len(w) == 376  # the 3 subject5 files here; 2232 on the full release
    assert_aligned(w)


def test_cache_key_depends_on_params_content_and_code(tmp_path):
    a = tmp_path / "a.bvh"
    a.write_bytes(b"one")
    key = cache.cache_key("k", [a], {"window": 50})
    assert cache.cache_key("k", [a], {"window": 50}) == key
    assert cache.cache_key("k", [a], {"window": 65}) != key
    assert cache.cache_key("other", [a], {"window": 50}) != key
    assert cache.cache_key("k", [a], {"window": 50}, code=("stitchjax.data.windows",)) != key
    a.write_bytes(b"two")
    assert cache.cache_key("k", [a], {"window": 50}) != key


def test_plain_bvh_is_preferred_over_gz_and_other_files_ignored(tmp_path):
    shutil.copy(sample_dir() / "walk4_subject1.bvh.gz", tmp_path)
    (tmp_path / "walk4_subject1.bvh").write_text("x")
    (tmp_path / "notes.txt").write_text("x")
    (tmp_path / "walk4.bvh").write_text("x")  # no subject in the name
    assert lafan1.list_files(tmp_path) == {"subject1": [tmp_path / "walk4_subject1.bvh"]}
