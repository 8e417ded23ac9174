"""The concealed-effect suite is made by the rigs' own physics, never by what explains it.

Issue 14: "a reader must not find one function that both makes an effect and explains
it". The suite (``benchmarks/concealed/``) makes its cases with the rigs
(:mod:`thermogym.rigs`), whose concealed effects are written in the rig modules; the
diagnosis explains them with the model augmentations (:mod:`thermogym.models.augmented`,
:mod:`thermogym.models._effects`) and its own code (:mod:`thermogym.identification.diagnosis`).
Read from the source (AST): an import inside a function counts as well.
"""

from __future__ import annotations

import ast
import importlib.util
import sys
from pathlib import Path

import pytest

import thermogym.rigs

ROOT = Path(__file__).resolve().parents[1]
SUITE = ROOT / "benchmarks" / "concealed"
RIGS = Path(thermogym.rigs.__file__).parent

#: What explains an effect: the model augmentations and the diagnosis.
EXPLAINERS = ("thermogym.models.augmented", "thermogym.models._effects")
DIAGNOSIS = "thermogym.identification.diagnosis"
#: The runners call the diagnosis' public entry point, blind, and nothing else of it.
RUNNERS = {"run.py", "real_data.py"}


def _imports(path: Path) -> list[str]:
    """``module`` or ``module:name`` of every import in a file, at any depth."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.extend(f"{node.module}:{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.extend(a.name for a in node.names)
        elif isinstance(node, ast.Call) and getattr(node.func, "id", "") == "__import__":
            out.extend(str(a.value) for a in node.args if isinstance(a, ast.Constant))
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "import_module":
            out.extend(str(a.value) for a in node.args if isinstance(a, ast.Constant))
    return out


def _touches(imp: str, prefix: str) -> bool:
    mod, _, name = imp.partition(":")
    full = f"{mod}.{name}" if name else mod
    return mod == prefix or mod.startswith(prefix + ".") or full == prefix


def _suite_modules() -> list[Path]:
    return sorted(SUITE.glob("*.py"))


@pytest.mark.parametrize("path", _suite_modules(), ids=lambda p: p.name)
def test_no_suite_module_imports_what_explains_an_effect(path):
    imps = _imports(path)
    bad = [i for i in imps if any(_touches(i, e) for e in EXPLAINERS)]
    assert not bad, f"{path.name} imports a model augmentation: {bad}"
    diag = [i for i in imps if _touches(i, DIAGNOSIS)]
    if path.name in RUNNERS:
        assert set(diag) <= {f"{DIAGNOSIS}:diagnose"}, f"{path.name}: {diag}"
    else:
        assert not diag, f"{path.name} makes cases and imports the diagnosis: {diag}"


def test_the_case_maker_draws_its_effects_from_the_rigs_only():
    imps = {i.partition(":")[0] for i in _imports(SUITE / "cases.py")}
    pkg = {i for i in imps if i.startswith("thermogym")}
    assert pkg <= {"thermogym.recording", "thermogym.rigs"}, pkg


@pytest.mark.parametrize("path", sorted(RIGS.glob("*.py")), ids=lambda p: p.name)
def test_no_rig_module_imports_the_diagnosis_or_an_augmentation(path):
    imps = _imports(path)
    bad = [
        i for i in imps if any(_touches(i, e) for e in (*EXPLAINERS, "thermogym.identification"))
    ]
    assert not bad, f"{path.name}: {bad}"


def test_the_check_sees_imports_inside_functions(tmp_path):
    f = tmp_path / "x.py"
    f.write_text(
        "def make():\n"
        "    from thermogym.models import augmented\n"
        "    import thermogym.identification.diagnosis.effects\n"
        "    __import__('thermogym.models._effects')\n"
    )
    imps = _imports(f)
    assert any(_touches(i, "thermogym.models.augmented") for i in imps)
    assert any(_touches(i, DIAGNOSIS) for i in imps)
    assert any(_touches(i, "thermogym.models._effects") for i in imps)


def _cases():
    spec = importlib.util.spec_from_file_location("_concealed_cases", SUITE / "cases.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


def test_every_case_is_an_effect_of_its_rigs_own_physics():
    from thermogym.rigs import get_rig

    mod = _cases()
    assert mod.CASES
    for case in mod.CASES:
        rig = get_rig(case.plant)
        if case.effect == "none":
            continue
        assert case.effect in rig.supported_effects, case.name
        # the rig's own default magnitude, written in the rig module
        assert case.effect in rig.effect_defaults, case.name
        built = get_rig(case.plant, mod._effects(case))
        assert [e.name for e in built.effects] == [case.effect], case.name
