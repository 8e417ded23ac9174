"""PID control and its tuning from identified models (SIMC, lambda / IMC).

Controller (:class:`PID`)
-------------------------
The discrete PID of Åström & Hägglund (*Advanced PID Control*, 2006,
section 3.7 and 13; Åström & Murray, *Feedback Systems*, section 11.5), with
sample time ``h``, set-point weight ``b`` and derivative on the measurement::

    P_k = K_p (b r_k − y_k)                                   proportional
    D_k = a_d D_{k−1} − b_d (y_k − y_{k−1})                   filtered derivative
          a_d = T_d / (T_d + N h),  b_d = K_p T_d N / (T_d + N h)   (backward difference)
    v_k = P_k + I_k + D_k + u_ff                              unsaturated output
    u_k = sat(v_k, u_min, u_max)                              output limits
    I_{k+1} = I_k + K_p h / T_i · e_k + h / T_t · (u_k − v_k) integral, back-calculation

with ``e = r − y``. Anti-windup by back-calculation (tracking time ``T_t``,
default ``√(T_i T_d)``, or ``T_i`` for a PI) or by conditional integration
(``"clamping"``: the integral stops while the output is saturated and the
error would drive it further). The derivative acts on the measurement, never
on the set-point, and the proportional part on ``b r``: a set-point step
moves the output by ``K_p b Δr`` only (``b = 0``: none); ``setpoint_rate``
ramps set-point changes. Gain changes (:meth:`PID.set_gains`) and the switch
from manual (``u0``) are bumpless: the integral absorbs the jump.

Tuning (:func:`simc`, :func:`lambda_tuning`)
--------------------------------------------
Both take a first-order-plus-dead-time model ``K e^{−θs}/(T s + 1)`` — an
identified FOPTD (:class:`~thermogym.models.linear.FOPTDModel` or its
FitResult) or any stable linear model reduced to one (:func:`foptd_of`; a
state-space model by the method of areas) — and return :class:`PIDGains`:

* SIMC (Skogestad, *J. Process Control* 13, 2003, eqs 16-17 for a
  first-order model): ``K_c = T / (K (τ_c + θ))``, ``T_i = min(T, 4 (τ_c + θ))``;
  default ``τ_c = θ`` ("tight control").
* lambda / IMC (Rivera, Morari & Skogestad, *Ind. Eng. Chem. Process Des.
  Dev.* 25, 1986, Table 1): PI ``K_c = T / (K (λ + θ))``, ``T_i = T``; PID
  (first-order Padé of the delay) ``K_c = (T + θ/2) / (K (λ + θ/2))``,
  ``T_i = T + θ/2``, ``T_d = T θ / (2T + θ)``; default ``λ = T``.

A PWM output stage and sampling add delay: pass ``extra_delay`` (about half
the PWM period plus half the sample time, Skogestad's "half rule").
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import finite, nonnegative, positive
from thermogym.controllers.base import Controller, EnvInfo, Loop, _num
from thermogym.errors import ConfigError, ParameterError
from thermogym.fitresult import FitResult, load_fit
from thermogym.models.base import Model
from thermogym.models.linear import FOPTDModel, StateSpaceModel

__all__ = [
    "FOPTD",
    "PID",
    "PIDGains",
    "foptd_of",
    "lambda_tuning",
    "simc",
]

ANTI_WINDUP = ("back-calculation", "clamping", "none")


# ------------------------------------------------------------------- models
@dataclass(frozen=True)
class FOPTD:
    """A first-order-plus-dead-time model ``K e^{−τ s}/(T s + 1)``.

    Attributes
    ----------
    K : float
        Gain [output unit per input unit].
    T : float
        Time constant [s].
    tau : float
        Dead time [s].
    input, output : str
        Signal names of the pair.
    source : str
        Where it comes from (``"FOPTDModel"``, ``"state space, method of areas"``).
    fingerprint : str or None
        Fingerprint of the FitResult it was read from.
    """

    K: float
    T: float
    tau: float
    input: str = "u"
    output: str = "y"
    source: str = "given"
    fingerprint: str | None = None

    def __post_init__(self) -> None:
        finite("FOPTD K", self.K, text=False)
        positive("FOPTD T", self.T, unit="s", text=False)
        nonnegative("FOPTD tau", self.tau, unit="s", text=False)
        if self.K == 0:
            raise ParameterError("FOPTD gain K is 0; the input does not act on the output")


def _pick(names: tuple[str, ...], want: str | None, what: str, model: str) -> int:
    if want is None:
        if len(names) != 1:
            raise ConfigError(f"{model} has {what}s {list(names)}; name the one to use ({what}=)")
        return 0
    if want not in names:
        raise ConfigError(f"{model} has no {what} {want!r}; its {what}s are {list(names)}")
    return names.index(want)


def _area_method(
    A: NDArray[np.float64], B: NDArray[np.float64], C: NDArray[np.float64], D: float, dt: float
) -> tuple[float, float, float]:
    # Method of areas (Åström & Hägglund 2006, section 2.7) on the unit-step response of a
    # discrete SISO system; written here because no library reduces a state space to an FOPTD.
    n = A.shape[0]
    x = np.zeros(n)
    ys = []
    eig = float(np.max(np.abs(np.linalg.eigvals(A)))) if n else 0.0
    if eig >= 1.0:
        raise ParameterError(
            f"the state-space model is not stable (largest |eigenvalue| {eig:.6f}); no FOPTD"
        )
    # simulate until the response settles (20 slowest time constants, capped)
    n_steps = int(min(200_000, max(200, 20.0 / max(1e-12, -math.log(max(eig, 1e-12))))))
    for _ in range(n_steps):
        ys.append(float(C @ x + D))
        x = A @ x + B
    y = np.asarray(ys)
    K = float(C @ np.linalg.solve(np.eye(n) - A, B) + D)
    if K == 0 or not math.isfinite(K):
        raise ParameterError(f"the pair has steady-state gain {K!r}; no FOPTD")
    # y[k] is the response at t = k·dt to a step applied at t = 0 (ZOH)
    # trapezoidal rule on the samples (the response settled: the tail is negligible)
    A0 = float((np.sum(K - y) - 0.5 * (K - y[0]) - 0.5 * (K - y[-1])) * dt)  # ∫(K − y) = K(T + τ)
    Tar = A0 / K
    if Tar <= 0:
        raise ParameterError("the step response overshoots its final value too much for an FOPTD")
    # ∫_0^Tar y dt = K T / e: trapezoids up to the last sample before Tar, then the fraction
    kf = min(Tar / dt, len(y) - 1.0)
    k = math.floor(kf)
    A1 = float((np.sum(y[: k + 1]) - 0.5 * (y[0] + y[k])) * dt)
    if k + 1 < len(y):
        frac = kf - k
        y_end = y[k] + frac * (y[k + 1] - y[k])
        A1 += 0.5 * (y[k] + y_end) * frac * dt
    T = math.e * A1 / K
    T = min(max(T, 1e-9 * Tar), Tar)
    return float(K), float(T), float(max(Tar - T, 0.0))


def foptd_of(
    source: Any,
    *,
    input: str | None = None,
    output: str | None = None,
    theta: Any = None,
) -> FOPTD:
    """The FOPTD of one input-output pair of an identified linear model.

    Parameters
    ----------
    source : FOPTD, FOPTDModel, StateSpaceModel, FitResult, path or dict
        An FOPTD model (its pair is read directly) or a state-space model
        (reduced by the method of areas on its step response), or the
        FitResult of either.
    input, output : str, optional
        The pair (needed when the model has several).
    theta : parameter set, optional
        Parameters of a model object (default: its nominal ones).

    Returns
    -------
    FOPTD

    Examples
    --------
    >>> from thermogym.models.linear import FOPTDModel, StateSpaceModel
    >>> foptd_of(FOPTDModel(["P"], ["T"], K=2.0, T=600.0, tau=60.0))
    FOPTD(K=2.0, T=600.0, tau=60.0, input='P', output='T', source='FOPTDModel', fingerprint=None)
    >>> ss = StateSpaceModel.from_continuous([[-1 / 600]], [[2.0 / 600]], [[1.0]], dt=1.0)
    >>> f = foptd_of(ss)
    >>> round(f.K, 6), abs(f.T - 600.0) < 2.0, f.tau < 1.0
    (2.0, True, True)
    """
    if isinstance(source, FOPTD):
        return source
    fp = None
    if isinstance(source, FitResult | str | os.PathLike | Mapping):
        fit = load_fit(source)
        fp = fit.fingerprint()
        model: Model = fit.build_model()
        theta = fit.theta(model)
    elif isinstance(source, Model):
        model = source
    else:
        raise ConfigError(
            f"cannot read an FOPTD from {type(source).__name__}; give an FOPTD, an FOPTDModel, "
            "a StateSpaceModel or their FitResult"
        )
    outs = tuple(model.output_names)
    exo = tuple(model.exogenous_names)
    if isinstance(model, FOPTDModel):
        j = _pick(outs, output, "output", "the FOPTD model")
        i = _pick(exo, input, "input", "the FOPTD model")
        K, T, tau = (float(v[0, j, i]) for v in model.pair_parameters(theta))
        return FOPTD(K, T, tau, exo[i], outs[j], "FOPTDModel", fp)
    if isinstance(model, StateSpaceModel):
        j = _pick(outs, output, "output", "the state-space model")
        i = _pick(exo, input, "input", "the state-space model")
        m = model.matrices(theta)
        if model.dt is None:
            raise ConfigError(
                "the state-space model has no sample period (dt=None); the method of areas "
                "needs one: build or fit the model with its period"
            )
        K, T, tau = _area_method(m.A[0], m.B[0][:, i], m.C[0][j], float(m.D[0][j, i]), model.dt)
        return FOPTD(K, T, tau, exo[i], outs[j], "state space, method of areas", fp)
    raise ConfigError(
        f"model {model.name!r} is not linear; tuning rules need an FOPTD or a state-space model "
        "(identify one from recordings: thermogym identify foptd / n4sid)"
    )


# ------------------------------------------------------------------- gains
@dataclass(frozen=True)
class PIDGains:
    """Gains of a PID in the ideal (ISA) form ``K_p (e + 1/T_i ∫e + T_d de/dt)``.

    Attributes
    ----------
    kp : float
        Proportional gain [command per unit of the measurement].
    ti : float
        Integral time [s] (``inf``: no integral action).
    td : float
        Derivative time [s].
    method : str
        How they were found.
    model : dict
        The FOPTD they were tuned on (``K``, ``T``, ``tau``, ``input_scale``,
        ``extra_delay``, ``fingerprint``).
    """

    kp: float
    ti: float
    td: float = 0.0
    method: str = "given"
    model: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form."""
        d = asdict(self)
        if math.isinf(self.ti):
            d["ti"] = None
        return d


