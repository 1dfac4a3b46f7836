"""On-disk cache for preprocessed arrays (windows, statistics).

An entry is one ``.npz`` file (uncompressed, no pickles) named by a key that hashes

- a format version (:data:`FORMAT_VERSION`, bumped whenever the preprocessing changes),
- what is being computed (``kind``) and its parameters,
- the name and the full *content* (blake2b of the bytes) of every input file,
- the source code of the modules that compute the entry (``code``: module names).

So a changed input file (or a changed reader) can never be served stale, whatever its size or modification time. Entries
are written atomically (temporary file in the same folder, then ``os.replace``), so a crash or a
concurrent writer never leaves a half-written entry under a valid name; an unreadable entry is
treated as a miss and rewritten.

Where: the ``cache_dir`` argument when given; else ``$STITCHJAX_CACHE_DIR``; else
``~/.cache/stitchjax``. ``cache_dir=False`` (or ``STITCHJAX_CACHE_DIR=off``) disables caching.
Entries are never evicted automatically: delete the folder to reclaim the space.
"""
from __future__ import annotations

import hashlib
import json
import os
import pathlib
import tempfile

import numpy as np

__all__ = ["FORMAT_VERSION", "resolve_cache_dir", "file_digest", "cache_key", "load", "save", "cached"]

FORMAT_VERSION = 1
ENV_VAR = "STITCHJAX_CACHE_DIR"
_DISABLED = {"", "0", "off", "false", "no", "none"}
_CHUNK = 1 << 22


def resolve_cache_dir(cache_dir=None):
    """The cache folder to use (a Path), or None when caching is disabled.

    ``cache_dir``: None -> ``$STITCHJAX_CACHE_DIR`` or ``~/.cache/stitchjax``; False -> disabled;
    a path -> that folder. The environment variable set to ``off`` (or 0/false/no/none) disables.
    """
    if cache_dir is False:
        return None
    if cache_dir is None or cache_dir is True:
        env = os.environ.get(ENV_VAR)
        if env is not None:
            return None if env.strip().lower() in _DISABLED else pathlib.Path(env).expanduser()
        return pathlib.Path.home() / ".cache" / "stitchjax"
    return pathlib.Path(os.fspath(cache_dir)).expanduser()


def file_digest(path) -> str:
    """blake2b hex digest of the file's bytes (as stored: a .gz file is hashed compressed)."""
    h = hashlib.blake2b(digest_size=20)
    with open(path, "rb") as f:
        while True:
            chunk = f.read(_CHUNK)
            if not chunk:
                break
            h.update(chunk)
    return h.hexdigest()


def _source_digest(module: str) -> str:
    """blake2b of a module's source file (found without importing the module itself)."""
    import importlib.util
    spec = importlib.util.find_spec(module)
    if spec is None or not spec.origin or not os.path.isfile(spec.origin):
        return "missing"
    return file_digest(spec.origin)


def cache_key(kind: str, files=(), params=None, code=()) -> str:
    """Key of an entry: ``kind`` + hash of (format version, params, file names and contents, and
    the source of the ``code`` modules, e.g. ``("stitchjax.data.bvh", "stitchjax.data.windows")``).

    ``params`` must be JSON-serialisable (numbers, strings, lists, dicts); files are hashed in the
    order given (callers pass them sorted).
    """
    h = hashlib.blake2b(digest_size=20)
    header = {"format": FORMAT_VERSION, "kind": kind, "params": params or {},
              "code": {m: _source_digest(m) for m in code}}
    h.update(json.dumps(header, sort_keys=True, default=str).encode())
    for path in files:
        path = pathlib.Path(path)
        h.update(b"\0" + path.name.encode() + b"\0" + file_digest(path).encode())
    safe_kind = "".join(c if c.isalnum() or c in "-_" else "_" for c in kind)
    return f"{safe_kind}-{h.hexdigest()}"


def _entry_path(cache_dir: pathlib.Path, key: str) -> pathlib.Path:
    return pathlib.Path(cache_dir) / f"{key}.npz"


def load(cache_dir, key: str):
    """The arrays of entry ``key`` as a dict, or None when absent, disabled or unreadable."""
    if cache_dir is None:
        return None
    path = _entry_path(cache_dir, key)
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            return {name: data[name] for name in data.files}
    except Exception:  # corrupt / truncated entry: a miss; it will be rewritten
        return None


def save(cache_dir, key: str, arrays: dict) -> None:
    """Write entry ``key`` atomically (temp file + os.replace). Failure to write only warns."""
    if cache_dir is None:
        return
    cache_dir = pathlib.Path(cache_dir)
    tmp_name = None
    try:
        cache_dir.mkdir(parents=True, exist_ok=True)
        fd, tmp_name = tempfile.mkstemp(prefix=f".{key}.", suffix=".tmp", dir=cache_dir)
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **{k: np.asarray(v) for k, v in arrays.items()})
        os.replace(tmp_name, _entry_path(cache_dir, key))
        tmp_name = None
    except OSError as e:
        import warnings
        warnings.warn(f"stitchjax: could not write cache entry in {cache_dir} ({e}); continuing "
                      f"without caching (set {ENV_VAR} to a writable folder, or to 'off')")
    finally:
        if tmp_name is not None:
            try:
                os.unlink(tmp_name)
            except OSError:
                pass


def cached(kind: str, files, params, compute, cache_dir=None, code=()) -> dict:
    """``compute()`` -> dict of arrays, memoised on disk under :func:`cache_key` (kind, files,
    params, code).

    ``cache_dir`` as in :func:`resolve_cache_dir`. Returns the stored arrays on a hit, otherwise
    computes, stores and returns them (the stored and returned arrays are identical).
    """
    folder = resolve_cache_dir(cache_dir)
    if folder is None:
        return {k: np.asarray(v) for k, v in compute().items()}
    key = cache_key(kind, files, params, code)
    hit = load(folder, key)
    if hit is not None:
        return hit
    arrays = {k: np.asarray(v) for k, v in compute().items()}
    save(folder, key, arrays)
    return arrays
