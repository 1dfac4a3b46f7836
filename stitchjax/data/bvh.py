"""Read and write BVH motion files.

Size (~520 lines): one job, the format; most of the reader is its error reporting, which names the file,
the line and the fix for every malformed case (tests/data/test_bvh.py).

A BVH file is a joint hierarchy (names, bone offsets, per-joint channel lists, End Sites) followed by
a MOTION block with one line of channel values per frame. :func:`load` turns it into a
:class:`Motion` of local quaternions and local positions; :func:`save` writes one back with the same
hierarchy and channel layout.

Conventions (docs/design.md §3-4): quaternions are (w, x, y, z), Hamilton; a joint's rotation channels in
file order ``Zrotation Yrotation Xrotation`` (order ``"zyx"``, degrees in the file) give
``q = q_z * q_y * q_x``. A joint with position channels has an animated local position (the channel
values, which replace its OFFSET); every other joint's local position is its OFFSET. Positions stay
in the file's units (LAFAN1: centimetres).

Any hierarchy, any rotation order, 0-3 rotation and 0-3 position channels on any joint, tabs, CRLF
line endings and gzip-compressed files (``.bvh.gz``) are supported. A malformed file raises
:class:`BVHError` naming the file, the line and what is wrong.
"""
from __future__ import annotations

import dataclasses
import gzip
import io
import os
import pathlib
import re
import zlib

import numpy as np

from stitchjax import rotations as R
from stitchjax.skeleton import GlobalTransforms, Skeleton

__all__ = ["BVHError", "Motion", "load", "save", "file_stem", "ROOT_CHANNELS", "JOINT_CHANNELS"]

_POSITION_CHANNELS = {"xposition": 0, "yposition": 1, "zposition": 2}
_ROTATION_CHANNELS = {"xrotation": "x", "yrotation": "y", "zrotation": "z"}
_CANONICAL = {
    "xposition": "Xposition", "yposition": "Yposition", "zposition": "Zposition",
    "xrotation": "Xrotation", "yrotation": "Yrotation", "zrotation": "Zrotation",
}
# Channel layout of LAFAN1 (and most mocap BVH): used by save() when a Motion carries no channels.
ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
JOINT_CHANNELS = ("Zrotation", "Yrotation", "Xrotation")


class BVHError(ValueError):
    """A BVH file that cannot be read (the message names the file, the line and the problem)."""


@dataclasses.dataclass(frozen=True, eq=False)
class Motion(GlobalTransforms):
    """One BVH take as local joint transforms.

    Attributes:
      rotations: (T, J, 4) local unit quaternions (w, x, y, z), sign-continuous over time.
      positions: (T, J, 3) local positions in file units: the position channels of joints that have
        them (the root's trajectory), the constant OFFSET for every other joint.
      skeleton: hierarchy; ``skeleton.offsets`` are the file's OFFSETs (J, 3).
      fps: frames per second (1 / Frame Time, rounded to a whole number when within 0.01%).
      channels: per joint, its BVH channel names in file order, e.g. ("Zrotation", "Yrotation",
        "Xrotation"); ``None`` means the LAFAN1 layout (root 6 channels, others ZYX rotations).
      end_sites: ((joint index, (x, y, z) offset), ...) End Sites for writing back; ``None`` means a
        zero-offset End Site under every leaf joint.
    """

    rotations: np.ndarray
    positions: np.ndarray
    skeleton: Skeleton
    fps: float
    channels: tuple | None = None
    end_sites: tuple | None = None

    def __post_init__(self):
        t, j = np.shape(self.rotations)[:2]
        if np.shape(self.rotations) != (t, j, 4) or np.shape(self.positions) != (t, j, 3):
            raise ValueError(
                f"Motion needs rotations (T, J, 4) and positions (T, J, 3); got "
                f"{np.shape(self.rotations)} and {np.shape(self.positions)}")
        if j != self.skeleton.num_joints:
            raise ValueError(f"Motion has {j} joints but its skeleton has {self.skeleton.num_joints}")
        if self.channels is not None:
            channels = tuple(tuple(str(c) for c in ch) for ch in self.channels)
            if len(channels) != j:
                raise ValueError(f"channels lists {len(channels)} joints, skeleton has {j}")
            object.__setattr__(self, "channels", channels)

    @property
    def num_frames(self) -> int:
        return int(np.shape(self.rotations)[0])

    @property
    def num_joints(self) -> int:
        return self.skeleton.num_joints

    def __len__(self) -> int:
        return self.num_frames

    def __getitem__(self, frames) -> "Motion":
        """Frames ``frames`` (a slice, an index array, or an int kept as a 1-frame Motion)."""
        if isinstance(frames, (int, np.integer)):
            frames = slice(int(frames), int(frames) + 1 if frames != -1 else None)
        return dataclasses.replace(self, rotations=self.rotations[frames],
                                   positions=self.positions[frames])

    def with_frames(self, rotations, positions) -> "Motion":
        """Same skeleton, fps and channel layout with new (T', J, 4) rotations, (T', J, 3) positions."""
        return dataclasses.replace(self, rotations=rotations, positions=positions)

    def __repr__(self):
        return (f"Motion({self.num_frames} frames, {self.num_joints} joints, fps={self.fps:g}, "
                f"root={self.skeleton.names[0]!r})")