def _model_for_tuning(
    model: Any, input_scale: float, extra_delay: float, input: str | None, output: str | None
) -> tuple[FOPTD, float, float, float]:
    f = foptd_of(model, input=input, output=output)
    s = _num("tuning", "input_scale", input_scale)
    if s == 0:
        raise ConfigError("tuning: input_scale is 0; expected model-input units per unit command")
    extra = _num("tuning", "extra_delay", extra_delay, lo=0.0)
    return f, f.K * s, f.T, f.tau + extra


def _meta(f: FOPTD, input_scale: float, extra: float, **kw: Any) -> dict[str, Any]:
    return {
        "K": f.K,
        "T": f.T,
        "tau": f.tau,
        "input": f.input,
        "output": f.output,
        "input_scale": input_scale,
        "extra_delay": extra,
        "source": f.source,
        "fingerprint": f.fingerprint,
        **kw,
    }


def simc(
    model: Any,
    *,
    tau_c: float | None = None,
    input_scale: float = 1.0,
    extra_delay: float = 0.0,
    input: str | None = None,
    output: str | None = None,
) -> PIDGains:
    """SIMC PI tuning (Skogestad 2003) from an FOPTD or a linear model.

    Parameters
    ----------
    model : FOPTD, FOPTDModel, StateSpaceModel or FitResult
        Identified model (see :func:`foptd_of`).
    tau_c : float, optional
        Desired closed-loop time constant [s]; default ``θ`` (tight
        control). Needed when the model has no delay.
    input_scale : float
        Model-input units per unit of the controller command (e.g. 100 when
        the model's input is in % and the command in [0, 1]).
    extra_delay : float
        Delay added to the model's [s] (PWM period / 2 + sample time / 2).
    input, output : str, optional
        The pair of a multi-signal model.

    Returns
    -------
    PIDGains

    Examples
    --------
    >>> g = simc(FOPTD(K=2.0, T=600.0, tau=60.0))
    >>> round(g.kp, 4), g.ti, g.td        # K_c = 600 / (2 · 120), T_i = min(600, 480)
    (2.5, 480.0, 0.0)
    """
    f, K, T, theta = _model_for_tuning(model, input_scale, extra_delay, input, output)
    if tau_c is None:
        if theta <= 0:
            raise ConfigError(
                "simc: the model has no delay; give tau_c (the closed-loop time constant, s)"
            )
        tau_c = theta
    tc = _num("simc", "tau_c", tau_c, lo=0.0)
    if tc + theta <= 0:
        raise ConfigError("simc: tau_c + delay is 0; expected a positive closed-loop time")
    kp = T / (K * (tc + theta))  # (16) of Skogestad 2003, first-order model
    ti = min(T, 4.0 * (tc + theta))  # (17)
    return PIDGains(kp, ti, 0.0, "SIMC", _meta(f, input_scale, extra_delay, tau_c=tc))


