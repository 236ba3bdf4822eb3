"""File input and output shared by the whole package.

- Atomic writes: the data go to a temporary file in the destination's folder,
  are flushed to disk (``fsync``) and then renamed over the destination, so a
  reader sees the old file or the new one, never a truncated one, and a kill
  in the middle leaves no partial file under the final name. A failed write
  (a full disk, say) removes the temporary file, and its `OSError` names the
  destination, not the temporary file. `atomic_path` yields a path to write
  to, `atomic_open` an open file, `atomic_savefig` saves a matplotlib figure.
- `read_json`: a JSON file whose damage is reported with the file's name.
- `sha256_file`: the hash of a file, read in blocks.
- Path checks to run before any work starts: an output file that is not a
  folder and whose folder exists and is writable, an input file that is an
  existing regular file of bounded size, an output folder that is not a file.

Errors are `filmcal._errors.InputError` (a path option that cannot work) and
`filmcal._errors.DamagedFileError` (a file that cannot be read as JSON).
"""
from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import stat
import tempfile
from pathlib import Path
from typing import IO, Any, Iterator

from filmcal._errors import InputError, damaged
from filmcal._json import json_safe

__all__ = [
    "atomic_path", "atomic_open", "atomic_savefig", "atomic_write_bytes", "atomic_write_text", "atomic_write_json",
    "read_json", "sha256_file", "canonical_json", "json_hash",
    "check_output_file", "check_output_dir", "check_input_file", "INPUT_FILE_MAX_MIB", "check_distinct_files"]

#: The largest input file accepted by default, in MiB: far above any dataset, film file, profile or design
#: a lab writes, and far below what would exhaust memory once read.
INPUT_FILE_MAX_MIB = 256


def _current_umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _final_mode(path: Path) -> int:
    """Permissions of the replaced file if there is one, else those a plain ``open`` would give."""
    try:
        return path.stat().st_mode & 0o7777
    except OSError:
        return 0o666 & ~_current_umask()


def _fsync_dir(folder: Path) -> None:
    """Flush a folder's entry table (the rename) to disk where the OS allows it."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


#: Errors of a write that found no room: whatever raised them, they are about the file being written.
_NO_SPACE = tuple(getattr(errno, name) for name in ("ENOSPC", "EDQUOT", "EFBIG") if hasattr(errno, name))


def _name_destination(exc: OSError, path: Path, tmp_name: str | None) -> None:
    """Make `exc` name `path`, the file being written, in place of its temporary file or of nothing.

    A full disk met by ``write`` or ``fsync`` carries no file name, and an
    error on the temporary file names a file the user never asked for and
    that no longer exists.
    """
    named = exc.filename
    if tmp_name is not None and isinstance(named, (str, os.PathLike)) \
            and os.path.normpath(os.fspath(named)) == os.path.normpath(tmp_name):
        exc.filename, exc.filename2 = str(path), None
    elif named is None and exc.errno in _NO_SPACE:
        exc.filename = str(path)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside `path`; on success move it over `path`.

    For writers that need a file name (``numpy.savez``, ``savefig``, h5py):
    write to the yielded path inside the ``with`` block. The temporary name
    keeps `path`'s suffix, so libraries that add or check a suffix behave.
    On an exception (or Ctrl-C) the temporary file is removed and `path` is
    left as it was; an `OSError` of the write (no space left, say) is made
    to name `path`.

    Parameters
    ----------
    path : str or os.PathLike
        The final file name.

    Yields
    ------
    pathlib.Path
        Where to write.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{path.suffix}", dir=folder)
    except OSError as exc:  # the folder refuses, or has no room even for an empty file
        _name_destination(exc, path, None if exc.filename is None else os.fspath(exc.filename))
        raise
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.chmod(tmp, _final_mode(path))  # mkstemp makes 0600 files
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        if isinstance(exc, OSError):
            _name_destination(exc, path, tmp_name)
        raise
    _fsync_dir(folder)


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike[str], mode: str = "w", **kwargs: Any) -> Iterator[IO[Any]]:
    """Yield a file open for writing on a temporary path beside `path`; on success move it over `path`.

    For writers that take an open file (``csv.writer``, ``numpy.savez``,
    ``savefig``). The file is closed, flushed to disk and renamed when the
    ``with`` block ends; on an exception the temporary file is removed and
    `path` is left as it was (see `atomic_path`).

    Parameters
    ----------
    path : str or os.PathLike
        The final file name.
    mode : {"w", "wb"}, optional
        Text (default) or binary.
    **kwargs
        Passed to `open` (``newline``, ``encoding``).
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open writes a new file: mode must be 'w' or 'wb', got {mode!r}")
    with atomic_path(path) as tmp, open(tmp, mode, **kwargs) as fh:
        yield fh


