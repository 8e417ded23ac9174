"""Adapter for a Python script whose uncertain parameters are variables in it.

Paper 000 (``000_24627a5308ee07db.txt``, section 3, workflow steps 1-2):
"models that have been written as scripts contain adjustable parameters as
variables"; the user names the script and the variables to optimise, and may
set other variables manually. The script is used as it is, never converted.

The contract
------------
Before the script runs, its global namespace holds

* each uncertain parameter and each value set manually (``fixed``), as a
  Python ``float`` under its variable name;
* each input variable (``inputs``: model variable → recording column), as a
  float64 array (T,) — a copy the script may change;
* the recording's sample times [s] as an array (T,) under ``time`` (or the
  name given by ``time_variable``);
* ``__name__ == "__thermogym__"`` (so an ``if __name__ == "__main__":``
  block, e.g. plotting for a stand-alone run, is skipped) and ``__file__``.

The script runs top to bottom and leaves each output variable (``outputs``)
as an array (T,) on the recording's time grid in its global namespace. When
it computes on a grid of its own, it names that grid's times in
``output_time``; the outputs are then interpolated linearly onto the
recording's times.

**Default values stay in the script.** So that the script still runs on its
own, it may give every injected variable a default value. The *first*
module-level statement that assigns such a variable with a plain
``name = value`` (or ``name: type = value``) is taken as its default and is
skipped when the adapter runs the script (the syntax tree is rewritten when
the script is loaded; the file is not changed and line numbers stay). Later
assignments run as written (``K = K * 1e-3`` converts the injected value).
A default given any other way (tuple assignment, import, ``def``) is refused
with an error naming the line, because it would silently replace the
injected value. Assignments inside ``if``/``try`` blocks run as written:
guard them (``if "K" not in globals(): K = 2.0``).

The script is compiled once per worker process; modules it imports stay
imported between evaluations, so only the script body runs per evaluation.
Its folder is put on ``sys.path`` (sibling modules import) and it runs in
``workdir`` (default: its folder).

Example script::

    import numpy as np
    K = 2.0        # gain [K/W]: uncertain parameter (default for stand-alone runs)
    tau = 300.0    # time constant [s]: uncertain parameter
    time = np.arange(0.0, 3600.0, 10.0)
    P = np.where(time > 60.0, 50.0, 0.0)       # heater power [W] (input)
    a = np.exp(-np.diff(time) / tau)
    y = np.zeros_like(time)
    for k in range(len(time) - 1):             # exact zero-order-hold step
        y[k + 1] = a[k] * y[k] + (1 - a[k]) * K * P[k]
"""

from __future__ import annotations

import ast
import builtins
import contextlib
import os
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from thermogym.errors import ConfigError
from thermogym.identification.external._evaluate import (
    Evaluator,
    ExperimentData,
    OutputError,
    Outputs,
    traceback_line,
)
from thermogym.identification.external.base import ExternalModel, common_kwargs, file_digest

if TYPE_CHECKING:
    from thermogym.identification.external.config import ExternalConfig

__all__ = ["ScriptModel", "rewrite_script"]


def _bindings(node: ast.AST) -> Iterator[tuple[str, str]]:
    """Names a statement binds in the module scope, with how (``simple`` or another kind).

    Does not descend into function or class bodies, lambdas or comprehensions
    (their own scopes).
    """
    if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
        yield node.name, "definition"
        return
    if isinstance(node, ast.Import | ast.ImportFrom):
        for a in node.names:
            if a.name != "*":
                yield (a.asname or a.name.split(".")[0]), "import"
        return
    if isinstance(node, ast.Lambda | ast.ListComp | ast.SetComp | ast.DictComp | ast.GeneratorExp):
        return
    if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store | ast.Del):
        yield node.id, "assignment"
        return
    if isinstance(node, ast.NamedExpr) and isinstance(node.target, ast.Name):
        yield node.target.id, "assignment expression"
    for child in ast.iter_child_nodes(node):
        yield from _bindings(child)


def _simple_target(stmt: ast.stmt) -> str | None:
    """The name of a plain ``name = value`` / ``name: T = value`` statement."""
    if isinstance(stmt, ast.Assign) and len(stmt.targets) == 1:
        t = stmt.targets[0]
        if isinstance(t, ast.Name):
            return t.id
    if (
        isinstance(stmt, ast.AnnAssign)
        and stmt.value is not None
        and isinstance(stmt.target, ast.Name)
    ):
        return stmt.target.id
    return None