# ----------------------------------------------------------------------------------------- reading

def _read_text(path: pathlib.Path) -> str:
    try:
        with open(path, "rb") as f:
            data = f.read()
    except FileNotFoundError:
        raise FileNotFoundError(f"BVH file not found: {path}") from None
    except IsADirectoryError:
        raise FileNotFoundError(f"expected a BVH file, got a directory: {path}") from None
    if data[:2] == b"\x1f\x8b":
        try:
            data = gzip.decompress(data)
        except (OSError, EOFError, zlib.error) as e:
            raise BVHError(f"{path}: corrupt gzip data ({e}); re-download or re-compress the file") from None
    if data[:3] == b"\xef\xbb\xbf":  # UTF-8 byte order mark
        data = data[3:]
    text = data.decode("latin-1")
    if "\n" not in text:  # classic Mac line endings (CR only)
        text = text.replace("\r", "\n")
    return text


class _Tokens:
    """The hierarchy as a token stream that remembers each token's line number."""

    def __init__(self, path, lines, first_line: int):
        self.path = path
        self.items = []
        for n, line in enumerate(lines):
            for tok in line.replace("{", " { ").replace("}", " } ").split():
                self.items.append((tok, first_line + n))
        self.i = 0
        self.last_line = first_line + len(lines)  # the MOTION line

    def error(self, message, line=None):
        if line is None:
            line = self.items[self.i][1] if self.i < len(self.items) else self.last_line
        return BVHError(f"{self.path}, line {line}: {message}")

    def peek(self):
        return self.items[self.i][0] if self.i < len(self.items) else None

    def next(self, what):
        if self.i >= len(self.items):
            raise self.error(f"hierarchy ends early: expected {what} before MOTION")
        tok, line = self.items[self.i]
        self.i += 1
        return tok, line

    def expect(self, word):
        tok, line = self.next(repr(word))
        if tok.lower() != word.lower():
            raise self.error(f"expected {word!r}, found {tok!r}", line)
        return line

    def rest_of_line(self, line):
        """Tokens after the current position that are on ``line`` (stopping at '{')."""
        out = []
        while self.i < len(self.items) and self.items[self.i][1] == line and self.peek() != "{":
            out.append(self.items[self.i][0])
            self.i += 1
        return out

    def floats(self, count, what):
        values = []
        for _ in range(count):
            tok, line = self.next(what)
            try:
                values.append(float(tok))
            except ValueError:
                raise self.error(f"{what}: expected a number, found {tok!r}", line) from None
        return values


