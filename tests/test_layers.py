"""The package's import graph keeps DESIGN.md's layers and has no cycles.

Reads every module of ``thermogym/`` with :mod:`ast` (nothing is imported):
module-level, function-level and type-checking imports are all dependencies of
the layer rules; the cycle check follows the imports that run (everything but
``if TYPE_CHECKING:`` blocks), wherever they sit, since an import moved into a
function hides a cycle without removing it.

Run it as a script for the picture: ``python tests/test_layers.py`` prints the
package graph, the cycles, the count of function-level imports and the modules
over 1,000 lines.
"""

from __future__ import annotations

import ast
import functools
import sys
from collections import defaultdict
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "thermogym"

#: Modules every part may import: errors, value checks, the vocabulary, numba's cache
#: keys, atomic file writing, CSV dialects and the package's version. Only ``errors`` among them is
#: imported by the others.
FOUNDATION = frozenset(
    {"thermogym", "errors", "_checks", "vocabulary", "_jitcache", "_fileio", "_csvdialect"}
)

#: Shared data contracts and figures: every part above the models may use them.
DATA = frozenset({"recording", "fitresult", "datasets", "plotting"})

#: What each part may import besides itself and the foundation (DESIGN.md, "Dependency
#: direction"; the README's picture). Listed bottom-up; no part lists one above it.
MAY_IMPORT: dict[str, frozenset[str]] = {
    "models": frozenset(),
    "recording": frozenset({"models"}),
    "fitresult": frozenset({"models", "recording"}),
    "datasets": frozenset({"recording"}),
    "plotting": frozenset({"recording"}),
    "rigs": DATA | {"models"},  # models: signal names only (see below)
    "estimation": DATA | {"models"},
    "identification": DATA | {"models"},
    "envs": DATA | {"models", "rigs"},
    "firmware": DATA | {"models", "rigs", "estimation"},
    "controllers": DATA | {"models", "envs"},
}
_BELOW_CLI = frozenset(MAY_IMPORT)
MAY_IMPORT["studies"] = _BELOW_CLI  # "studies may use everything below the CLI"
MAY_IMPORT["demo"] = _BELOW_CLI | {"studies"}
MAY_IMPORT["_cli"] = _BELOW_CLI | {"studies", "demo"}
MAY_IMPORT["cli"] = frozenset({"_cli"})  # nothing imports cli

#: The foundation imports nothing of the package but errors; models only these.
FOUNDATION_MAY_IMPORT = frozenset({"errors"})
MODELS_MAY_IMPORT = frozenset({"errors", "_checks", "vocabulary", "_jitcache"})

#: Third-party modules a part never imports ("plotting stays out of numerical modules").
NEVER_IMPORTS = {"models": ("matplotlib",), "estimation": ("matplotlib",)}

#: Rule violations known today, each with the issue that removes it; the stale-exception
#: test fails once one no longer occurs, so that it is deleted here.
KNOWN_VIOLATIONS: dict[tuple[str, str], str] = {
    # (issue 14 removed the transitional ModelRig with the strut's and spindle's true plants)
}
#: Import cycles known today (the modules of each strongly connected component).
KNOWN_CYCLES: dict[frozenset[str], str] = {
    # (the diagnosis rewrite of issue 15 removed run <-> sindy)
}


@dataclass(frozen=True)
class Import:
    """One ``thermogym`` import: the importing module, the imported module, the names."""

    source: str
    target: str
    names: tuple[str, ...]
    line: int
    runtime: bool  # False inside ``if TYPE_CHECKING:``
    in_function: bool


@dataclass
class Graph:
    """The package's modules, their imports and their sizes."""

    files: dict[str, Path] = field(default_factory=dict)
    packages: set[str] = field(default_factory=set)
    imports: list[Import] = field(default_factory=list)
    third_party: dict[str, set[str]] = field(default_factory=lambda: defaultdict(set))
    function_level: int = 0

    def resolve(self, name: str) -> str | None:
        """The module ``name`` denotes, or its nearest enclosing module of the package."""
        while name and name not in self.files:
            name = name.rpartition(".")[0]
        return name or None