def rewrite_script(
    source: str, filename: str, injected: set[str] | frozenset[str]
) -> tuple[ast.Module, dict[str, int]]:
    r"""Skip the first module-level default assignment of each injected variable.

    Parameters
    ----------
    source : str
        Script text.
    filename : str
        For messages.
    injected : set of str
        Variables the adapter sets before the script runs.

    Returns
    -------
    tree : ast.Module
        The rewritten syntax tree (line numbers unchanged).
    defaults : dict
        Variable → line of the default assignment that is skipped.

    Raises
    ------
    ConfigError
        Syntax error, or an injected variable whose first module-level binding
        is not a plain assignment (it would override the injected value).

    Examples
    --------
    >>> tree, defaults = rewrite_script("K = 2.0\ny = K * 3\n", "s.py", {"K"})
    >>> defaults
    {'K': 1}
    >>> ns = {"K": 5.0}
    >>> exec(compile(tree, "s.py", "exec"), ns)
    >>> ns["y"]
    15.0
    """
    try:
        tree = ast.parse(source, filename=filename)
    except SyntaxError as e:
        raise ConfigError(f"script {filename!r} line {e.lineno}: {e.msg}") from e
    seen: set[str] = set()
    defaults: dict[str, int] = {}
    body: list[ast.stmt] = []
    for stmt in tree.body:
        name = _simple_target(stmt)
        if name is not None and name in injected and name not in seen:
            seen.add(name)
            defaults[name] = stmt.lineno
            body.append(ast.copy_location(ast.Pass(), stmt))
            continue
        compound = isinstance(
            stmt,
            ast.If
            | ast.For
            | ast.AsyncFor
            | ast.While
            | ast.Try
            | ast.TryStar
            | ast.With
            | ast.AsyncWith,
        )
        for bound, how in _bindings(stmt):
            if bound not in injected or bound in seen:
                continue
            seen.add(bound)
            if not compound and not isinstance(stmt, ast.AugAssign):
                advice = (
                    f"import it under another name (import ... as _{bound}) or give the "
                    "adapter another variable name"
                    if how == "import"
                    else f"write its default as a plain '{bound} = value' line"
                )
                raise ConfigError(
                    f"script {filename!r} line {stmt.lineno} gives the variable {bound!r} "
                    f"its first value by {how}, which would replace the value the adapter "
                    f"sets; {advice}"
                )
        body.append(stmt)
    tree.body = body
    return tree, defaults


def _names_used(tree: ast.AST) -> tuple[set[str], set[str]]:
    """(names read or written anywhere, names assigned in the module scope or declared global)."""
    used: set[str] = set()
    stored: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            used.add(node.id)
        elif isinstance(node, ast.Global):
            used.update(node.names)
            stored.update(node.names)
    for stmt in tree.body if isinstance(tree, ast.Module) else []:
        stored.update(n for n, _ in _bindings(stmt))
    return used, stored


class _ScriptEvaluator(Evaluator):
    def __init__(
        self,
        path: Path,
        injected: frozenset[str],
        time_variable: str,
        output_time: str | None,
        workdir: Path | None,
    ) -> None:
        self.path = str(path)
        self.injected = injected
        self.time_variable = time_variable
        self.output_time = output_time
        self.workdir = str(workdir) if workdir is not None else None
        self.label = f"script {path.name!r}"

    def setup(self) -> None:
        source = Path(self.path).read_text(encoding="utf-8")
        tree, _ = rewrite_script(source, self.path, self.injected)
        self._live_code = compile(tree, self.path, "exec")
        folder = os.path.dirname(self.path)
        if folder not in sys.path:
            sys.path.insert(0, folder)

    def run(self, params: dict[str, float], exp: ExperimentData, timeout: float | None) -> Any:
        ns: dict[str, Any] = {
            "__name__": "__thermogym__",
            "__file__": self.path,
            "__builtins__": builtins,
        }
        ns.update(params)
        ns.update({k: v.copy() for k, v in exp.inputs.items()})
        ns[self.time_variable] = exp.time.copy()
        cwd = contextlib.chdir(self.workdir) if self.workdir else contextlib.nullcontext()
        with cwd:
            exec(self._live_code, ns)
        values = {v: ns[v] for v in self.output_vars if v in ns}
        if len(values) < len(self.output_vars):
            missing = [v for v in self.output_vars if v not in ns]
            raise OutputError(
                f"the script left no variable {missing[0]!r} (outputs {list(self.output_vars)})"
            )
        if self.output_time is not None:
            if self.output_time not in ns:
                raise OutputError(f"the script left no variable {self.output_time!r} (output_time)")
            return Outputs(values, time=ns[self.output_time])
        return values

    def describe_error(self, exc: BaseException) -> str:
        line = traceback_line(exc, self.path)
        where = f" (script {os.path.basename(self.path)} line {line})" if line else ""
        return f"{type(exc).__name__}: {exc}{where}"