def _parse_channels(tokens: _Tokens, name: str) -> tuple:
    """The canonical channel names of joint `name`'s CHANNELS line (the next token is CHANNELS)."""
    _, line = tokens.next("CHANNELS")
    count_tok, _ = tokens.next("channel count")
    if not count_tok.isdigit():
        raise tokens.error(f"CHANNELS of joint {name!r}: expected a count, found {count_tok!r}", line)
    found = []
    for _ in range(int(count_tok)):
        tok, cline = tokens.next(f"{count_tok} channel names for joint {name!r}")
        if tok.lower() not in _CANONICAL:
            hint = (" (fewer channel names than the count?)" if cline != line
                    else "; channels are X/Y/Z position and X/Y/Z rotation")
            raise tokens.error(f"joint {name!r}: unknown channel {tok!r}{hint}", cline)
        found.append(_CANONICAL[tok.lower()])
    extra = tokens.rest_of_line(line)
    if extra:
        raise tokens.error(f"joint {name!r}: CHANNELS {count_tok} is followed by more than "
                           f"{count_tok} names ({' '.join(extra)})", line)
    if len(set(found)) != len(found):
        raise tokens.error(f"joint {name!r} lists a channel twice: {' '.join(found)}", line)
    return tuple(found)


def _parse_hierarchy(tokens: _Tokens):
    """Returns names, parents, offsets, channels (canonical names), end sites."""
    names, parents, offsets, channels, end_sites = [], [], [], [], []

    def joint(parent, keyword_line):
        name = " ".join(tokens.rest_of_line(keyword_line))
        if not name:
            raise tokens.error("joint without a name", keyword_line)
        if name in names:
            raise tokens.error(f"joint name {name!r} appears twice", keyword_line)
        index = len(names)
        names.append(name)
        parents.append(parent)
        tokens.expect("{")
        tokens.expect("OFFSET")
        offsets.append(tokens.floats(3, f"OFFSET of joint {name!r}"))
        chans = _parse_channels(tokens, name) if (tokens.peek() or "").upper() == "CHANNELS" else ()
        channels.append(chans)
        while True:
            tok, line = tokens.next(f"'}}' closing joint {name!r}")
            word = tok.upper()
            if tok == "}":
                return
            if word == "JOINT":
                joint(index, line)
            elif word == "END":
                tokens.rest_of_line(line)  # "Site"
                tokens.expect("{")
                tokens.expect("OFFSET")
                end_sites.append((index, tuple(tokens.floats(3, f"End Site OFFSET of {name!r}"))))
                tokens.expect("}")
            elif word == "ROOT":
                raise tokens.error("a second ROOT; only one skeleton per file is supported", line)
            else:
                raise tokens.error(f"unexpected {tok!r} inside joint {name!r} (expected JOINT, "
                                   f"End Site or '}}')", line)

    if (tokens.peek() or "").upper() != "HIERARCHY":
        raise tokens.error("not a BVH file: it must start with HIERARCHY")
    tokens.next("HIERARCHY")
    _, line = tokens.next("ROOT")
    if tokens.items[tokens.i - 1][0].upper() != "ROOT":
        raise tokens.error(f"expected ROOT, found {tokens.items[tokens.i - 1][0]!r}", line)
    joint(-1, line)
    if tokens.peek() is not None:
        tok, line = tokens.next("MOTION")
        if tok.upper() == "ROOT":
            raise tokens.error("a second ROOT; only one skeleton per file is supported", line)
        raise tokens.error(f"unexpected {tok!r} after the hierarchy (expected MOTION)", line)
    return names, parents, np.array(offsets, dtype=np.float64), tuple(channels), tuple(end_sites)


_HIERARCHY_RE = re.compile(r"\s*HIERARCHY\b", re.IGNORECASE)  # the first word of a BVH file
_MOTION_RE = re.compile(r"^[ \t]*MOTION[ \t]*\r?$", re.MULTILINE | re.IGNORECASE)


def _header_value(path, lines, index, key, first_line):
    if index >= len(lines):
        raise BVHError(f"{path}, line {first_line + index}: file ends before the '{key}:' line")
    line = lines[index].strip()
    label, _, value = line.partition(":")
    if " ".join(label.split()).lower() != key.lower():
        raise BVHError(f"{path}, line {first_line + index}: expected '{key}: <number>', found {line!r}")
    try:
        return float(value)
    except ValueError:
        raise BVHError(f"{path}, line {first_line + index}: '{key}:' needs a number, found "
                       f"{value.strip()!r}") from None