def lambda_tuning(
    model: Any,
    *,
    lam: float | None = None,
    derivative: bool = False,
    input_scale: float = 1.0,
    extra_delay: float = 0.0,
    input: str | None = None,
    output: str | None = None,
) -> PIDGains:
    """Lambda (IMC) tuning of a PI or PID from an FOPTD or a linear model.

    Parameters
    ----------
    model : FOPTD, FOPTDModel, StateSpaceModel or FitResult
    lam : float, optional
        Closed-loop time constant λ [s]; default the model's ``T``.
    derivative : bool
        PID (first-order Padé of the delay) instead of PI.
    input_scale, extra_delay, input, output
        As :func:`simc`.

    Returns
    -------
    PIDGains

    Examples
    --------
    >>> g = lambda_tuning(FOPTD(K=2.0, T=600.0, tau=60.0), lam=300.0)
    >>> round(g.kp, 4), g.ti                  # K_c = 600 / (2 · 360)
    (0.8333, 600.0)
    """
    f, K, T, theta = _model_for_tuning(model, input_scale, extra_delay, input, output)
    lam_v = T
    if lam is not None:
        lam_v = positive("lambda_tuning: lam", lam, unit="s", error=ConfigError, text=False)
    if derivative:
        kp = (T + theta / 2.0) / (K * (lam_v + theta / 2.0))
        ti = T + theta / 2.0
        td = T * theta / (2.0 * T + theta)
        return PIDGains(kp, ti, td, "lambda PID", _meta(f, input_scale, extra_delay, lam=lam_v))
    kp = T / (K * (lam_v + theta))
    return PIDGains(kp, T, 0.0, "lambda PI", _meta(f, input_scale, extra_delay, lam=lam_v))