class ScriptModel(ExternalModel):
    r"""A Python script as an identifiable model (see the module docstring).

    Parameters
    ----------
    path : path
        The ``.py`` script.
    parameters, outputs, inputs, fixed
        As :class:`~.base.ExternalModel`; names are the script's variables.
    name : str, optional
        Default: the script's file stem.
    time_variable : str
        Variable holding the sample times (default ``"time"``).
    output_time : str, optional
        Variable holding the times of the outputs when the script computes on
        a grid of its own.
    workdir : path, optional
        Folder the script runs in (default: its folder).
    **evaluation
        ``timeout``, ``kill_grace``, ``backend``, ``workers``, ``chunksize``,
        ``ray_options``.

    Raises
    ------
    ConfigError
        The script cannot be read or parsed; a parameter, fixed value or
        input does not occur in it; an output is never assigned; a default is
        given in a way the adapter cannot replace.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from thermogym.recording import Recording
    >>> script = pathlib.Path(tempfile.mkdtemp()) / "gain.py"
    >>> _ = script.write_text("K = 1.0\ny = K * u\n")
    >>> rec = Recording(np.arange(3.0), {"u": [1.0, 2.0, 3.0]})
    >>> with ScriptModel(script, parameters={"K": (1.0, 0.0, 5.0)}, inputs=["u"],
    ...                  outputs=["y"], backend="serial") as m:
    ...     m.simulate(np.array([[2.0]]), rec).outputs[0, :, 0]
    array([2., 4., 6.])
    """

    evaluator: _ScriptEvaluator

    kind = "script"

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        parameters: Any,
        outputs: Mapping[str, str] | list[str],
        inputs: Mapping[str, str] | list[str] | None = None,
        fixed: Mapping[str, float] | None = None,
        name: str | None = None,
        time_variable: str = "time",
        output_time: str | None = None,
        workdir: str | os.PathLike[str] | None = None,
        **evaluation: Any,
    ) -> None:
        p = Path(path).resolve()
        if not p.is_file():
            raise ConfigError(f"script {str(p)!r} does not exist")
        placeholder = _ScriptEvaluator(p, frozenset(), time_variable, output_time, None)
        super().__init__(
            placeholder,
            name=name or p.stem,
            parameters=parameters,
            outputs=outputs,
            inputs=inputs,
            fixed=fixed,
            **evaluation,
        )
        injected = frozenset({*self.param_names, *self.fixed, *self.inputs, time_variable})
        if time_variable in {*self.param_names, *self.fixed, *self.inputs, *self.outputs}:
            raise ConfigError(f"time_variable {time_variable!r} is also a parameter or signal")
        try:
            source = p.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise ConfigError(f"cannot read script {str(p)!r}: {e}") from e
        tree, self.defaults = rewrite_script(source, str(p), injected)
        used, stored = _names_used(tree)
        for key, names in (
            ("parameters", self.param_names),
            ("fixed", self.fixed),
            ("inputs", self.inputs),
        ):
            for n in names:
                if n not in used:
                    raise ConfigError(
                        f"configuration key '{key}.{n}': {n!r} is not a variable of script "
                        f"{p.name!r} (paper 000 workflow step 1: the uncertain parameters must be "
                        "variables of the script)"
                    )
        for n in [*self.outputs, *([output_time] if output_time else [])]:
            if n not in stored:
                key = "output_time" if n == output_time else f"outputs.{n}"
                raise ConfigError(
                    f"configuration key '{key}': script {p.name!r} never assigns {n!r} in its "
                    "module scope"
                )
        ev = _ScriptEvaluator(
            p, injected, time_variable, output_time, Path(workdir) if workdir else p.parent
        )
        ev.output_vars = tuple(self.outputs)
        self.evaluator = ev
        self.path = p
        self._used = used
        self._type_config = {
            "path": str(p),
            "time_variable": time_variable,
            **({"output_time": output_time} if output_time else {}),
        }
        if workdir:
            self._type_config["workdir"] = str(Path(workdir).resolve())
        self._source_digest = file_digest(p)
        self._ready = True

    def _new_value_names(self, names: list[str]) -> None:
        """A new manual value: its default in the script must be skipped too."""
        for n in names:
            if n not in self._used:
                raise ConfigError(f"{n!r} is not a variable of script {self.path.name!r}")
        old = self.evaluator
        injected = frozenset({*old.injected, *names})
        source = self.path.read_text(encoding="utf-8")
        _, self.defaults = rewrite_script(source, str(self.path), injected)
        ev = _ScriptEvaluator(
            self.path, injected, old.time_variable, old.output_time, Path(old.workdir or ".")
        )
        ev.output_vars = old.output_vars
        self.close()  # workers compiled the old script; new ones start on the next call
        self.evaluator = ev

    @classmethod
    def from_config(cls, cfg: ExternalConfig) -> ScriptModel:
        """Build from a checked configuration (``type = "script"``)."""
        o = cfg.options
        return cls(
            o["path"],
            time_variable=o.get("time_variable", "time"),
            output_time=o.get("output_time"),
            workdir=cfg.workdir,
            **common_kwargs(cfg),
        )