def module_name(path: Path, root: Path = ROOT) -> tuple[str, bool]:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        return ".".join(parts[:-1]), True
    return ".".join(parts), False


def part(module: str) -> str:
    """The top-level part a module belongs to (``thermogym.models.axt211`` → ``models``)."""
    bits = module.split(".")
    return "thermogym" if len(bits) == 1 else bits[1]


def _is_type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING"
    )


_Found = Iterator[tuple[ast.Import | ast.ImportFrom, bool, bool]]


def _walk(node: ast.AST, runtime: bool, in_function: bool) -> _Found:
    for child in ast.iter_child_nodes(node):
        yield from _visit(child, runtime, in_function)


def _visit(node: ast.AST, runtime: bool, in_function: bool) -> _Found:
    if isinstance(node, ast.Import | ast.ImportFrom):
        yield node, runtime, in_function
    elif isinstance(node, ast.If) and _is_type_checking(node):
        for sub in node.body:
            yield from _visit(sub, False, in_function)
        for sub in node.orelse:
            yield from _visit(sub, runtime, in_function)
    else:
        fn = isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
        yield from _walk(node, runtime, in_function or fn)


def build_graph(package: Path = PACKAGE) -> Graph:
    """Parse every module of the package and collect its imports."""
    g = Graph()
    trees: dict[str, tuple[ast.Module, bool]] = {}
    for path in sorted(package.rglob("*.py")):
        name, is_pkg = module_name(path, package.parent)
        g.files[name] = path
        if is_pkg:
            g.packages.add(name)
        trees[name] = (ast.parse(path.read_text(encoding="utf-8"), str(path)), is_pkg)
    for name, (tree, is_pkg) in trees.items():
        base = name if is_pkg else name.rpartition(".")[0]
        for node, runtime, in_function in _walk(tree, True, False):
            g.function_level += in_function
            if isinstance(node, ast.Import):
                pairs = [(a.name, ()) for a in node.names]
            else:
                if node.level:
                    anchor = base.split(".")[: len(base.split(".")) - (node.level - 1)]
                    mod = ".".join(anchor + ([node.module] if node.module else []))
                else:
                    mod = node.module or ""
                pairs = []
                for a in node.names:
                    sub = f"{mod}.{a.name}"
                    pairs.append((sub, ()) if sub in g.files else (mod, (a.name,)))
            for mod, names in pairs:
                if mod.split(".")[0] != "thermogym":
                    g.third_party[name].add(mod.split(".")[0])
                    continue
                target = g.resolve(mod)
                if target is not None and target != name:
                    g.imports.append(Import(name, target, names, node.lineno, runtime, in_function))
    return g


def _defines(g: Graph, module: str, name: str, seen: int = 0) -> str:
    """``"class"``, ``"function"`` or ``"other"``: what ``name`` is in ``module``."""
    tree = ast.parse(g.files[module].read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.ClassDef) and node.name == name:
            return "class"
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and node.name == name:
            return "function"
        if isinstance(node, ast.ImportFrom) and node.module and seen < 5:
            for a in node.names:
                if (a.asname or a.name) == name and node.module in g.files:
                    return _defines(g, node.module, a.name, seen + 1)
    return "other"


