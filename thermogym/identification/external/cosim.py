"""Co-simulation: several models identified together against one criterion.

Paper 000 (``000_24627a5308ee07db.txt``, section 1): "it is even possible to
combine external models (cosimulation). For example, the parameters of a
Matlab script model can in that way easily be optimized simultaneously with
parameters of a Python script model."

:class:`CoSimModel` is a :class:`~thermogym.identification.simmodel.SimModel`
made of named sub-models (any ``SimModel``: external adapters or
:class:`~thermogym.identification.simmodel.ThermogymModel`):

* its parameters are the sub-models' parameters, prefixed with the
  sub-model's name (``heater.K``, ``wall.tau``), so equal names in two models
  stay apart;
* its outputs are the sub-models' outputs, concatenated in the order the
  models are given (output names must be unique: they are the recording
  columns the criterion compares);
* a connection ``("heater.T_h", "wall.T_in")`` feeds the simulated output
  ``T_h`` of ``heater`` into the input ``T_in`` of ``wall`` instead of the
  recording's column, for each parameter set separately. Models run in
  dependency order; each output trajectory is computed completely before it
  feeds the next model (sequential coupling: connections must not form a
  loop — a feedback loop needs step-wise co-simulation, e.g. an FMI master
  algorithm inside one FMU).

Its inputs are the sub-models' inputs that no connection feeds. A parameter
set that fails in one model is reported with the model's name and is not
passed on to the models it feeds.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym.errors import ConfigError, ParameterError
from thermogym.identification.external import build_model

if TYPE_CHECKING:
    from thermogym.identification.external.config import ExternalConfig
    from thermogym.identification.simmodel import SimBatch, SimModel
    from thermogym.recording import Recording

__all__ = ["CoSimModel"]


def _split(end: str | tuple[str, str], what: str) -> tuple[str, str]:
    if isinstance(end, tuple) and len(end) == 2:
        return end
    if isinstance(end, str) and end.count(".") == 1:
        m, s = end.split(".")
        return m, s
    raise ConfigError(f"connection {what} {end!r}: expected 'model.signal'")


class CoSimModel:
    """Several models whose parameters are identified simultaneously (see the module docstring).

    Parameters
    ----------
    models : mapping
        Prefix → SimModel, in output order.
    connections : sequence of (source, target)
        ``("a.y", "b.u")``: output ``y`` of model ``a`` feeds input ``u`` of
        model ``b`` (names are the sub-models' recording columns).
    name : str

    Raises
    ------
    ConfigError
        Unknown model or signal in a connection, an input fed twice, a loop,
        or an output name used by two models.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.recording import Recording
    >>> from thermogym.identification.external import CallableModel
    >>> def gain(time, inputs, params):
    ...     return {"y": params["K"] * inputs["u"]}
    >>> a = CallableModel(gain, parameters={"K": (2.0, 0, 5)}, inputs=["u"],
    ...                   outputs={"y": "y_a"}, backend="serial")
    >>> b = CallableModel(gain, parameters={"K": (3.0, 0, 5)}, inputs={"u": "u_b"},
    ...                   outputs={"y": "y_b"}, backend="serial")
    >>> with CoSimModel({"a": a, "b": b}, [("a.y_a", "b.u_b")]) as m:
    ...     print(m.param_names, m.input_names, m.output_names)
    ...     out = m.simulate(np.array([[2.0, 3.0]]), Recording([0.0, 1.0], {"u": [1.0, 2.0]}))
    ('a.K', 'b.K') ('u',) ('y_a', 'y_b')
    >>> out.outputs[0]
    array([[ 2.,  6.],
           [ 4., 12.]])
    """

    def __init__(
        self,
        models: Mapping[str, SimModel],
        connections: Sequence[tuple[Any, Any]] = (),
        *,
        name: str = "cosim",
    ) -> None:
        if not models:
            raise ConfigError("a co-simulation needs at least one model")
        for prefix in models:
            if not isinstance(prefix, str) or not prefix.isidentifier():
                raise ConfigError(f"model prefix {prefix!r} is not an identifier")
        self.models = dict(models)
        self.name = name
        # feeds[target_model][target_input] = (source_model, source_output)
        self.feeds: dict[str, dict[str, tuple[str, str]]] = {p: {} for p in self.models}
        for src, dst in connections:
            (ma, sa), (mb, sb) = _split(src, "source"), _split(dst, "target")
            for m, s, kind, names in (
                (ma, sa, "output", "output_names"),
                (mb, sb, "input", "input_names"),
            ):
                if m not in self.models:
                    raise ConfigError(
                        f"connection {src!r} -> {dst!r}: no model {m!r}; models are "
                        f"{list(self.models)}"
                    )
                have = getattr(self.models[m], names)
                if s not in have:
                    raise ConfigError(
                        f"connection {src!r} -> {dst!r}: {s!r} is not an {kind} of model {m!r}; "
                        f"its {kind}s are {list(have)}"
                    )
            if sb in self.feeds[mb]:
                raise ConfigError(f"input {mb}.{sb} is fed by two connections")
            if ma == mb:
                raise ConfigError(
                    f"connection {src!r} -> {dst!r} feeds a model with itself (a loop)"
                )
            self.feeds[mb][sb] = (ma, sa)
        self.order = self._topological_order()

        self.param_names: tuple[str, ...] = ()
        self._slices: dict[str, slice] = {}
        nominal, lower, upper = [], [], []
        for p, model in self.models.items():
            start = len(self.param_names)
            self.param_names += tuple(f"{p}.{n}" for n in model.param_names)
            self._slices[p] = slice(start, len(self.param_names))
            nominal.append(np.asarray(model.nominal, dtype=float))
            lower.append(np.asarray(model.lower, dtype=float))
            upper.append(np.asarray(model.upper, dtype=float))
        self.nominal = np.concatenate(nominal)
        self.lower = np.concatenate(lower)
        self.upper = np.concatenate(upper)
        outs: list[str] = []
        for p, model in self.models.items():
            for o in model.output_names:
                if o in outs:
                    raise ConfigError(
                        f"output {o!r} of model {p!r} is also an output of another model; "
                        "map the outputs to distinct recording columns"
                    )
                outs.append(o)
        self.output_names = tuple(outs)
        ins: list[str] = []
        for p, model in self.models.items():
            for i in model.input_names:
                if i not in self.feeds[p] and i not in ins:
                    ins.append(i)
        self.input_names = tuple(ins)
        self.batched = all(bool(getattr(m, "batched", False)) for m in self.models.values())

    def _topological_order(self) -> list[str]:
        # Kahn's algorithm, stable in the order the models were given
        deps = {p: {src for src, _ in f.values()} for p, f in self.feeds.items()}
        order: list[str] = []
        while len(order) < len(self.models):
            ready = [p for p in self.models if p not in order and deps[p] <= set(order)]
            if not ready:
                left = [p for p in self.models if p not in order]
                raise ConfigError(f"the connections form a loop among the models {left}")
            order.append(ready[0])
        return order

    def _theta(self, theta: ArrayLike) -> NDArray[np.float64]:
        th = np.asarray(theta, dtype=float)
        if th.ndim == 1:
            th = th[None, :]
        P = len(self.param_names)
        if th.ndim != 2 or th.shape[1] != P:
            raise ParameterError(
                f"theta has shape {np.shape(theta)}, expected (B, {P}) for {list(self.param_names)}"
            )
        return th

    def _run_fed(
        self, prefix: str, th: NDArray[np.float64], experiment: Recording, overrides: dict[str, Any]
    ) -> SimBatch:
        """Simulate a model whose inputs are partly other models' outputs (one set per row)."""
        # lazy: workers start without pandas (see base)
        from thermogym.identification.simmodel import SimBatch

        m = self.models[prefix]
        if hasattr(m, "simulate_sets"):
            return m.simulate_sets(th, experiment, overrides)
        # any other SimModel: one simulation per parameter set with its own columns
        outs, errs = [], []
        for b in range(th.shape[0]):
            rec = experiment.with_columns({c: v[b] for c, v in overrides.items()})
            r = m.simulate(th[b : b + 1], rec)
            outs.append(r.outputs[0])
            errs.append(r.errors[0])
        return SimBatch(np.stack(outs), errs)

    def simulate(self, theta: ArrayLike, experiment: Recording) -> SimBatch:
        """Simulate the sub-models in dependency order; outputs concatenated.

        Parameters
        ----------
        theta : array_like, shape (B, P)
            Values of :attr:`param_names`.
        experiment : Recording

        Returns
        -------
        SimBatch
            Errors are prefixed with the model's name.
        """
        # lazy: workers start without pandas (see base)
        from thermogym.identification.simmodel import SimBatch

        th = self._theta(theta)
        B, T = th.shape[0], experiment.n_samples
        errors: list[str | None] = [None] * B
        results: dict[str, NDArray[np.float64]] = {}
        for p in self.order:
            m = self.models[p]
            th_m = th[:, self._slices[p]]
            n_out = len(m.output_names)
            full = np.full((B, T, n_out), np.nan)
            feeds = self.feeds[p]
            if not feeds:
                r = m.simulate(th_m, experiment)
                full[:] = r.outputs
                sub_err = list(r.errors)
            else:
                ok = [b for b in range(B) if errors[b] is None]
                sub_err = [None] * B
                if ok:
                    ov = {}
                    for col, (src, out) in feeds.items():
                        j = self.models[src].output_names.index(out)
                        ov[col] = results[src][ok, :, j]
                    r = self._run_fed(p, th_m[ok], experiment, ov)
                    full[ok] = r.outputs
                    for i, b in enumerate(ok):
                        sub_err[b] = r.errors[i]
            for b, e in enumerate(sub_err):
                if e is not None and errors[b] is None:
                    errors[b] = f"{p}: {e}"
            results[p] = full
        outputs = np.concatenate([results[p] for p in self.models], axis=2)
        for b, e in enumerate(errors):
            if e is not None:
                outputs[b] = np.nan
        return SimBatch(outputs, errors)

    @property
    def version(self) -> str:
        """The sub-models' versions (FitResults record what was fitted)."""
        return ";".join(f"{p}={getattr(m, 'version', '?')}" for p, m in self.models.items())

    def config(self) -> dict[str, Any]:
        """A configuration that rebuilds this co-simulation (where every sub-model has one)."""
        subs = {}
        for p, m in self.models.items():
            cfg = getattr(m, "config", None)
            if not callable(cfg):
                return {"type": "cosim", "name": self.name, "models": list(self.models)}
            subs[p] = cfg()
        conns = [
            {"from": f"{s[0]}.{s[1]}", "to": f"{t}.{i}"}
            for t, f in self.feeds.items()
            for i, s in f.items()
        ]
        return {"type": "cosim", "name": self.name, "models": subs, "connections": conns}

    def close(self) -> None:
        """Close every sub-model."""
        for m in self.models.values():
            m.close()

    def __enter__(self) -> CoSimModel:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        conns = [f"{s[0]}.{s[1]}->{t}.{i}" for t, f in self.feeds.items() for i, s in f.items()]
        return f"CoSimModel({self.name!r}, models={list(self.models)}, connections={conns})"

    @classmethod
    def from_config(cls, cfg: ExternalConfig) -> CoSimModel:
        """Build from a checked configuration (``type = "cosim"``).

        Each entry of ``models`` is an inline table or a model file; the
        evaluation options and time limit given for the co-simulation (or as
        overrides) apply to every sub-model.
        """
        # lazy: workers start without the configuration reader
        from thermogym.identification.external.config import read_config

        o = cfg.options
        overrides = dict(o.get("sub_overrides", {}))
        models: dict[str, Any] = {}
        try:
            for prefix, sub in o["models"].items():
                if isinstance(sub, str | os.PathLike):
                    sub_cfg = read_config(Path(sub), **overrides)
                else:
                    sub = {"name": prefix, **sub}
                    sub_cfg = read_config(sub, base_dir=cfg.base_dir, **overrides)
                    if sub_cfg.type == "cosim":
                        raise ConfigError(f"models.{prefix}: a co-simulation cannot nest another")
                    if sub_cfg.workdir is None and cfg.workdir is not None:
                        sub_cfg = _with_workdir(sub_cfg, cfg.workdir)
                models[prefix] = build_model(sub_cfg)
            conns = [(f"{a}.{x}", f"{b}.{y}") for (a, x), (b, y) in o.get("connections", [])]
            return cls(models, conns, name=cfg.name)
        except BaseException:
            for m in models.values():
                m.close()
            raise


def _with_workdir(cfg: ExternalConfig, workdir: Path) -> ExternalConfig:
    return dataclasses.replace(cfg, workdir=workdir)
