"""On-disk cache of FE results (flank influence coefficients), shared by the 2D and the 3D models.

An entry is one NPZ file of named arrays, written by :func:`write_arrays` and read by
:func:`read_arrays`:

* its name carries a key (:func:`cache_key`) that hashes everything the entry depends on (the
  gearrom version, the code revision of the model, gear geometry, material, mesh settings), so
  that an entry is never found for inputs it was not computed from;
* it holds a SHA-256 digest of its arrays (names, dtypes, shapes and bytes), checked on every read,
  so that damage which still loads as valid arrays (a flipped bit in the data) is detected as well
  as files that do not load at all (truncated, empty, broken ZIP structure);
* it is written to a temporary file in the cache directory and moved into place with
  :func:`os.replace` (:func:`atomic_path`), so that a reader sees either the complete old entry,
  the complete new one or none, never a partly written file, also with several processes sharing
  the directory. A writer killed before the rename leaves only a hidden ``.*.tmp*`` file, which
  no reader opens.

:class:`FECache` is the cache used by the models: a damaged entry is reported (one ``WARNING`` log
line of the ``gearrom.fe.cache`` logger naming the file), deleted and recomputed; an unwritable
directory is reported once (naming the directory and the reason) and the run continues without
storing its results. The reports go to :mod:`logging` rather than :mod:`warnings` so that they
stay one line and are not hidden by callers that silence model warnings.
"""
from __future__ import annotations

import errno
import hashlib
import json
import logging
import os
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import TypeVar

import numpy as np

from gearrom.errors import GearromError

log = logging.getLogger(__name__)

T = TypeVar("T")

CACHE_FORMAT = 2
"""Layout of the cache entries (arrays plus the digest field); part of every key."""

DIGEST_FIELD = "_content_sha256"
"""Name of the array that holds the SHA-256 digest of the other arrays of an entry."""


def _process_umask() -> int:
    """The process's file mode creation mask (read by setting and restoring it)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


_FILE_MODE = 0o666 & ~_process_umask()
"""Mode of new entries: that of an ordinary new file (:func:`tempfile.mkstemp` creates 0o600, which
would hide the entries of a shared cache directory from other users)."""


class CacheEntryError(GearromError, ValueError):
    """A cache file cannot be read as a complete, intact entry (the message names the file)."""


def _version() -> str:
    """The installed gearrom version (``gearrom.__version__``)."""
    from gearrom import __version__

    return str(__version__)


def cache_key(kind: str, data: Mapping) -> str:
    """Hash of everything a cache entry depends on.

    Parameters
    ----------
    kind : str
        Model and code revision of the entry (for example ``"compliance-2d-v3"``).
    data : mapping
        The inputs of the entry (geometry, material, mesh settings...), JSON-serialisable; other
        values are hashed through ``str``.

    Returns
    -------
    str
        24 hexadecimal characters of the SHA-256 of the canonical JSON of ``data`` together with
        ``kind``, the gearrom version and :data:`CACHE_FORMAT`.
    """
    payload = {"kind": kind, "gearrom": _version(), "format": CACHE_FORMAT, "data": data}
    return hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()[:24]


def content_digest(arrays: Mapping[str, np.ndarray]) -> str:
    """SHA-256 (hexadecimal) of the names, dtypes, shapes and bytes of ``arrays`` in name order."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(json.dumps([name, a.dtype.str, list(a.shape)]).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def write_arrays(path: str | Path, arrays: Mapping[str, object]) -> Path:
    """Write ``arrays`` and their :func:`content_digest` to the NPZ file ``path``, atomically.

    The data go to a temporary file in the same directory, which is flushed to disk and then
    renamed over ``path`` (:func:`os.replace`), so that ``path`` is never a partly written file.
    Missing parent directories are created.

    Parameters
    ----------
    path : str or Path
        Target file.
    arrays : mapping of str to array_like
        The entry's arrays (no object arrays: entries are read without pickle). The name
        :data:`DIGEST_FIELD` is reserved.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OSError
        The directory cannot be created or written.
    """
    path = Path(path)
    data = {k: np.asanyarray(v) for k, v in arrays.items() if k != DIGEST_FIELD}
    data[DIGEST_FIELD] = np.array(content_digest(data))
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez(f, **data)
    return path


@contextmanager
def atomic_path(path: str | Path, durable: bool = True) -> Iterator[Path]:
    """A temporary file next to ``path`` that replaces ``path`` when the block completes.

    The block writes the temporary file (any writer that takes a path); on normal exit the file is
    flushed to disk (``durable``; False skips the flush for files that are recomputed when found
    damaged) and renamed over ``path`` with :func:`os.replace` (atomic within one file system), on
    an exception it is deleted and ``path`` is left as it was. The temporary name is
    hidden, unique per writer and ends with ``path``'s suffix (for writers that check it). Missing
    parent directories are created.

    Raises
    ------
    OSError
        The directory cannot be created or written.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{path.suffix}", dir=path.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        os.chmod(tmp, _FILE_MODE)
        yield tmp
        if durable:
            with open(tmp, "rb+") as f:
                os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise


def read_arrays(path: str | Path) -> dict[str, np.ndarray]:
    """Read an entry written by :func:`write_arrays` and check its content digest.

    Parameters
    ----------
    path : str or Path
        The NPZ file.

    Returns
    -------
    dict of str to ndarray
        The arrays (without the digest).

    Raises
    ------
    FileNotFoundError, PermissionError
        The file does not exist or cannot be opened.
    CacheEntryError
        The file is not a complete, intact entry: it does not load (empty, truncated, broken
        ZIP or array headers), has no digest, or its arrays do not match the digest.
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as d:
            data = {k: d[k] for k in d.files}
    except (FileNotFoundError, PermissionError, IsADirectoryError):
        raise
    except Exception as exc:  # noqa: BLE001  (every other failure to parse the file means damage)
        raise CacheEntryError(f"{path}: does not load ({_one_line(exc)})") from exc
    stored = data.pop(DIGEST_FIELD, None)
    if stored is None:
        raise CacheEntryError(f"{path}: no content digest (not written by gearrom.fe.cache.write_arrays)")
    if str(stored) != content_digest(data):
        raise CacheEntryError(f"{path}: content does not match its SHA-256 digest")
    return data