def layer_violations(g: Graph) -> list[tuple[str, str, str]]:
    """Every import against the rules: ``(source, imported, why)``."""
    out = []
    for imp in g.imports:
        src, dst = part(imp.source), part(imp.target)
        what = ", ".join(f"{imp.target}.{n}" for n in imp.names) or imp.target
        if src == dst:
            pass
        elif src in FOUNDATION:
            if dst not in FOUNDATION_MAY_IMPORT:
                out.append((imp.source, what, "the foundation imports only errors"))
        elif src == "models":
            if dst not in MODELS_MAY_IMPORT:
                out.append((imp.source, what, f"models import only {sorted(MODELS_MAY_IMPORT)}"))
        elif dst not in FOUNDATION and dst not in MAY_IMPORT.get(src, frozenset()):
            out.append((imp.source, what, f"{src} may not import {dst} (DESIGN.md)"))
        if src == "rigs" and dst == "models":
            # "rigs never import a plant model": signal names may be shared, classes and
            # kernels may not
            targets = [(imp.target, n) for n in imp.names] or [(imp.target, "")]
            for mod, n in targets:
                kind = _defines(g, mod, n) if n else "module"
                if kind != "other":
                    out.append((imp.source, f"{mod}.{n}" if n else mod, "rigs import a model"))
    for module, mods in g.third_party.items():
        for bad in NEVER_IMPORTS.get(part(module), ()):
            if bad in mods:
                out.append((module, bad, f"{part(module)} never imports {bad}"))
    return out


#: Parts that use the models only through their public kernel API: never a private name of
#: ``thermogym.models`` (a module ``_x``, a name ``_y`` imported from or read off a module).
PUBLIC_MODEL_API_ONLY = frozenset({"envs"})


def private_model_names(g: Graph, parts: frozenset[str] | None = None) -> list[tuple[str, str]]:
    """``(module, name)`` for every private name of ``thermogym.models`` a module reaches.

    Found statically: private modules imported, private names imported from a models
    module, and private attributes read off a name bound to a models module
    (``from thermogym.models import axt211 as ax; ax._rhs``).
    """
    out = []
    for name, path in g.files.items():
        if part(name) == "models" or (parts is not None and part(name) not in parts):
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        aliases: set[str] = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith(
                "thermogym.models"
            ):
                mod = node.module or ""
                for a in node.names:
                    full = f"{mod}.{a.name}"
                    private = any(b.startswith("_") for b in full.split("."))
                    if private:
                        out.append((name, full))
                    if full in g.files:  # a module bound to a name
                        aliases.add(a.asname or a.name)
            elif isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.startswith("thermogym.models"):
                        if any(b.startswith("_") for b in a.name.split(".")):
                            out.append((name, a.name))
                        if a.asname:
                            aliases.add(a.asname)
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Attribute)
                and node.attr.startswith("_")
                and not node.attr.startswith("__")
                and isinstance(node.value, ast.Name)
                and node.value.id in aliases
            ):
                out.append((name, f"{node.value.id}.{node.attr}"))
    return sorted(set(out))


def cycles(g: Graph) -> list[frozenset[str]]:
    """Strongly connected components (more than one module) of the run-time import graph."""
    edges: dict[str, set[str]] = defaultdict(set)
    for imp in g.imports:
        if imp.runtime:
            edges[imp.source].add(imp.target)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[frozenset[str]] = []

    def visit(v: str) -> None:  # Tarjan's algorithm
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(frozenset(comp))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(g.files)))
    for v in sorted(g.files):
        if v not in index:
            visit(v)
    return found


def package_graph(g: Graph) -> dict[str, set[str]]:
    """Part → parts it imports (foundation left out)."""
    out: dict[str, set[str]] = defaultdict(set)
    for imp in g.imports:
        a, b = part(imp.source), part(imp.target)
        if a != b and b not in FOUNDATION:
            out[a].add(b)
    return out


# ------------------------------------------------------------------------ the tests
@functools.cache
def _graph() -> Graph:
    return build_graph()


def test_every_module_belongs_to_a_known_part():
    g = _graph()
    unknown = {part(m) for m in g.files} - set(MAY_IMPORT) - FOUNDATION
    assert not unknown, f"parts without a layer rule: {sorted(unknown)}; add them to MAY_IMPORT"


def test_the_layer_table_is_acyclic():
    # the table itself is the layer picture: a part never lists a part that lists it
    for a, allowed in MAY_IMPORT.items():
        for b in allowed:
            assert a not in MAY_IMPORT.get(b, frozenset()), f"{a} and {b} may import each other"