# --------------------------------------------------------------- controller
class PID(Controller):
    """Discrete PID with anti-windup, derivative filter, limits and bumpless changes.

    Parameters
    ----------
    kp : float
        Proportional gain [command per unit of the measurement].
    ti : float
        Integral time [s]; ``inf`` for no integral action.
    td : float
        Derivative time [s].
    gains : PIDGains, optional
        Gains from a tuning rule (replace ``kp``, ``ti``, ``td``).
    n : float
        Derivative filter: the derivative is low-passed with time constant
        ``T_d / N`` (typically 5-20).
    b : float
        Set-point weight of the proportional part (0-1).
    anti_windup : {"back-calculation", "clamping", "none"}
    tt : float, optional
        Tracking time of back-calculation [s] (default ``√(T_i T_d)``, ``T_i``
        for a PI).
    u_min, u_max : float
        Output limits (command units, within [0, 1]).
    bias : float
        Constant added to the output (the command at zero error, for a P or
        PD controller).
    u0 : float, optional
        Output of the first sample (bumpless start from a manual value): the
        integral is initialised to match it.
    setpoint_rate : float, optional
        Largest set-point change per second (unit of the measurement / s).
    feedforward : Controller, optional
        A controller whose command is added to the PID output (e.g. a
        static inverse of the plant); it runs at the PID's sample time.
    loop, sample_time
        See :class:`~thermogym.controllers.base.Controller`.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import thermogym.envs
    >>> env = gym.make("thermogym/AXT211Valve-v0", setpoint=2.0, sensor_noise=False)
    >>> pid = PID(kp=0.05, ti=240.0).bind(env)
    >>> obs, _ = env.reset(seed=0)
    >>> for _ in range(360):  # one hour
    ...     obs, *_ = env.step(pid.act(obs))
    >>> abs(env.unwrapped.true_outputs()["x_V"] - 2.0) < 0.05
    True
    """

    label = "pid"

    def __init__(
        self,
        kp: float | None = None,
        ti: float | None = math.inf,
        td: float = 0.0,
        *,
        gains: PIDGains | None = None,
        n: float = 10.0,
        b: float = 1.0,
        anti_windup: str = "back-calculation",
        tt: float | None = None,
        u_min: float = 0.0,
        u_max: float = 1.0,
        bias: float = 0.0,
        u0: float | None = None,
        setpoint_rate: float | None = None,
        feedforward: Controller | None = None,
        loop: Loop | None = None,
        sample_time: float | None = None,
    ) -> None:
        super().__init__(loop=loop, sample_time=sample_time)
        who = "PID"
        if gains is not None:
            if not isinstance(gains, PIDGains):
                raise ConfigError(f"{who}: gains is {gains!r:.60}; expected PIDGains")
            kp, ti, td = gains.kp, gains.ti, gains.td
        if kp is None:
            raise ConfigError(f"{who}: give kp (and ti, td) or gains=PIDGains(...)")
        self.gains = gains
        self.kp = _num(who, "kp", kp)
        if ti is None or (isinstance(ti, float | int) and math.isinf(ti)):
            self.ti = math.inf
        else:
            self.ti = _num(who, "ti", ti, lo=0.0)
        if self.ti <= 0:
            raise ConfigError(f"{who}: ti is {ti!r}; expected > 0 s (inf: no integral action)")
        self.td = _num(who, "td", td, lo=0.0)
        self.n = _num(who, "n", n, lo=1e-6)
        self.b = _num(who, "b", b, lo=0.0, hi=1.0)
        if anti_windup not in ANTI_WINDUP:
            raise ConfigError(
                f"{who}: anti_windup is {anti_windup!r}; expected one of {ANTI_WINDUP}"
            )
        self.anti_windup = anti_windup
        self.tt = None if tt is None else _num(who, "tt", tt, lo=1e-12)
        self.u_min = _num(who, "u_min", u_min, lo=0.0, hi=1.0)
        self.u_max = _num(who, "u_max", u_max, lo=0.0, hi=1.0)
        if self.u_min >= self.u_max:
            raise ConfigError(f"{who}: u_min {u_min!r} >= u_max {u_max!r}")
        self.bias = _num(who, "bias", bias)
        self.u0 = None if u0 is None else _num(who, "u0", u0, lo=0.0, hi=1.0)
        self.setpoint_rate = (
            None if setpoint_rate is None else _num(who, "setpoint_rate", setpoint_rate, lo=0.0)
        )
        if feedforward is not None and not isinstance(feedforward, Controller):
            raise ConfigError(f"{who}: feedforward is {feedforward!r:.60}; expected a Controller")
        self.feedforward = feedforward
        self._I = 0.0
        self._D = 0.0
        self._y_old = math.nan
        self._r = math.nan
        self._first = True
        self._n_sat = 0
        self._n = 0

    # ------------------------------------------------------------------ set-up
    def _bind(self, info: EnvInfo) -> None:
        if self.feedforward is not None:
            if self.feedforward.loop is None:
                self.feedforward.loop = self.bound_loop
            self.feedforward.bind(info, sample_time=self.h, inner=True)

    def _reset(self, seed: int | None) -> None:
        self._I = 0.0
        self._D = 0.0
        self._y_old = math.nan
        self._r = math.nan
        self._first = True
        self._n_sat = 0
        self._n = 0
        if self.feedforward is not None and self.feedforward._info is not None:
            self.feedforward.reset(seed=seed)

    @property
    def tracking_time(self) -> float:
        """Tracking time of back-calculation [s]."""
        if self.tt is not None:
            return self.tt
        if math.isinf(self.ti):
            return math.inf
        return math.sqrt(self.ti * self.td) if self.td > 0 else self.ti

    def set_gains(
        self, kp: float | None = None, ti: float | None = None, td: float | None = None
    ) -> None:
        """Change gains between samples without a jump of the output (bumpless)."""
        if self._first:
            self.kp = self.kp if kp is None else _num("PID", "kp", kp)
            self.ti = self.ti if ti is None else float(ti)
            self.td = self.td if td is None else _num("PID", "td", td, lo=0.0)
            return
        s = 1.0 if self.bound_loop.direct else -1.0
        p_old = self.kp * (self.b * s * self._r - s * self._y_old)
        if kp is not None:
            self.kp = _num("PID", "kp", kp)
        if ti is not None:
            if not (math.isinf(ti) or ti > 0):
                raise ConfigError(f"PID: ti is {ti!r}; expected > 0 s")
            self.ti = float(ti)
        if td is not None:
            self.td = _num("PID", "td", td, lo=0.0)
        p_new = self.kp * (self.b * s * self._r - s * self._y_old)
        self._I += p_old - p_new  # the integral takes the jump of the proportional part

    # ---------------------------------------------------------------- samples
    def update(self, obs: NDArray[np.float64]) -> float:
        """One PID sample (see the module docstring for the equations)."""
        h = self.h
        s = 1.0 if self.bound_loop.direct else -1.0  # reverse acting: work on −y, −r
        y = s * self.measurement(obs)
        r_target = s * self.setpoint(obs)
        if self._first or self.setpoint_rate is None:
            r = r_target
        else:  # ramp set-point changes
            step = self.setpoint_rate * h
            r = self._r + min(max(r_target - self._r, -step), step)
        if self._first:
            self._y_old = y
        e = r - y
        P = self.kp * (self.b * r - y)
        if self.td > 0:
            ad = self.td / (self.td + self.n * h)
            bd = self.kp * self.td * self.n / (self.td + self.n * h)
            self._D = ad * self._D - bd * (y - self._y_old)
        ff = 0.0 if self.feedforward is None else float(self.feedforward.update(obs))
        if self._first and self.u0 is not None:
            self._I = self.u0 - P - self._D - ff - self.bias  # bumpless start from manual
        self._first = False
        v = P + self._I + self._D + ff + self.bias
        u = min(max(v, self.u_min), self.u_max)
        if u != v:
            self._n_sat += 1
        self._n += 1
        if not math.isinf(self.ti):
            di = self.kp * h / self.ti * e
            if self.anti_windup == "back-calculation":
                self._I += di + h / self.tracking_time * (u - v)
            elif self.anti_windup == "clamping":
                pushing = (v > self.u_max and e > 0) or (v < self.u_min and e < 0)
                if not pushing:
                    self._I += di
            else:
                self._I += di
        self._y_old = y
        self._r = r
        return u

    @property
    def integral(self) -> float:
        """The integral part of the output now."""
        return self._I

    def _settings(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "kp": self.kp,
            "ti": None if math.isinf(self.ti) else self.ti,
            "td": self.td,
            "n": self.n,
            "b": self.b,
            "anti_windup": self.anti_windup,
            "u_limits": [self.u_min, self.u_max],
        }
        if self.tt is not None:
            out["tt"] = self.tt
        if self.bias:
            out["bias"] = self.bias
        if self.u0 is not None:
            out["u0"] = self.u0
        if self.setpoint_rate is not None:
            out["setpoint_rate"] = self.setpoint_rate
        if self.gains is not None:
            out["tuning"] = {"method": self.gains.method, "model": self.gains.model}
        if self.feedforward is not None:
            out["feedforward"] = self.feedforward.settings()
        return out

    def stats(self) -> dict[str, float]:
        """``saturated_fraction``: share of samples with the output at a limit."""
        return {"saturated_fraction": self._n_sat / self._n if self._n else 0.0}