def _find_bad_line(path, body: str, first_line: int, num_channels: int, num_frames: int):
    """The slow path after the fast parse failed: walk the lines and describe the first problem."""
    frames = 0
    line_no = first_line
    for n, line in enumerate(body.splitlines()):
        line_no = first_line + n
        values = line.split()
        if not values:
            continue
        if frames == num_frames:
            return BVHError(f"{path}, line {line_no}: more frame lines than 'Frames: {num_frames}' "
                            f"announces (fix the Frames count or remove the extra lines)")
        if len(values) != num_channels:
            return BVHError(f"{path}, line {line_no}: frame {frames} has {len(values)} values but "
                            f"the hierarchy declares {num_channels} channels")
        for col, v in enumerate(values):
            try:
                float(v)
            except ValueError:
                return BVHError(f"{path}, line {line_no}: frame {frames}, channel {col}: "
                                f"{v!r} is not a number")
        frames += 1
    if frames < num_frames:
        return BVHError(f"{path}, line {line_no}: motion block is truncated: 'Frames: {num_frames}' "
                        f"but the file ends after {frames} frames (the last one on this line)")
    return BVHError(f"{path}: could not read the motion block (lines {first_line}-{line_no})")


def _fps_from_frame_time(frame_time: float) -> float:
    fps = 1.0 / frame_time
    whole = round(fps)
    return float(whole) if whole > 0 and abs(fps - whole) <= 1e-4 * whole else fps


def _pad_order(order: str) -> str:
    """A 1- or 2-axis rotation order completed to three distinct axes (extra angles are zero)."""
    return order + "".join(a for a in "xyz" if a not in order)[: 3 - len(order)]


def file_stem(path) -> str:
    """A BVH file's name without its ``.bvh`` / ``.gz`` endings (either or both, any case): its take's name.
    ``"walk1_subject1.bvh.gz"`` -> ``"walk1_subject1"``; ``path``: a path or a file name."""
    name = pathlib.Path(path).name
    for suffix in (".gz", ".bvh"):
        if name.lower().endswith(suffix):
            name = name[: -len(suffix)]
    return name


def load(path) -> Motion:
    """Read a ``.bvh`` or ``.bvh.gz`` file into a :class:`Motion` (float64).

    Raises FileNotFoundError for a missing file and :class:`BVHError` (a ValueError) naming the line
    for a malformed one.
    """
    path = pathlib.Path(os.fspath(path))
    text = _read_text(path)
    if not _HIERARCHY_RE.match(text):
        what = "it is empty" if not text.strip() else "its first line is not HIERARCHY"
        raise BVHError(f"{path}: not a BVH file: {what} (a BVH file starts with a HIERARCHY block, then "
                       f"MOTION); pass a .bvh or .bvh.gz file")
    match = _MOTION_RE.search(text)
    if match is None:
        raise BVHError(f"{path}: no MOTION line: the file has a hierarchy but no motion block "
                       f"(or is not a BVH file)")
    head_lines = text[: match.start()].splitlines()
    tokens = _Tokens(path, head_lines, 1)
    names, parents, offsets, channels, end_sites = _parse_hierarchy(tokens)
    skeleton = Skeleton(names, parents, offsets)

    motion_line = len(head_lines) + 1
    # The three header lines after MOTION, then the frame lines in one piece.
    rest = text[match.end():]
    rest = rest[1:] if rest.startswith("\n") else rest
    parts = rest.split("\n", 2)
    num_frames_f = _header_value(path, parts, 0, "Frames", motion_line + 1)
    if not (0 <= num_frames_f < 2**40 and num_frames_f == int(num_frames_f)):
        raise BVHError(f"{path}, line {motion_line + 1}: 'Frames:' must be a whole number, "
                       f"found {num_frames_f:g}")
    num_frames = int(num_frames_f)
    frame_time = _header_value(path, parts, 1, "Frame Time", motion_line + 1)
    if not frame_time > 0:
        raise BVHError(f"{path}, line {motion_line + 2}: 'Frame Time:' must be positive, "
                       f"found {frame_time:g}")
    body = parts[2] if len(parts) > 2 else ""
    first_line = motion_line + 3
    num_channels = sum(len(c) for c in channels)

    if num_channels == 0 or num_frames == 0:
        if num_channels and body.strip():
            raise _find_bad_line(path, body, first_line, num_channels, num_frames)
        values = np.zeros((num_frames, num_channels))
    else:
        try:
            values = np.loadtxt(io.StringIO(body), dtype=np.float64, ndmin=2, comments=None)
        except ValueError:
            raise _find_bad_line(path, body, first_line, num_channels, num_frames) from None
        if values.shape != (num_frames, num_channels):
            raise _find_bad_line(path, body, first_line, num_channels, num_frames)
        if not np.all(np.isfinite(values)):
            t, c = np.argwhere(~np.isfinite(values))[0]
            bad = _nth_nonblank_line(body, t)
            raise BVHError(f"{path}, line {first_line + bad}: frame {t}, channel {c} is "
                           f"{values[t, c]} (not a finite number)")

    rotations, positions = _channels_to_local(values, channels, offsets, num_frames)
    return Motion(rotations=rotations, positions=positions, skeleton=skeleton,
                  fps=_fps_from_frame_time(frame_time), channels=channels, end_sites=end_sites)


