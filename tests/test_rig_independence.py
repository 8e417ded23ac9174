"""Rigs are written apart from the models: no rig module imports a plant model's code.

A rig may share signal names and units with a model (its recordings carry the model's
column names), never a model class, kernel or parameter table: read from the source (AST),
so an import inside a function counts as well.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import thermogym.rigs

RIGS = Path(thermogym.rigs.__file__).parent
#: Names a rig may take from thermogym.models: signal-name tuples and the signal record.
ALLOWED_NAMES = {"Signal", "STRUT_OUTPUTS", "SPINDLE_OUTPUTS"}
#: The transitional ModelRig (a rig built on a model): removed with its last user (every rig
#: has a true plant of its own now).
PENDING: set[str] = set()
#: Rigs still on ModelRig: none.
LEGACY_USERS: set[str] = set()


def _model_imports(path: Path) -> list[str]:
    """``module:name`` of every import from thermogym.models in a file, at any depth."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            if node.module == "thermogym.models" or node.module.startswith("thermogym.models."):
                found.extend(f"{node.module}:{a.name}" for a in node.names)
            elif node.module == "thermogym" and any(a.name == "models" for a in node.names):
                found.append("thermogym:models")
        elif isinstance(node, ast.Import):
            found.extend(a.name for a in node.names if a.name.startswith("thermogym.models"))
        elif isinstance(node, ast.Call) and getattr(node.func, "id", "") == "__import__":
            args = [a.value for a in node.args if isinstance(a, ast.Constant)]
            found.extend(str(a) for a in args if str(a).startswith("thermogym.models"))
    return found


def _modules() -> list[Path]:
    return sorted(p for p in RIGS.glob("*.py"))


@pytest.mark.parametrize("path", _modules(), ids=lambda p: p.name)
def test_rig_module_imports_no_plant_model(path):
    if path.name in PENDING:
        pytest.skip(f"{path.name}: still on a model (pending its true plant)")
    bad = [i for i in _model_imports(path) if i.split(":")[-1] not in ALLOWED_NAMES]
    assert not bad, f"{path.name} imports model code: {bad}"


def test_the_check_catches_an_import_inside_a_function(tmp_path):
    f = tmp_path / "x.py"
    f.write_text(
        "def plant():\n    from thermogym.models.registry import get_model\n"
        "    import thermogym.models.axt211\n"
    )
    assert _model_imports(f) == ["thermogym.models.registry:get_model", "thermogym.models.axt211"]


def _uses_legacy(path: Path) -> bool:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return any(
        isinstance(n, ast.ImportFrom) and n.module == "thermogym.rigs._legacy"
        for n in ast.walk(tree)
    )


def test_only_the_known_rigs_still_stand_on_a_model():
    users = {p.name for p in _modules() if _uses_legacy(p)}
    assert users <= LEGACY_USERS, f"new rigs on a model: {users - LEGACY_USERS}"
    # an exception for a module that no longer needs it must be removed
    assert users == LEGACY_USERS, f"remove {LEGACY_USERS - users} from LEGACY_USERS"
    for name in PENDING:
        path = RIGS / name
        if not users:
            assert not path.exists(), f"{name} is no longer used: remove it and PENDING"
        else:
            assert [i for i in _model_imports(path) if i.split(":")[-1] not in ALLOWED_NAMES]


def test_true_plant_rigs_build_no_model():
    from thermogym.rigs import get_rig
    from thermogym.rigs.base import TruePlant

    for name in ("axt211", "room", "strut", "spindle"):
        assert isinstance(get_rig(name).plant(), TruePlant)
