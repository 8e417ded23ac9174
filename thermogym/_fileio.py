"""Atomic file writing and JSON conversion shared by recordings and FitResults.

A file is never written in place: the content goes to a temporary file in the
same folder (same file system, so the final rename is atomic), is flushed to
disk and then renamed over the target with :func:`os.replace`. If anything
fails before the rename, the temporary file is removed and the target is left
exactly as it was: a failure never leaves a half-written file nor destroys an
existing one (DESIGN.md, Conventions).

:func:`atomic_write_many` writes several files as one unit (a CSV and its JSON
sidecar): every temporary file is written first and only when all of them
succeeded are they renamed into place, one after the other.

:func:`to_jsonable` converts numpy scalars and arrays, tuples, paths and
non-finite floats into plain JSON types, naming the offending entry when an
object cannot be represented.
"""

from __future__ import annotations

import datetime as _dt
import math
import os
import secrets
import stat
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "WriteFn",
    "atomic_write",
    "atomic_write_many",
    "atomic_write_text",
    "to_jsonable",
]

#: A callable that writes the complete content of a file to the path it is given (what
#: it returns, such as ``Path.write_bytes``'s byte count, is ignored).
WriteFn = Callable[[Path], object]


def _temp_path(target: Path) -> Path:
    """Create an empty, unique temporary file next to ``target`` and return its path.

    The file is created with mode ``0o666`` filtered by the process umask, so the
    final file gets the same permissions as one made by :func:`open`.
    """
    for _ in range(100):
        tmp = target.with_name(f".{target.name}.{secrets.token_hex(6)}.tmp")
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
        os.close(fd)
        return tmp
    raise FileExistsError(f"could not create a temporary file next to {target}")  # pragma: no cover


def _fsync_file(path: Path) -> None:
    with open(path, "rb+") as f:
        os.fsync(f.fileno())