def _nth_nonblank_line(body: str, n: int) -> int:
    count = -1
    for i, line in enumerate(body.splitlines()):
        if line.strip():
            count += 1
            if count == n:
                return i
    return 0


def _layout(channels):
    """Column indices per joint: (position axes, position columns), (rotation order, columns)."""
    column = 0
    layout = []
    for chans in channels:
        pos_axes, pos_cols, rot_axes, rot_cols = [], [], [], []
        for name in chans:
            key = name.lower()
            if key in _POSITION_CHANNELS:
                pos_axes.append(_POSITION_CHANNELS[key])
                pos_cols.append(column)
            else:
                rot_axes.append(_ROTATION_CHANNELS[key])
                rot_cols.append(column)
            column += 1
        layout.append((pos_axes, pos_cols, "".join(rot_axes), rot_cols))
    return layout


def _channels_to_local(values, channels, offsets, num_frames):
    """(T, C) channel values -> local rotations (T, J, 4), local positions (T, J, 3)."""
    num_joints = len(channels)
    positions = np.broadcast_to(offsets, (num_frames, num_joints, 3)).copy()
    rotations = np.zeros((num_frames, num_joints, 4))
    rotations[..., 0] = 1.0
    groups = {}  # padded rotation order -> (joints, (k, 3) column table with -1 = zero angle)
    for j, (pos_axes, pos_cols, order, rot_cols) in enumerate(_layout(channels)):
        if pos_axes:
            positions[:, j, pos_axes] = values[:, pos_cols]
        if order:
            padded = _pad_order(order)
            joints, cols = groups.setdefault(padded, ([], []))
            joints.append(j)
            cols.append(rot_cols + [-1] * (3 - len(rot_cols)))
    for order, (joints, cols) in groups.items():
        cols = np.array(cols)
        angles = np.deg2rad(values[:, np.maximum(cols, 0)])  # (T, k, 3)
        angles[:, cols < 0] = 0.0
        rotations[:, joints] = R.euler_to_quat(angles, order)
    rotations = R.quat_continuity(rotations, axis=0)
    return rotations, positions


# ----------------------------------------------------------------------------------------- writing

def _default_channels(num_joints):
    return (ROOT_CHANNELS,) + (JOINT_CHANNELS,) * (num_joints - 1)


