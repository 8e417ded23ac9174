"""What the catalogue sees: the fitted nominal model, the data, the residual's signatures.

:class:`Context` gathers the nominal model (its specification, parameters and
the parameters the nominal fit varied), the recordings (training first, then
held-out), the nominal simulation and what was located. :func:`signatures`
computes the residual patterns the effects of the vocabulary leave
(module docstring of :mod:`.effects`); they order the hypotheses and are
quoted as evidence, the fits decide.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.identification.diagnosis.experiments import half_time, step_responses
from thermogym.identification.diagnosis.hypothesis import NominalSpec
from thermogym.identification.residuals import cross_correlation
from thermogym.models.base import Model

__all__ = ["TEMPERATURE_UNITS", "Context", "signatures"]

TEMPERATURE_UNITS = ("°C", "K", "degC")


@dataclass
class Context:
    """The nominal model and the data, as the catalogue needs them.

    Attributes
    ----------
    model : Model
        The nominal model instance.
    spec : NominalSpec
        How to build it with candidates switched on.
    theta : ndarray, shape (P,)
        Nominal parameters (calibrated).
    free : tuple of str
        Parameters the nominal fit varied (refitted with each hypothesis).
    outputs : tuple of str
        Compared outputs.
    time, dt, u, y, sim : list
        Per recording (training first, then held-out): sample times, period,
        exogenous (T, n_u), measured (T, n_y) and nominal simulation (T, n_y).
    is_train : list of bool
    sigma, scale, share : dict
        Per output: white-noise level, spread, share of the nominal's error.
    regimes : list of dict
        Located regimes (:func:`~.locate.locate`).
    assumed_celsius : bool
        The outputs carry no unit; heat-transfer hypotheses take them as °C.
    """

    model: Model
    spec: NominalSpec
    theta: NDArray[np.float64]
    free: tuple[str, ...]
    outputs: tuple[str, ...]
    time: list[NDArray[np.float64]]
    dt: list[float]
    u: list[NDArray[np.float64]]
    y: list[NDArray[np.float64]]
    sim: list[NDArray[np.float64]]
    is_train: list[bool]
    sigma: dict[str, float]
    scale: dict[str, float]
    share: dict[str, float]
    regimes: list[dict[str, Any]] = field(default_factory=list)
    assumed_celsius: bool = False
    features: dict[str, Any] = field(default_factory=dict)
    _memo: dict[tuple[str, ...], Any] = field(default_factory=dict, repr=False)

    # ------------------------------------------------------------ signals
    @property
    def units(self) -> dict[str, str]:
        """Unit of every signal."""
        return {s.name: s.unit for s in self.model.signals}

    @property
    def exogenous(self) -> tuple[str, ...]:
        """Exogenous signal names (model order)."""
        return self.model.exogenous_names

    @property
    def inputs(self) -> tuple[str, ...]:
        """Manipulated inputs."""
        return tuple(s.name for s in self.model.inputs)

    @property
    def main_input(self) -> str:
        """The manipulated input with the largest effect, or the first exogenous signal."""
        return self.inputs[0] if self.inputs else self.exogenous[0]

    def is_temperature(self, name: str) -> bool:
        """Whether a signal is a temperature (by its unit, or by the °C assumption)."""
        unit = self.units.get(name, "1")
        if unit in TEMPERATURE_UNITS:
            return True
        return self.assumed_celsius and name in self.outputs

    @property
    def temperature_outputs(self) -> list[str]:
        """Compared outputs that are temperatures, most erring first."""
        out = [o for o in self.outputs if self.is_temperature(o)]
        return sorted(out, key=lambda o: -self.share.get(o, 0.0))

    @property
    def temperature_inputs(self) -> list[str]:
        """Exogenous temperatures (ambient, coolant), disturbances first."""
        dis = [s.name for s in self.model.disturbances if s.unit in TEMPERATURE_UNITS]
        ins = [s.name for s in self.model.inputs if s.unit in TEMPERATURE_UNITS]
        return dis + ins

    @property
    def ambient(self) -> str | None:
        """The surroundings' temperature (the ambient port of loop terms), if any.

        The first exogenous temperature that no input's conductance acts across
        (:meth:`sets_conductance`: a coolant inlet behind a valve is not the
        surroundings), else the first exogenous temperature.
        """
        t = self.temperature_inputs
        if not t:
            return None
        outs = self.temperature_outputs or list(self.outputs)
        if outs:
            across = {self.sets_conductance(i, outs[0]) for i in self.inputs}
            free = [x for x in t if x not in across]
            if free:
                return free[0]
        return t[0]

    def column(self, name: str, train_only: bool = False) -> list[NDArray[np.float64]]:
        """An exogenous signal per recording."""
        j = list(self.exogenous).index(name)
        return [
            u[:, j] for u, tr in zip(self.u, self.is_train, strict=True) if tr or not train_only
        ]

    def varies(self, name: str) -> bool:
        """Whether an exogenous signal changes in the training data."""
        v = np.concatenate(self.column(name, True))
        return bool(np.ptp(v[np.isfinite(v)]) > 0) if np.isfinite(v).any() else False

    def levels(self, name: str) -> NDArray[np.float64]:
        """Distinct non-zero values of an input in the training data."""
        v = np.concatenate(self.column(name, True))
        return np.unique(np.round(v[np.isfinite(v) & (v != 0)], 6))

    def u_ref(self, name: str) -> float:
        """Mean absolute non-zero value of an input in the training data (its scale)."""
        v = np.concatenate(self.column(name, True))
        nz = np.abs(v[np.isfinite(v) & (v != 0)])
        return float(np.mean(nz)) if nz.size else 1.0

    def reversals(self, name: str) -> int:
        """How often an input changes direction in the training data."""
        n = 0
        for v in self.column(name, True):
            d = np.diff(v)
            s = np.sign(d[d != 0])
            n += int(np.sum(s[1:] != s[:-1]))
        return n

    def output_range(self, name: str) -> tuple[float, float]:
        """Smallest and largest measured value of an output (all recordings)."""
        j = self.outputs.index(name)
        v = np.concatenate([y[:, j] for y in self.y])
        v = v[np.isfinite(v)]
        return (float(v.min()), float(v.max())) if v.size else (0.0, 1.0)

    @property
    def duration(self) -> float:
        """Shortest training recording [s]."""
        return float(
            min(t[-1] - t[0] for t, tr in zip(self.time, self.is_train, strict=True) if tr)
        )

    @property
    def span(self) -> float:
        """Longest recording [s] (the span of per-recording courses)."""
        return float(max(t[-1] - t[0] for t in self.time)) + max(self.dt)

    @property
    def dt_min(self) -> float:
        """Shortest sample period [s]."""
        return float(min(self.dt))

    @property
    def residual(self) -> list[NDArray[np.float64]]:
        """``y − ŷ`` per recording."""
        return [y - s for y, s in zip(self.y, self.sim, strict=True)]

    def value(self, name: str) -> float:
        """Nominal value of a parameter."""
        return float(self.theta[self.model.param_index(name)])

    def port_gain(self, port: str, output: str, u: NDArray[np.float64] | None = None) -> float:
        """Steady-state gain of the nominal model from an exogenous signal to an output.

        Measured on the first training recording: the mean output change over
        its second half when ``port`` is raised by a small step throughout
        (1 % of its span in that recording). ``u``, shape (T, n_u), replaces
        the recording's exogenous signals (the gain at another operating point).
        """
        i = self.is_train.index(True)
        j = list(self.exogenous).index(port)
        col = self.u[i][:, j]
        span = float(np.ptp(col)) or max(abs(float(np.mean(col))), 1.0)
        du = 0.01 * span
        base = self.u[i] if u is None else u
        uu = np.stack([base, base])
        uu[1, :, j] += du
        th = np.repeat(self.theta[None], 2, axis=0)
        try:
            x0 = self.model.initial_state(th, uu[:, 0])
            sim = self.model.simulate(uu, self.dt[i], th, x0, strict=False)
        except Exception:
            return math.nan
        k = self.model.output_names.index(output)
        half = base.shape[0] // 2
        d = sim.outputs[1, half:, k] - sim.outputs[0, half:, k]
        return float(np.mean(d) / du) if np.isfinite(d).all() else math.nan

    def _step_response(self, port: str) -> NDArray[np.float64] | None:
        """Change of every model output after a step of ``port``, shape (T', n_out).

        The step (1 % of the port's span) is applied a quarter into the first
        training recording; None when the model cannot be simulated so.
        """
        d: NDArray[np.float64] | None = self.memo(("step", port), lambda: self._step_of(port))
        return d

    def _step_of(self, port: str) -> NDArray[np.float64] | None:
        i = self.is_train.index(True)
        u = self.u[i]
        j = list(self.exogenous).index(port)
        span = float(np.ptp(u[:, j])) or max(abs(float(np.mean(u[:, j]))), 1.0)
        d = step_responses(self.model, self.theta, u, self.dt[i], [(j, 0.01 * span)])
        return d[0] if d is not None and np.isfinite(d).all() else None

    def response_time(self, port: str, output: str) -> float:
        """Seconds the nominal model's output takes to make half its response to a step of ``port``.

        Infinite when the output has not made half the change it shows over the
        first training recording's last sixth, or shows none
        (:meth:`_step_response`, :func:`.experiments.half_time`).
        """
        d = self._step_response(port)
        if d is None:
            return math.inf
        x = d[:, self.model.output_names.index(output)]
        return half_time(x, self.dt[self.is_train.index(True)])

    def locality(self, port: str, output: str) -> float:
        """How much more ``output`` than any other output a step of ``port`` moves at first.

        The ratio of the first clear changes (the first sample where some
        output has moved by a thousandth of its largest change): a heat flow
        entered at ``output``'s own node moves it before heat reaches the other
        nodes; one entered through the surroundings moves every zone at once.
        Infinite with one compared output; 0 when the output does not move.
        """
        others = [o for o in self.outputs if o != output]
        if not others:
            return math.inf
        d = self._step_response(port)
        if d is None:
            return 0.0
        cols = [self.model.output_names.index(o) for o in (output, *others)]
        a = np.abs(d[:, cols])
        peak = float(a.max())
        if peak == 0:
            return 0.0
        first = int(np.nonzero(a.max(axis=1) > 1e-3 * peak)[0][0])
        other = float(a[first, 1:].max())
        return float(a[first, 0] / other) if other > 0 else math.inf

    def memo(self, key: tuple[str, ...], make: Callable[[], Any]) -> Any:
        """``make()``, computed once per context for ``key`` (a proposer's reading of the model).

        Examples
        --------
        >>> from thermogym.identification.diagnosis.context import Context
        >>> calls = []
        >>> ctx = Context.__new__(Context)
        >>> ctx._memo = {}
        >>> [ctx.memo(("port", "T"), lambda: calls.append(1) or "T_a") for _ in range(2)]
        ['T_a', 'T_a']
        >>> len(calls)
        1
        """
        if key not in self._memo:
            self._memo[key] = make()
        return self._memo[key]

    def sets_conductance(self, name: str, output: str) -> str | None:
        """The temperature input across which ``name`` sets a conductance, if any.

        An input that sets a conductance (a coolant flow through a coil, a fan's
        speed) moves heat only across a temperature difference: in a plant held
        isothermal (every temperature input at one value, the other manipulated
        inputs at zero) it does nothing, whereas a power input (a heater, a
        lamp) still heats. So ``name`` sets a conductance when its gain there is
        below a tenth of its gain on the training data. Returns the far side of
        the conductance, else None: the temperature input that, raised by 5 K
        alone in the isothermal plant, makes the input pull the output up most
        (more conductance to a warmer side warms the output).
        """
        found: str | None = self.memo(
            ("sets", name, output), lambda: self._sets_conductance(name, output)
        )
        return found

    def _sets_conductance(self, name: str, output: str) -> str | None:
        temps = [t for t in self.temperature_inputs if t in self.exogenous]
        if name not in self.inputs or not temps:
            return None
        g0 = self.port_gain(name, output)
        if not math.isfinite(g0) or abs(g0) < 1e-12:
            return None
        i = self.is_train.index(True)
        k = self.outputs.index(output)
        level = float(np.nanmean(self.y[i][:, k]))
        iso = self.u[i].copy()
        for c, n in enumerate(self.exogenous):
            if n in temps:
                iso[:, c] = level
            elif n in self.inputs and n != name:
                iso[:, c] = 0.0
        g_iso = self.port_gain(name, output, iso)
        if not math.isfinite(g_iso) or abs(g_iso) > _CONDUCTANCE_REL * abs(g0):
            return None
        pull = []
        for t in temps:
            sh = iso.copy()
            sh[:, list(self.exogenous).index(t)] += _CONDUCTANCE_SHIFT_K
            g1 = self.port_gain(name, output, sh)
            pull.append(g1 if math.isfinite(g1) else -math.inf)
        best = int(np.argmax(pull))
        return temps[best] if pull[best] > 0 else None


#: Marks of an input that sets a conductance (:meth:`Context.sets_conductance`): its gain
#: in the isothermal plant below this share of its gain on the data, and the shift of a
#: temperature input that tells across which temperature it acts.
_CONDUCTANCE_REL = 0.1
_CONDUCTANCE_SHIFT_K = 5.0


# ------------------------------------------------------------------ signatures
def _r2(e: NDArray[np.float64], x: NDArray[np.float64]) -> tuple[float, float]:
    """R² and slope of ``e ≈ c·x`` (both centred)."""
    ok = np.isfinite(e) & np.isfinite(x)
    if ok.sum() < 5:
        return 0.0, 0.0
    ec = e[ok] - e[ok].mean()
    xc = x[ok] - x[ok].mean()
    sxx = float(xc @ xc)
    see = float(ec @ ec)
    if sxx <= 0 or see <= 0:
        return 0.0, 0.0
    c = float(xc @ ec) / sxx
    return max(0.0, min(1.0, c * c * sxx / see)), c


def _xcorr_peak(
    res: Sequence[NDArray[np.float64]], u: Sequence[NDArray[np.float64]], dt: float, max_lag: int
) -> tuple[float, float, float]:
    """Peak of the residual's cross-correlation with an input's changes: lag [s], height, width.

    A dead time makes the residual a shifted copy of the response's derivative,
    so the correlation with the input's changes peaks at a lag near the dead
    time and stays narrow; a lag smooths it (a wide peak near zero).
    """
    acc = np.zeros(2 * max_lag + 1)
    n = 0
    for e, x in zip(res, u, strict=True):
        if e.size <= 2 * max_lag + 2:
            continue
        du = np.diff(x, prepend=x[0])
        if not np.any(du):
            continue
        acc += cross_correlation(e, du, max_lag) * e.size
        n += e.size
    if n == 0:
        return 0.0, 0.0, 0.0
    r = np.abs(acc[max_lag:] / n)  # residual vs the input's past changes
    k = int(np.argmax(r))
    height = float(r[k])
    width = float(np.sum(r >= 0.5 * height)) if height > 0 else 0.0
    return k * dt, height, width * dt


def signatures(ctx: Context) -> dict[str, Any]:
    """Residual signature features of the nominal model.

    Returns
    -------
    dict
        Per output: ``offset`` (share of the mean square that is a constant,
        and its value), ``drift`` (R² of a time trend, slope per hour),
        ``lag`` (R² of ``e ≈ −τ dŷ/dt``, τ), η² of the located regimes
        (``band``, ``direction``, ``onoff``, ``level``, ``time``), the
        cross-correlation peak with each input's changes (``xcorr``); overall
        the residual spectrum's peak (``period``, ``period_peak``).
    """
    res = ctx.residual
    out: dict[str, Any] = {"outputs": {}}
    dt = ctx.dt_min
    max_lag = int(min(200, max(5, 0.1 * min(r.shape[0] for r in res))))
    for j, o in enumerate(ctx.outputs):
        e = np.concatenate([r[:, j] for r in res])
        ok = np.isfinite(e)
        ms = float(np.mean(e[ok] ** 2)) if ok.any() else 0.0
        mean = float(np.mean(e[ok])) if ok.any() else 0.0
        t_h = np.concatenate([(t - t[0]) / 3600.0 for t in ctx.time])
        drift_r2, slope = _r2(e, t_h)
        dy = np.concatenate(
            [
                np.gradient(s[:, j], d) if s.shape[0] > 1 else 0 * s[:, j]
                for s, d in zip(ctx.sim, ctx.dt, strict=True)
            ]
        )
        lag_r2, c = _r2(e, dy)
        feats: dict[str, Any] = {
            "offset": (mean * mean / ms if ms > 0 else 0.0),
            "offset_value": mean,
            "drift": drift_r2,
            "drift_per_h": slope,
            "lag": lag_r2 if c < 0 else 0.0,
            "lag_tau": -c if c < 0 else 0.0,
            "share": ctx.share.get(o, 0.0),
            "xcorr": {},
        }
        for name in ctx.exogenous:
            lag_s, h, w = _xcorr_peak([r[:, j] for r in res], ctx.column(name), dt, max_lag)
            feats["xcorr"][name] = {"peak_lag_s": lag_s, "height": h, "width_s": w}
        for reg in ctx.regimes:
            if reg["signal"] != o:
                continue
            key = {
                "temperature_band": "band",
                "opening_closing": "direction",
                "heating_cooling": "heating",
                "on_off": "onoff",
                "input_level": "level",
                "time_in_run": "time",
                "experiment": "recording",
            }.get(reg["kind"])
            if key:
                feats[key] = max(feats.get(key, 0.0), reg["eta2"])
        out["outputs"][o] = feats
    best_p, best_ratio = math.nan, 0.0
    for r, d in zip(res, ctx.dt, strict=True):
        n = r.shape[0]
        if n < 16:
            continue
        x = np.where(np.isfinite(r), r, 0.0)
        x = x - x.mean(axis=0)
        x = x * np.hanning(n)[:, None]
        P = (np.abs(np.fft.rfft(x, axis=0)) ** 2).sum(axis=1)
        f = np.fft.rfftfreq(n, d)
        sel = (f > 1.5 / (n * d)) & (f < 0.25 / d)
        if sel.sum() < 4:
            continue
        k = int(np.argmax(np.where(sel, P, 0.0)))
        ratio = float(P[k] / np.median(P[sel]))
        if ratio > best_ratio:
            best_ratio, best_p = ratio, float(1.0 / f[k])
    out["period"] = best_p
    out["period_peak"] = best_ratio
    return out
