"""Keep numba's on-disk cache of compiled kernels correct across modules and processes.

numba keys a cached kernel on its own source file; :func:`cache_depends_on` adds the
sources of every module whose compiled functions the kernel may inline — found by walking
the names its code refers to (:func:`kernel_sources`), not listed by hand — and gives
closure kernels an index key that is stable across processes. Used by the models, the
environments and the rigs.
"""

from __future__ import annotations

import functools
import hashlib
import sys
import sysconfig
import types
from pathlib import Path
from types import ModuleType
from typing import Any

__all__ = ["cache_depends_on", "kernel_sources", "module_kernels_depend_on"]


@functools.cache
def _source(path: str) -> bytes:
    # a module's source, read once per process (many kernels depend on the same modules)
    return Path(path).read_bytes()


@functools.cache
def _library_dirs() -> tuple[str, ...]:
    # installed libraries and the standard library: their code is numba's or numpy's, not
    # a dependency this cache must follow (numba keys on its own version)
    paths = sysconfig.get_paths()
    dirs = {paths[k] for k in ("stdlib", "platstdlib", "purelib", "platlib") if k in paths}
    return tuple(str(Path(d).resolve()) for d in dirs)


def _project_file(module: ModuleType | None) -> str | None:
    f = getattr(module, "__file__", None)
    if not f or not f.endswith(".py"):
        return None
    f = str(Path(f).resolve())
    return None if f.startswith(_library_dirs()) else f


def _code_names(code: types.CodeType) -> set[str]:
    # every global or attribute name a code object and its nested code objects refer to
    names = set(code.co_names)
    for c in code.co_consts:
        if isinstance(c, types.CodeType):
            names |= _code_names(c)
    return names


def kernel_sources(fn: Any) -> list[str]:
    """Source files of the project a compiled kernel ``fn`` may contain code from.

    Starting from the kernel's Python function, the names its code refers to are
    followed: compiled functions (their module, then their own references), plain
    functions (numba overloads such as the integrators' tuple helpers), modules used as
    namespaces (``ax.step``: the module and the attribute) and the contents of closure
    cells, transitively. Installed libraries are not followed.

    Examples
    --------
    >>> from thermogym.models.axt211 import _step_kernel
    >>> sorted(Path(f).name for f in kernel_sources(_step_kernel))
    ['_vmath.py', 'axt211.py', 'axt211_dynamics.py', 'integrators.py']
    """
    seen: set[int] = set()
    files: set[str] = set()

    def visit(obj: Any) -> None:
        if id(obj) in seen:
            return
        seen.add(id(obj))
        f = getattr(obj, "py_func", obj)  # a dispatcher's Python function
        if isinstance(f, types.FunctionType):
            mod = sys.modules.get(f.__module__ or "")
            path = _project_file(mod)
            if path is None:
                return
            files.add(path)
            g = f.__globals__
            names = _code_names(f.__code__)
            for name in names:
                if name in g:
                    visit_value(g[name], names)
            for cell in f.__closure__ or ():
                try:
                    visit_value(cell.cell_contents, names)
                except ValueError:  # an empty cell
                    pass

    def visit_value(v: Any, names: set[str]) -> None:
        if isinstance(v, ModuleType):
            path = _project_file(v)
            if path is None or id(v) in seen:
                return
            seen.add(id(v))
            files.add(path)
            for name in names:  # the attributes the code may take from it
                a = getattr(v, name, None)
                if a is not None and not isinstance(a, ModuleType):
                    visit_value(a, names)
        elif isinstance(v, tuple):
            for x in v:
                visit_value(x, names)
        elif isinstance(v, types.FunctionType) or hasattr(v, "py_func"):
            visit(v)

    visit(fn)
    return sorted(files)


def cache_depends_on(dispatcher: Any, *modules: ModuleType) -> Any:
    """Make a cached numba kernel's on-disk cache also depend on the code it inlines.

    numba keys a cached function on its own source file only, but a kernel
    that calls compiled functions of other modules (the models' step
    functions) contains a copy of their machine code: after an edit of a model
    the stale kernel would still be loaded. numba has no option for this (its
    cache index compares one "source stamp"), so the stamp is replaced here by
    a hash over the kernel's own stamp and the sources of :func:`kernel_sources`
    (plus ``modules``, for code reached in ways the walk cannot see). Should
    numba's internals change, caching is switched off for the kernel instead:
    slower start, never stale code. A closure kernel also gets a cache index key
    that is stable across processes (:class:`_StableIndexKey`).
    """
    cache: Any = getattr(dispatcher, "_cache", None)
    cache_file = getattr(cache, "_cache_file", None)
    if cache_file is None or not hasattr(cache_file, "_source_stamp"):
        if hasattr(dispatcher, "disable_caching"):
            dispatcher.disable_caching()
        return dispatcher
    h = hashlib.sha256(repr(cache_file._source_stamp).encode())
    paths = set(kernel_sources(dispatcher))
    paths.update(str(Path(str(m.__file__)).resolve()) for m in modules)
    for path in sorted(paths):
        h.update(_source(path))
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

    Call it at the end of a module whose kernels inline compiled functions of other
    modules: ``module_kernels_depend_on(globals())`` (the dependencies are derived).
    """
    name = namespace.get("__name__")
    for v in list(namespace.values()):
        f = getattr(v, "py_func", None)
        if f is not None and hasattr(v, "_cache") and getattr(f, "__module__", None) == name:
            cache_depends_on(v, *modules)
