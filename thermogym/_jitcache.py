"""Keep numba's on-disk cache of compiled kernels correct across modules and processes.

numba keys a cached kernel on its own source file; :func:`cache_depends_on` adds the
sources of the modules whose compiled functions the kernel inlines, and gives closure
kernels an index key that is stable across processes. Used by the models and the
environments.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path
from types import ModuleType
from typing import Any

__all__ = ["cache_depends_on", "module_kernels_depend_on"]


@functools.cache
def _source(path: str) -> bytes:
    # a module's source, read once per process (many kernels depend on the same modules)
    return Path(path).read_bytes()


def cache_depends_on(dispatcher: Any, *modules: ModuleType) -> Any:
    """Make a cached numba kernel's on-disk cache also depend on ``modules``.

    numba keys a cached function on its own source file only, but a kernel
    that calls compiled functions of other modules (the models' step
    functions) contains a copy of their machine code: after an edit of a model
    the stale kernel would still be loaded. numba has no option for this (its
    cache index compares one "source stamp"), so the stamp is replaced here by
    a hash over the kernel's own stamp and the dependencies' sources. Should
    numba's internals change, caching is switched off for the kernel instead:
    slower start, never stale code. A closure kernel also gets a cache index key
    that is stable across processes (:class:`_StableIndexKey`).
    """
    cache = getattr(dispatcher, "_cache", None)
    cache_file = getattr(cache, "_cache_file", None)
    if cache_file is None or not hasattr(cache_file, "_source_stamp"):
        if hasattr(dispatcher, "disable_caching"):
            dispatcher.disable_caching()
        return dispatcher
    h = hashlib.sha256(repr(cache_file._source_stamp).encode())
    for m in modules:
        h.update(_source(str(m.__file__)))
    cache_file._source_stamp = h.digest()
    closure = getattr(getattr(dispatcher, "py_func", None), "__closure__", None)
    if closure is not None:
        try:
            key = _StableIndexKey(dispatcher.py_func)
        except TypeError:  # a cell without a stable description: no caching, never stale
            key = None
        if key is None or not hasattr(cache, "_index_key"):
            dispatcher.disable_caching()
            return dispatcher
        cache._index_key = key
    return dispatcher


def _cell_key(v: Any) -> Any:
    # a stable description of a closure cell: a compiled kernel by its function's module,
    # name and own cells; constants as they are
    f = getattr(v, "py_func", None)
    if f is not None:
        cells = tuple(_cell_key(c.cell_contents) for c in f.__closure__ or ())
        return ("kernel", f.__module__, f.__qualname__, cells)
    if v is None or isinstance(v, bool | int | float | str):
        return v
    if isinstance(v, tuple):
        return tuple(_cell_key(x) for x in v)
    raise TypeError(f"closure cell of type {type(v).__name__} has no stable cache key")


class _StableIndexKey:
    """numba's cache index key of a closure kernel, stable across processes.

    numba keys a cached closure on a pickle of its cells; a cell holding another
    compiled kernel pickles with that dispatcher's per-process random id, so a
    factory-made kernel (e.g. a step kernel closing over its lockstep loop) missed
    the cache in every new process and was compiled again (14-40 s per process,
    measured). Here kernels in cells are described by module, qualified name and
    their own cells, constants by value (numba's own key otherwise: signature,
    codegen magic tuple, bytecode hash).
    """

    def __init__(self, py_func: Any) -> None:
        self._code = hashlib.sha256(py_func.__code__.co_code).hexdigest()
        cells = tuple(_cell_key(c.cell_contents) for c in py_func.__closure__)
        self._cells = hashlib.sha256(repr(cells).encode()).hexdigest()

    def __call__(self, sig: Any, codegen: Any) -> tuple[Any, ...]:
        return (sig, codegen.magic_tuple(), (self._code, self._cells))


def module_kernels_depend_on(namespace: dict[str, Any], *modules: ModuleType) -> None:
    """Apply :func:`cache_depends_on` to every kernel defined in a module's ``namespace``.

    Call it at the end of a module whose kernels inline compiled functions of ``modules``
    (e.g. ``module_kernels_depend_on(globals(), axt211, _vmath)``).
    """
    name = namespace.get("__name__")
    for v in list(namespace.values()):
        f = getattr(v, "py_func", None)
        if f is not None and hasattr(v, "_cache") and getattr(f, "__module__", None) == name:
            cache_depends_on(v, *modules)