def atomic_savefig(fig: Any, path: str | os.PathLike[str], **kwargs: Any) -> Path:
    """Save a matplotlib figure to `path` atomically (see `atomic_open`); return the path.

    The format is `path`'s suffix (``.png``, ``.pdf``, ``.svg``), or
    matplotlib's default (``savefig.format``, PNG) for a name without one,
    unless ``format`` is given; the file is written under exactly the name
    given. Other keywords (``dpi``) go to ``Figure.savefig``.
    """
    kwargs.setdefault("format", Path(path).suffix[1:] or fig.canvas.get_default_filetype())
    with atomic_open(path, "wb") as fh:
        fig.savefig(fh, **kwargs)
    return Path(path)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write `data` to `path` atomically (temporary file, fsync, rename); return the path."""
    with atomic_open(path, "wb") as fh:
        fh.write(data)
    return Path(path)


def atomic_write_text(path: str | os.PathLike[str], text: str, encoding: str = "utf-8") -> Path:
    """Write `text` to `path` atomically (temporary file, fsync, rename); return the path."""
    return atomic_write_bytes(path, text.encode(encoding))


def atomic_write_json(path: str | os.PathLike[str], obj: Any, indent: int | None = 2) -> Path:
    """Write `obj` as strict JSON (numpy values converted, non-finite floats as null) atomically."""
    text = json.dumps(json_safe(obj), indent=indent, allow_nan=False)
    return atomic_write_text(path, text + "\n")


def read_json(path: str | os.PathLike[str], recomputable: bool = True) -> Any:
    """Read a JSON file; a damaged one raises a `DamagedFileError` naming it.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    recomputable : bool, optional
        True (default) for a file the package wrote: the message then says
        that deleting it recomputes it. False for a user's own file.

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    filmcal._errors.DamagedFileError
        If it cannot be decoded as UTF-8 JSON.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise damaged(path, exc, recomputable) from exc
    try:
        return json.loads(text)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise damaged(path, exc, recomputable) from exc


def canonical_json(obj: Any) -> str:
    """JSON text with sorted keys and no spaces: equal objects give equal text.

    Raises
    ------
    ValueError
        If `obj` holds non-finite floats or values JSON cannot represent.
    """
    try:
        return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"cannot represent as JSON: {exc}") from None


def json_hash(obj: Any, digits: int = 16) -> str:
    """The package's one settings hash: SHA-256 (first `digits` hex digits) of `obj`'s canonical JSON.

    Numpy values are converted first (`filmcal._json.json_safe`), so that equal
    settings give equal hashes however they were built.
    """
    return hashlib.sha256(canonical_json(json_safe(obj)).encode()).hexdigest()[:digits]