def _fsync_dir(folder: Path) -> None:
    """Flush a folder entry to disk where the platform allows it (POSIX)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:  # pragma: no cover - e.g. Windows cannot open folders
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover
        pass
    finally:
        os.close(fd)


def _remove_quietly(path: Path) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


def _publish(tmp: Path, target: Path, overwrite: bool) -> None:
    """Move a finished temporary file to ``target``.

    With ``overwrite=False`` a hard link is used, which fails atomically when
    ``target`` exists (no window between the check and the rename); file
    systems without hard links fall back to a check followed by a rename.
    """
    if overwrite:
        os.replace(tmp, target)
        return
    try:
        os.link(tmp, target)
    except FileExistsError:
        raise
    except OSError:  # no hard links on this file system
        if target.exists():
            raise FileExistsError(f"{target} exists and overwrite=False") from None
        os.replace(tmp, target)
    else:
        os.unlink(tmp)


def atomic_write_many(
    writes: Mapping[str | os.PathLike[str], WriteFn]
    | Iterable[tuple[str | os.PathLike[str], WriteFn]],
    *,
    overwrite: bool = True,
    fsync: bool = True,
) -> list[Path]:
    """Write several files as one unit, each through a temporary file.

    Every ``write_fn`` is called with the path of an (empty) temporary file in
    the target's folder and must write the complete content there. When all
    of them returned, the temporary files are renamed onto their targets. If
    any ``write_fn`` raises (or the process is interrupted), every temporary
    file is removed and no target is created or changed.

    Parameters
    ----------
    writes : mapping or iterable of (path, write_fn)
        Target path and the function that writes its content.
    overwrite : bool
        When False, refuse (:class:`FileExistsError`) if any target exists;
        nothing is written then.
    fsync : bool
        Flush each file (and its folder) to disk before/after renaming, so a
        power failure cannot leave an empty file behind the new name.

    Returns
    -------
    list of Path
        The targets, in the order given.

    Raises
    ------
    FileExistsError
        ``overwrite=False`` and a target exists.
    FileNotFoundError
        The folder of a target does not exist.
    ValueError
        The same target is named twice.
    Exception
        Whatever a ``write_fn`` raises, after the clean-up.
    """
    items = list(writes.items() if isinstance(writes, Mapping) else writes)
    targets = [Path(os.fspath(p)) for p, _ in items]
    resolved = [t.resolve() for t in targets]
    if len(set(resolved)) != len(resolved):
        raise ValueError(f"the same file is named twice among {[str(t) for t in targets]}")
    for t in targets:
        if not t.parent.is_dir():
            raise FileNotFoundError(f"folder {str(t.parent)!r} of {str(t)!r} does not exist")
        if t.is_dir():
            raise IsADirectoryError(f"{str(t)!r} is a folder, expected a file path")
        if not overwrite and t.exists():
            raise FileExistsError(f"{str(t)!r} exists and overwrite=False")
    temps: list[Path] = []
    published: list[Path] = []
    try:
        for target, (_, write_fn) in zip(targets, items, strict=True):
            tmp = _temp_path(target)
            temps.append(tmp)
            write_fn(tmp)
            if not tmp.is_file():
                raise FileNotFoundError(f"the writer of {str(target)!r} removed its temporary file")
            if target.exists():  # keep the permissions of the file being replaced
                os.chmod(tmp, stat.S_IMODE(target.stat().st_mode))
            if fsync:
                _fsync_file(tmp)
        for tmp, target in zip(temps, targets, strict=True):
            _publish(tmp, target, overwrite)
            published.append(target)
    except BaseException:
        for tmp in temps:
            _remove_quietly(tmp)
        if not overwrite:  # undo the links made before a later one failed
            for target in published:
                _remove_quietly(target)
        raise
    if fsync:
        for folder in {t.parent for t in targets}:
            _fsync_dir(folder)
    return targets


def atomic_write(
    path: str | os.PathLike[str],
    write_fn: WriteFn,
    *,
    overwrite: bool = True,
    fsync: bool = True,
) -> Path:
    """Write one file through a temporary file in the same folder.

    Parameters
    ----------
    path : str or path-like
        Target file.
    write_fn : callable
        ``write_fn(tmp_path)`` writes the complete content to ``tmp_path``.
    overwrite : bool
        When False, refuse if ``path`` exists (:class:`FileExistsError`).
    fsync : bool
        Flush the file to disk before renaming it.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> p = atomic_write(folder / "a.txt", lambda tmp: tmp.write_text("hello"))
    >>> p.read_text()
    'hello'
    >>> def broken(tmp: Path) -> None:
    ...     tmp.write_text("half")
    ...     raise RuntimeError("disk full")
    >>> try:
    ...     atomic_write(p, broken)
    ... except RuntimeError:
    ...     pass
    >>> p.read_text(), sorted(f.name for f in folder.iterdir())
    ('hello', ['a.txt'])
    """
    return atomic_write_many([(path, write_fn)], overwrite=overwrite, fsync=fsync)[0]


def atomic_write_text(
    path: str | os.PathLike[str],
    text: str,
    *,
    overwrite: bool = True,
    encoding: str = "utf-8",
    fsync: bool = True,
) -> Path:
    """Write ``text`` to ``path`` atomically (see :func:`atomic_write`)."""
    data = text.encode(encoding)
    return atomic_write(path, lambda tmp: tmp.write_bytes(data), overwrite=overwrite, fsync=fsync)


def to_jsonable(obj: Any, where: str = "value") -> Any:
    """Convert ``obj`` into plain JSON types.

    numpy scalars become ``int``/``float``/``bool``, arrays and tuples become
    lists, paths become strings, dates ISO strings, and non-finite floats
    (NaN, ±inf) become ``None`` (JSON has no NaN).

    Parameters
    ----------
    obj : object
        Value to convert.
    where : str
        Name of ``obj`` used in error messages, e.g. ``"meta"``.

    Returns
    -------
    object
        ``dict`` / ``list`` / ``str`` / ``int`` / ``float`` / ``bool`` / ``None``.

    Raises
    ------
    TypeError
        An entry cannot be represented in JSON; the message names its location,
        e.g. ``meta['report']['fn']``.

    Examples
    --------
    >>> to_jsonable({"a": np.float64(1.5), "b": (1, np.nan), "c": np.arange(2)})
    {'a': 1.5, 'b': [1, None], 'c': [0, 1]}
    """
    if obj is None or isinstance(obj, str | bool):
        return obj
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.generic):
        if isinstance(obj, np.bool_):
            return bool(obj)
        if isinstance(obj, np.integer):
            return int(obj)
        if isinstance(obj, np.floating):
            v = float(obj)
            return v if math.isfinite(v) else None
        if isinstance(obj, np.str_):
            return str(obj)
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "biuf":
            return to_jsonable(obj.tolist(), where)
        return [to_jsonable(v, f"{where}[{i}]") for i, v in enumerate(obj.tolist())]
    if isinstance(obj, Mapping):
        out: dict[str, Any] = {}
        for k, v in obj.items():
            key = str(k) if isinstance(k, np.str_) else k
            if not isinstance(key, str):
                raise TypeError(
                    f"{where} has the key {k!r} of type {type(k).__name__}; JSON keys must be "
                    "strings"
                )
            out[key] = to_jsonable(v, f"{where}[{key!r}]")
        return out
    if isinstance(obj, list | tuple):
        return [to_jsonable(v, f"{where}[{i}]") for i, v in enumerate(obj)]
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if isinstance(obj, _dt.datetime | _dt.date):
        return obj.isoformat()
    raise TypeError(
        f"{where} is of type {type(obj).__name__} ({obj!r:.60}), which JSON cannot hold; "
        "expected numbers, strings, booleans, None, lists or dicts"
    )
