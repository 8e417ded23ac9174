"""On-disk caching of the environments' compiled kernels across processes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

from thermogym._jitcache import _cell_key, _StableIndexKey

MODULE = textwrap.dedent(
    """
    import json, sys
    import numba as nb
    import numpy as np
    from thermogym._jitcache import cache_depends_on

    @nb.njit(cache=True)
    def inner(x, k):
        return x * k

    def make(kern, k):
        @nb.njit(cache=True)
        def outer(x):  # a closure over a compiled kernel and a constant
            return kern(x, k) + 1.0

        return cache_depends_on(outer)

    f = make(inner, int(sys.argv[1]))
    value = f(np.float64(2.0))
    print(json.dumps({"value": value, "hits": sum(f.stats.cache_hits.values())}))
    """
)


def _run(tmp_path, k: int) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    out = subprocess.run(
        [sys.executable, str(tmp_path / "factory.py"), str(k)],
        env=env, capture_output=True, text=True, check=True,
    )  # fmt: skip
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_closure_over_a_kernel_is_loaded_from_the_cache_in_a_new_process(tmp_path):
    (tmp_path / "factory.py").write_text(MODULE)
    first = _run(tmp_path, 3)
    second = _run(tmp_path, 3)
    assert first == {"value": 7.0, "hits": 0}  # compiled
    assert second == {"value": 7.0, "hits": 1}  # loaded, not compiled again
    # another constant is another kernel: compiled, never the cached k = 3 code
    assert _run(tmp_path, 5) == {"value": 11.0, "hits": 0}
    assert _run(tmp_path, 3)["hits"] == 1


def test_stable_key_describes_kernels_by_name_and_constants():
    import numba as nb

    def make(k):
        @nb.njit
        def f(x):
            return x + k

        return f

    a, b, c = make(1), make(1), make(2)
    assert _cell_key(a) == _cell_key(b) != _cell_key(c)
    assert _cell_key((1, None, "s")) == (1, None, "s")

    def g(x):
        return a(x)

    assert _StableIndexKey(g)._cells == _StableIndexKey(g)._cells
    try:
        _cell_key(object())
    except TypeError as e:
        assert "object" in str(e)
    else:  # pragma: no cover
        raise AssertionError("an object without a stable description must be refused")


def test_a_kernel_is_recompiled_when_a_module_it_inlines_changes(tmp_path):
    # module_kernels_depend_on(globals()) derives the dependencies: numba alone keys a.f's
    # cache on a.py only, and would load the stale machine code of b.g and c.h after b.py
    # or c.py changed. a reaches b as a module attribute, b reaches c by a name imported
    # from it; nothing lists either by hand
    (tmp_path / "c.py").write_text(
        "import numba as nb\n\n@nb.njit(cache=True, inline='always')\ndef h(x):\n"
        "    return x + 1.0\n"
    )
    (tmp_path / "b.py").write_text(
        "import numba as nb\nfrom c import h\n\n@nb.njit(cache=True, inline='always')\n"
        "def g(x):\n    return h(x) * 1.0\n"
    )
    (tmp_path / "a.py").write_text(
        "import numba as nb\nimport b\nfrom thermogym._jitcache import module_kernels_depend_on\n"
        "\n@nb.njit(cache=True)\ndef f(x):\n    return b.g(x) * 2.0\n\n"
        "module_kernels_depend_on(globals())\n"
    )
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": str(tmp_path / "cache"),
        "PYTHONPATH": str(tmp_path) + os.pathsep + os.environ.get("PYTHONPATH", ""),
    }

    def run() -> tuple[float, int]:
        out = subprocess.run(
            [
                sys.executable, "-c",
                "import a, json; v = a.f(1.0); "
                "print(json.dumps([v, sum(a.f.stats.cache_hits.values())]))",
            ],
            env=env, capture_output=True, text=True, check=True, cwd=tmp_path,
        )  # fmt: skip
        v, hits = json.loads(out.stdout.strip().splitlines()[-1])
        return v, hits

    assert run() == (4.0, 0)
    assert run() == (4.0, 1)  # from the cache
    (tmp_path / "c.py").write_text((tmp_path / "c.py").read_text().replace("1.0", "2.0"))
    assert run() == (6.0, 0)  # c changed: compiled again
    assert run() == (6.0, 1)
    (tmp_path / "b.py").write_text((tmp_path / "b.py").read_text().replace("* 1.0", "* 2.0"))
    assert run() == (12.0, 0)


def test_the_models_kernels_depend_on_what_they_inline():
    from pathlib import Path

    from thermogym._jitcache import kernel_sources
    from thermogym.envs import axt211_room
    from thermogym.models import room

    names = {Path(f).name for f in kernel_sources(room._step_kernel)}
    assert {"room.py", "room_dynamics.py", "axt211_dynamics.py", "integrators.py"} <= names
    assert "_vmath.py" in names  # vpow, min/max of the lanes
    # an environment's step kernel (closures over closures): its rows, the room's
    # equations, the turning-point tracker of the KPIs
    step = axt211_room._step_kernels(0, False).step
    env = {Path(f).name for f in kernel_sources(step)}
    assert {"_room_kernels.py", "_kernels.py", "kpis.py", "room_dynamics.py"} <= env
    assert not any("site-packages" in f for f in kernel_sources(room._step_kernel))
