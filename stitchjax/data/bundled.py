"""The bundled LAFAN1 excerpt: a few real clips so the pipeline and the tests run without the dataset.

``sample_dir()`` is a folder laid out like the LAFAN1 release (``<action><n>_subject<k>.bvh.gz``), so
everything that takes "the LAFAN1 folder" (subject splits by file name included) accepts it. It holds
four training clips (subjects 1-4) and one test clip (subject5), each a contiguous range of frames of
the real file, unmodified: the original text of the hierarchy and of those frame lines, with only
the ``Frames:`` count changed, gzip-compressed. Licence: CC BY-NC-ND 4.0 (``LICENSE.txt`` beside the
files); cite Harvey et al., "Robust Motion In-betweening", SIGGRAPH 2020 (``README.md`` beside them).

The excerpt was made from the release with :func:`build_sample`::

    python -c "from stitchjax.data.bundled import build_sample; build_sample('../shared/data/lafan1')"
"""
from __future__ import annotations

import gzip
import pathlib
import shutil

SAMPLE_DIR = pathlib.Path(__file__).resolve().parent / "sample_data" / "lafan1"

# (release file stem, first frame, end frame (exclusive)): frames counted from 0 after "Frame Time:".
SAMPLE_CLIPS = (
    ("walk4_subject1", 1200, 2400),            # walking at varied speeds, turns
    ("dance1_subject2", 2000, 2800),           # dancing
    ("obstacles1_subject1", 1800, 3000),       # walking/running over obstacles, climbing and vaulting
    ("obstacles3_subject3", 200, 800),         # running
    ("obstacles1_subject5", 1000, 1800),       # test subject: 800 frames = 19 windows of 65 / offset 40
)


def sample_dir() -> pathlib.Path:
    """Folder of the bundled LAFAN1 excerpt (``stitchjax/data/sample_data/lafan1``)."""
    return SAMPLE_DIR


def sample_files(subjects=None) -> list:
    """Sorted paths of the excerpt's ``*.bvh.gz`` files, optionally only those of ``subjects``
    (e.g. ``("subject5",)``), matched on the ``_subject<k>`` end of the file name."""
    files = sorted(SAMPLE_DIR.glob("*.bvh.gz"))
    if subjects is not None:
        wanted = {s.lower() for s in subjects}
        files = [f for f in files if f.name.split(".")[0].rsplit("_", 1)[-1].lower() in wanted]
    return files


def excerpt_text(source, start: int, stop: int) -> bytes:
    """Frames ``start``..``stop - 1`` of the BVH file ``source`` as the original bytes of its
    hierarchy and of those frame lines (line endings kept), with the ``Frames:`` line updated."""
    data = pathlib.Path(source).read_bytes()
    lines = data.splitlines(keepends=True)
    motion = next(i for i, line in enumerate(lines) if line.strip().upper() == b"MOTION")
    frames_line = lines[motion + 1]
    if not frames_line.strip().lower().startswith(b"frames:"):
        raise ValueError(f"{source}, line {motion + 2}: expected 'Frames:', found {frames_line!r}")
    total = int(frames_line.split(b":")[1])
    if not 0 <= start < stop <= total:
        raise ValueError(f"{source} has {total} frames; cannot take frames {start}..{stop - 1}")
    ending = frames_line[len(frames_line.rstrip(b"\r\n")):]
    header = lines[: motion + 1] + [b"Frames: %d" % (stop - start) + ending, lines[motion + 2]]
    body = lines[motion + 3 + start: motion + 3 + stop]
    return b"".join(header + body)


def build_sample(lafan1_dir, out_dir=None, clips=SAMPLE_CLIPS) -> list:
    """Write the excerpt (``<stem>.bvh.gz`` for each clip, plus LICENSE.txt) into ``out_dir``
    (default: the package's sample folder). Returns the written clip paths."""
    lafan1_dir = pathlib.Path(lafan1_dir)
    out_dir = pathlib.Path(out_dir) if out_dir is not None else SAMPLE_DIR
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for stem, start, stop in clips:
        text = excerpt_text(lafan1_dir / f"{stem}.bvh", start, stop)
        path = out_dir / f"{stem}.bvh.gz"
        path.write_bytes(gzip.compress(text, compresslevel=9, mtime=0))
        written.append(path)
    shutil.copyfile(lafan1_dir / "LICENSE.txt", out_dir / "LICENSE.txt")
    return written