def test_imports_follow_the_layers():
    bad = [v for v in layer_violations(_graph()) if v[:2] not in KNOWN_VIOLATIONS]
    assert not bad, "imports against DESIGN.md's layers:\n" + "\n".join(
        f"  {s} imports {w}: {why}" for s, w, why in bad
    )


def test_no_import_cycles():
    new = [c for c in cycles(_graph()) if c not in KNOWN_CYCLES]
    assert not new, "import cycles (an import inside a function hides, not removes, one):\n" + (
        "\n".join("  " + " <-> ".join(sorted(c)) for c in new)
    )


def test_envs_use_only_the_public_kernel_api_of_the_models():
    bad = private_model_names(_graph(), PUBLIC_MODEL_API_ONLY)
    assert not bad, "private names of thermogym.models used by:\n" + "\n".join(
        f"  {m}: {n}" for m, n in bad
    )


def test_the_private_name_check_finds_them(tmp_path):
    pkg = tmp_path / "thermogym"
    (pkg / "models").mkdir(parents=True)
    (pkg / "envs").mkdir()
    for p in (pkg, pkg / "models", pkg / "envs"):
        (p / "__init__.py").write_text("")
    (pkg / "models" / "a.py").write_text("def _k():\n    pass\n\ndef k():\n    pass\n")
    (pkg / "models" / "_b.py").write_text("")
    (pkg / "envs" / "c.py").write_text(
        "from thermogym.models import a as m\nfrom thermogym.models import _b\n"
        "from thermogym.models.a import _k, k\nm._k()\nm.k()\n"
    )
    found = private_model_names(build_graph(pkg), PUBLIC_MODEL_API_ONLY)
    assert found == [
        ("thermogym.envs.c", "m._k"),
        ("thermogym.envs.c", "thermogym.models._b"),
        ("thermogym.envs.c", "thermogym.models.a._k"),
    ]


def test_known_exceptions_still_occur():
    g = _graph()
    gone = set(KNOWN_VIOLATIONS) - {v[:2] for v in layer_violations(g)}
    gone_cycles = set(KNOWN_CYCLES) - set(cycles(g))
    assert not gone and not gone_cycles, (
        f"known exceptions that no longer occur, delete them from this file: "
        f"{sorted(gone)} {[sorted(c) for c in gone_cycles]}"
    )


def test_the_checker_finds_a_cycle_and_a_layer_violation(tmp_path):
    # a two-module package whose models import envs, and envs import models in a function
    pkg = tmp_path / "thermogym"
    (pkg / "models").mkdir(parents=True)
    (pkg / "envs").mkdir()
    for p in (pkg, pkg / "models", pkg / "envs"):
        (p / "__init__.py").write_text("")
    (pkg / "models" / "a.py").write_text("from thermogym.envs.b import step\n")
    (pkg / "envs" / "b.py").write_text("def step():\n    from thermogym.models import a\n")
    g = build_graph(pkg)
    assert cycles(g) == [frozenset({"thermogym.models.a", "thermogym.envs.b"})]
    assert [v[:2] for v in layer_violations(g)] == [("thermogym.models.a", "thermogym.envs.b.step")]
    assert g.function_level == 1


def _report() -> None:  # pragma: no cover - the script's output
    g = build_graph()
    print(f"{len(g.files)} modules; {g.function_level} imports inside functions")
    print("package graph (foundation left out):")
    for a, bs in sorted(package_graph(g).items()):
        print(f"  {a:15s} -> {', '.join(sorted(bs))}")
    print("import cycles:", [sorted(c) for c in cycles(g)] or "none")
    print("layer violations:", layer_violations(g) or "none")
    print("private names of thermogym.models used elsewhere:")
    for m, n in private_model_names(g):
        print(f"  {m}: {n}")
    sizes = {m: len(p.read_text(encoding="utf-8").splitlines()) for m, p in g.files.items()}
    print("modules over 1,000 lines:")
    for m, n in sorted(sizes.items(), key=lambda kv: -kv[1]):
        if n > 1000:
            print(f"  {n:5d} {m}")


if __name__ == "__main__":  # pragma: no cover
    _report()