def sha256_file(path: str | os.PathLike[str], block_bytes: int = 1 << 20) -> str:
    """Return the SHA-256 hex digest of a file's contents, read in blocks."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(block_bytes), b""):
            h.update(block)
    return h.hexdigest()


def _can_create_in(folder: Path) -> bool:
    """True if a file can be created in `folder`.

    Permissions answer for ordinary users. For root they always say yes, so a
    file is created and removed to find out (read-only mounts, /proc).
    """
    if not os.access(folder, os.W_OK | os.X_OK):
        return False
    if not hasattr(os, "geteuid") or os.geteuid() != 0:
        return True
    try:
        fd, name = tempfile.mkstemp(prefix=".filmcal-probe-", dir=folder)
    except OSError:
        return False
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(name)
    return True


def check_output_file(path: str | os.PathLike[str], option: str = "--out") -> Path:
    """Check, before any work, that `path` can be written as a file.

    The path must not be a folder, its folder must exist and be writable, and
    an existing file there must be writable. Nothing is left behind (for
    root, the folder is probed by creating and removing an empty temporary
    file).

    Parameters
    ----------
    path : str or os.PathLike
        The output file.
    option : str, optional
        The option that gave it, for the message.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    filmcal._errors.InputError
        Naming `option` and the path.
    """
    p = Path(path)
    if str(path) == "" or p.name == "":
        raise InputError(f"{option} must be a file name, got {str(path)!r}")
    if p.is_dir():
        raise InputError(f"{option} {str(p)!r} is a folder; give a file name")
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.exists():
        raise InputError(f"{option} {str(p)!r}: folder {str(folder)!r} does not exist; create it first")
    if not folder.is_dir():
        raise InputError(f"{option} {str(p)!r}: {str(folder)!r} is not a folder")
    if p.exists() and not os.access(p, os.W_OK):
        raise InputError(f"{option} {str(p)!r} is not writable")
    if not _can_create_in(folder):
        raise InputError(f"{option} {str(p)!r}: folder {str(folder)!r} is not writable")
    return p


def check_distinct_files(*paths: tuple[str | os.PathLike[str] | None, str]) -> None:
    """Refuse, before any work, two options that name the same file (an output written over an input or over
    another output): ``(path, option)`` pairs, None skipped; links and spellings are resolved.

    Raises
    ------
    filmcal._errors.InputError
        Naming both options and the file.
    """
    seen: dict[Path, str] = {}
    for path, option in paths:
        if path is None or str(path) == "":
            continue
        key = Path(path).resolve()
        if key in seen:
            raise InputError(f"{option} {str(path)!r} is the file of {seen[key]}: give another file (nothing was "
                             "written)")
        seen[key] = option


def check_output_dir(path: str | os.PathLike[str], option: str = "--study-dir",
                     must_exist: bool = False, writable: bool = True) -> Path:
    """Check, before any work, that `path` can be used as an output folder.

    It must not be an existing file; if it exists it must be writable; if it
    does not exist, `must_exist` must be False and its parent must be an
    existing writable folder (so that one ``mkdir`` makes it). With
    ``writable=False`` (a folder that may only be read) only the kind of path
    is checked. Nothing is created.

    Raises
    ------
    filmcal._errors.InputError
        Naming `option` and the path.
    """
    p = Path(path)
    if str(path) == "":
        raise InputError(f"{option} must be a folder name, got ''")
    if p.exists():
        if not p.is_dir():
            raise InputError(f"{option} {str(p)!r} is a file, not a folder")
        if writable and not _can_create_in(p):
            raise InputError(f"{option} {str(p)!r} is not writable")
        return p
    if must_exist:
        raise InputError(f"{option} {str(p)!r} does not exist")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"{option} {str(p)!r}: parent folder {str(parent)!r} does not exist")
    if writable and not _can_create_in(parent):
        raise InputError(f"{option} {str(p)!r}: parent folder {str(parent)!r} is not writable")
    return p


def _file_kind(mode: int) -> str:
    """What a path that is not a regular file is, in words."""
    kinds = ((stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
             (stat.S_ISFIFO, "a named pipe"), (stat.S_ISSOCK, "a socket"))
    return next((name for test, name in kinds if test(mode)), "a special file")


def check_input_file(path: str | os.PathLike[str], option: str, max_mib: float = INPUT_FILE_MAX_MIB) -> Path:
    """Check, before any work, that `path` is an existing, readable regular file of at most `max_mib` MiB.

    Links are followed: what counts is the file read. A folder, a device
    (``/dev/zero``), a named pipe or a socket is refused, as is a file larger
    than the cap (reading it would exhaust memory or never end).

    Parameters
    ----------
    path : str or os.PathLike
        The input file.
    option : str
        The option that gave it, for the message.
    max_mib : float, optional
        The largest size accepted, in MiB (default `INPUT_FILE_MAX_MIB`).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    filmcal._errors.InputError
        Naming `option` and the path.
    """
    p = Path(path)
    try:
        info = p.stat()
    except (FileNotFoundError, NotADirectoryError, ValueError):
        raise InputError(f"{option} {str(p)!r} does not exist") from None
    except OSError as exc:
        raise InputError(f"{option} {str(p)!r} cannot be read ({exc.strerror or exc})") from None
    if stat.S_ISDIR(info.st_mode):
        raise InputError(f"{option} {str(p)!r} is a folder; give a file")
    if not stat.S_ISREG(info.st_mode):
        raise InputError(f"{option} {str(p)!r} is {_file_kind(info.st_mode)}, not a regular file; give a file")
    if not os.access(p, os.R_OK):
        raise InputError(f"{option} {str(p)!r} is not readable")
    if info.st_size > max_mib * 2**20:
        raise InputError(f"{option} {str(p)!r} is larger than {max_mib:g} MiB ({info.st_size:,} bytes), the "
                         "limit for this option; give a smaller file")
    return p