def _one_line(exc: BaseException) -> str:
    """``Type: message`` of ``exc`` on one line."""
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


class FECache:
    """A directory of cache entries, with the recovery rules of the FE models.

    Parameters
    ----------
    directory : str or Path
        Cache directory (created on the first write).

    Notes
    -----
    :meth:`fetch` returns an entry if it is intact; a damaged one is reported in one warning log
    line naming the file and deleted, and the caller recomputes it. :meth:`store` writes an entry;
    if the directory cannot be written, one warning log line names the directory and the reason,
    and the cache stops writing (the caller keeps its result).
    """

    def __init__(self, directory: str | Path) -> None:
        self.directory = Path(directory).expanduser()
        self.writable = True

    def __repr__(self) -> str:
        return f"FECache({str(self.directory)!r})"

    def path(self, name: str) -> Path:
        """File of the entry ``name`` (a file name such as ``flank2d-<key>.npz``)."""
        return self.directory / name

    def fetch(self, name: str, load: Callable[[Path], T]) -> T | None:
        """The entry ``name`` read by ``load`` (``path -> object``), or None if absent or damaged.

        Any exception of ``load`` other than a missing or unreadable file counts as damage: it is
        reported in one warning log line naming the file, and the entry is deleted (if the
        directory allows it).
        """
        path = self.path(name)
        try:
            if not path.is_file():
                return None
        except OSError:
            return None
        try:
            return load(path)
        except FileNotFoundError:  # removed by another process since the check
            return None
        except PermissionError as exc:  # intact or not, this process cannot read it: leave it alone
            log.warning("FE cache entry %s cannot be read (%s), recomputing it", path, exc.strerror or exc)
            return None
        except Exception as exc:  # noqa: BLE001  (any failure to read an entry: recompute it)
            if isinstance(exc, CacheEntryError):  # its message starts with the path, named below
                reason = _one_line(exc.__cause__) if exc.__cause__ else str(exc).removeprefix(f"{path}: ")
            else:
                reason = _one_line(exc)
            try:
                path.unlink()
                action = "deleted"
            except FileNotFoundError:
                action = "deleted"
            except OSError as uexc:
                action = f"could not be deleted ({uexc.strerror or uexc})"
            log.warning("FE cache entry %s is damaged and %s, recomputing it: %s", path, action, reason)
            return None

    def store(self, name: str, save: Callable[[Path], object]) -> bool:
        """Write the entry ``name`` with ``save`` (``path -> ...``, atomic, see :func:`write_arrays`).

        Returns
        -------
        bool
            True if written. False if the directory cannot be written: the first failure is reported
            in one warning log line naming the directory and the reason, and later calls do not try
            again.
        """
        if not self.writable:
            return False
        try:
            save(self.path(name))
            return True
        except OSError as exc:
            self.writable = False
            log.warning("FE cache directory %s cannot be written (%s); running without the cache, "
                        "results are not stored", self.directory, self._why(exc))
            return False

    def _why(self, exc: OSError) -> str:
        """Reason of a failed write, in words."""
        d = self.directory
        for p in (d, *d.parents):
            if p.exists():
                if not p.is_dir():
                    return f"{p} is a file, not a directory"
                break
        if exc.errno in (errno.EACCES, errno.EPERM):
            return "permission denied"
        if exc.errno == errno.EROFS:
            return "read-only file system"
        if exc.errno == errno.ENOSPC:
            return "no space left on the device"
        return _one_line(exc)


def cached(cache: FECache | None, name: str, load: Callable[[Path], T], compute: Callable[[], T],
           save: Callable[[T, Path], object], atomic: bool = False) -> T:
    """The entry ``name`` of ``cache`` (read by ``load``), else ``compute()`` stored by ``save(obj, path)``.

    ``cache`` None: ``compute()`` alone. ``atomic``: ``save`` writes any file and is wrapped in
    :func:`atomic_path` (writers that are not atomic themselves, such as NetCDF); without it
    ``save`` must write atomically (:func:`write_arrays`).
    """
    if cache is None:
        return compute()
    obj = cache.fetch(name, load)
    if obj is None:
        obj = compute()

        def store(path: Path) -> None:
            if atomic:
                with atomic_path(path) as tmp:
                    save(obj, tmp)
            else:
                save(obj, path)

        cache.store(name, store)
    return obj


def as_cache(cache_dir: str | Path | FECache | None) -> FECache | None:
    """``cache_dir`` as an :class:`FECache` (None, False or an empty string: no cache)."""
    if cache_dir is None or cache_dir is False or cache_dir == "":
        return None
    return cache_dir if isinstance(cache_dir, FECache) else FECache(cache_dir)