def _local_to_channels(motion: Motion, channels) -> np.ndarray:
    """Local rotations and positions -> (T, C) channel values (degrees for rotations)."""
    rotations = np.asarray(motion.rotations, dtype=np.float64)
    positions = np.asarray(motion.positions, dtype=np.float64)
    layout = _layout(channels)
    num_frames = rotations.shape[0]
    values = np.zeros((num_frames, sum(len(c) for c in channels)))
    groups = {}
    for j, (pos_axes, pos_cols, order, rot_cols) in enumerate(layout):
        if pos_axes:
            values[:, pos_cols] = positions[:, j, pos_axes]
        if order:
            groups.setdefault(_pad_order(order), []).append((j, rot_cols))
    for order, members in groups.items():
        joints = [j for j, _ in members]
        angles = R.quat_to_euler(R.quat_normalize(rotations[:, joints]), order)
        for i, (_, cols) in enumerate(members):
            a = angles[:, i]
            if len(cols) < 3:
                # Only the first len(cols) angles are written, so pick, of the two equivalent
                # Tait-Bryan triples (a, b, c) and (a + pi, pi - b, c + pi), the one with c near 0.
                flip = np.abs(a[:, 2]) > np.pi / 2
                other = np.stack([a[:, 0] + np.pi, np.pi - a[:, 1], a[:, 2] + np.pi], axis=-1)
                a = np.where(flip[:, None], (other + np.pi) % (2 * np.pi) - np.pi, a)
            values[:, cols] = np.rad2deg(a[:, : len(cols)])
    return values


def _format_hierarchy(motion: Motion, channels, end_sites) -> list:
    skeleton = motion.skeleton
    sites = {}
    for j, offset in end_sites:
        sites.setdefault(int(j), []).append(offset)
    lines = ["HIERARCHY"]

    def vec(v):
        return " ".join(f"{float(x):.6f}" for x in v)

    def write(j, depth):
        pad = "\t" * depth
        keyword = "ROOT" if depth == 0 else "JOINT"
        lines.append(f"{pad}{keyword} {skeleton.names[j]}")
        lines.append(pad + "{")
        lines.append(f"{pad}\tOFFSET {vec(skeleton.offsets[j])}")
        if channels[j]:
            lines.append(f"{pad}\tCHANNELS {len(channels[j])} {' '.join(channels[j])}")
        for c in skeleton.children(j):
            write(c, depth + 1)
        for offset in sites.get(j, []):
            lines.extend([f"{pad}\tEnd Site", f"{pad}\t{{", f"{pad}\t\tOFFSET {vec(offset)}", f"{pad}\t}}"])
        lines.append(pad + "}")

    write(0, 0)
    return lines


def save(path, motion: Motion) -> None:
    """Write ``motion`` as BVH (gzip-compressed when ``path`` ends in ``.gz``).

    Rotations are written as Euler angles in degrees in each joint's channel order, values with six
    decimals; the hierarchy keeps the joint names, offsets, channel layout and End Sites. A joint's
    local position is written only through its position channels: joints without them get their
    skeleton OFFSET. Angles are written in (-180, 180] degrees (not unwrapped over time).
    """
    path = pathlib.Path(os.fspath(path))
    skeleton = motion.skeleton
    channels = motion.channels if motion.channels is not None else _default_channels(
        skeleton.num_joints)
    if motion.end_sites is None:
        end_sites = tuple((j, (0.0, 0.0, 0.0)) for j in range(skeleton.num_joints)
                          if not skeleton.children(j))
    else:
        end_sites = motion.end_sites
    values = _local_to_channels(motion, channels)
    lines = _format_hierarchy(motion, channels, end_sites)
    lines += ["MOTION", f"Frames: {motion.num_frames}", f"Frame Time: {1.0 / motion.fps:.8g}"]
    row = " ".join(["%.6f"] * values.shape[1]) + "\n"
    frames = (row * values.shape[0]) % tuple(values.ravel().tolist())
    data = ("\n".join(lines) + "\n" + frames).encode("latin-1")
    if path.suffix == ".gz":
        data = gzip.compress(data, compresslevel=6, mtime=0)
    with open(path, "wb") as f:
        f.write(data)
