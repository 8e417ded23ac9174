"""Grey-box identification of the AXT211 actuator: paper 002, sections VI-VII, on rig data.

``002_dae2310635fe074e.txt`` identifies the AXT211 model submodel by submodel
and validates each on other test cases with the accuracy ξ (22):

1. **PTC** (14): a 5th-order polynomial R_PTC(T_P), fitted by *linear* least
   squares to the resistance measured from voltage and current against the
   wax temperature, in the validated range 30-101 °C
   (:func:`fit_ptc_polynomial`); ξ on the power P_PTC (15).
2. **Thermodynamic** (17)-(18): C_P, λ_PG, C_G, λ_GU by grey-box fitting
   (bounded Gauss-Newton, exact forward sensitivities of the model's fixed-step
   RK4) of T_P and T_G, the PTC polynomial of step 1 fixed; ξ on T_P.
3. **Mechanical** (19)-(21): T_P0 and k_P(x_P) = a x_P² + b x_P + c and τ_P,
   fitted on the valve stroke x_V with the measured wax temperature as input
   (:class:`AXT211Mechanics`), **backlash (20) disabled** as the paper notes
   ("this function is not differentiable"); the backlash half-width is then
   found by a derivative-free search (all candidates simulated as one batch)
   and the mechanics refitted with it; ξ on x_V.

Training uses the rig's step tests at three corners of the supply/ambient range
plus the closed-loop temperature staircase (the paper's gain/backlash
experiment, Fig. 3); validation uses the other step tests and the PWM test. The
paper reports ξ = 0.93 / 0.95 / 0.84 (mean) and Table II above 0.90.

:func:`thermogym.studies.axt211.reproduce_paper002` generates the rig data and
runs everything from perturbed start values; :attr:`GreyboxResult.recovered`
compares the fitted parameters with the rig's true ones and their confidence
intervals.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numba as nb
import numpy as np
from numpy.typing import NDArray
from scipy import stats
from scipy.ndimage import uniform_filter1d

from thermogym._jitcache import module_kernels_depend_on
from thermogym.errors import ConfigError, RecordingError, ShapeError
from thermogym.fitresult import FitResult, data_entry
from thermogym.identification.coordinator import IdentificationResult, run_identification
from thermogym.identification.metrics import accuracy_xi
from thermogym.identification.problem import FreeParameter, Problem
from thermogym.identification.simmodel import SimBatch
from thermogym.identification.uncertainty import covariance_from_jacobian, estimate_input_noise
from thermogym.models import axt211_dynamics as ax
from thermogym.models.axt211 import AXT211, AXT211_PARAMETERS, ptc_resistance
from thermogym.models.integrators import rk4_accumulate, rk4_finish, rk4_stage_input
from thermogym.recording import Recording

__all__ = [
    "MECHANICAL",
    "PTC",
    "THERMAL",
    "AXT211Mechanics",
    "GreyboxResult",
    "PTCFit",
    "fit_ptc_polynomial",
    "identify_axt211",
    "smooth_disturbances",
]

#: Parameters of each submodel.
PTC: tuple[str, ...] = tuple(f"R_{i}" for i in range(6))
THERMAL: tuple[str, ...] = ("C_P", "lambda_PG", "C_G", "lambda_GU")
MECHANICAL: tuple[str, ...] = ("T_P0", "kP_a", "kP_b", "kP_c", "tau_P")
_T_LO, _T_HI = 30.0, 101.0
_SPEC = {p.name: p for p in AXT211_PARAMETERS}
_NOMINAL_FULL = np.array([p.nominal for p in ax.FULL_PARAMETERS])


# ------------------------------------------------------------------ PTC model
@dataclass
class PTCFit:
    """Least-squares fit of the PTC polynomial (14).

    Attributes
    ----------
    coeffs : ndarray, shape (6,)
        ``R_0 … R_5`` [Ω] of ``R = Σ R_i τ^i``, τ = (T_P − 65 °C)/35 K.
    stderr : ndarray, shape (6,)
    covariance : ndarray, shape (6, 6)
    rmse : float
        Residual RMSE [Ω].
    n_points : int
        Samples used (T_P within the validated range).
    """

    coeffs: NDArray[np.float64]
    stderr: NDArray[np.float64]
    covariance: NDArray[np.float64]
    rmse: float
    n_points: int

    def parameters(self) -> dict[str, float]:
        """``{"R_0": …, …}``."""
        return dict(zip(PTC, self.coeffs.tolist(), strict=True))


def fit_ptc_polynomial(
    recordings: Sequence[Recording], *, t_range: tuple[float, float] = (_T_LO, _T_HI)
) -> PTCFit:
    """Fit the PTC polynomial (14) by linear least squares (paper 002, section VI-A).

    The measured resistance ``R_PTC`` [Ω] is regressed on the powers
    ``τ^0 … τ^5`` of the normalised measured wax temperature (the model's
    parametrisation of the same 5th-order polynomial) over the samples with
    ``T_P`` in ``t_range`` (the validated range of the paper).

    Parameters
    ----------
    recordings : sequence of Recording
        With columns ``T_P`` [°C] and ``R_PTC`` [Ω].
    t_range : (float, float)
        Temperature range used [°C].

    Returns
    -------
    PTCFit

    Raises
    ------
    RecordingError
        Columns missing or fewer than 12 usable samples.

    Examples
    --------
    >>> from thermogym.rigs import run_experiment
    >>> recs = run_experiment("axt211", "steps", voltages=[24.0], ambients=[25.0], seed=0)
    >>> fit = fit_ptc_polynomial(recs)
    >>> fit.n_points > 500, bool(fit.rmse < 10.0)  # the rig's PTC is no polynomial: Ω off
    (True, True)
    """
    T, R = [], []
    for rec in recordings:
        for col in ("T_P", "R_PTC"):
            if col not in rec:
                raise RecordingError(
                    f"recording {rec.experiment_id!r} lacks column {col!r} for the PTC fit; "
                    f"it has {list(rec.columns)}"
                )
        t, r = np.asarray(rec["T_P"]), np.asarray(rec["R_PTC"])
        ok = np.isfinite(t) & np.isfinite(r) & (t >= t_range[0]) & (t <= t_range[1])
        T.append(t[ok])
        R.append(r[ok])
    Ta, Ra = np.concatenate(T), np.concatenate(R)
    if Ta.size < 12:
        raise RecordingError(
            f"only {Ta.size} samples with T_P in {list(t_range)} °C; the PTC fit needs at least 12"
        )
    tau = (Ta - 65.0) / 35.0
    X = np.vander(tau, 6, increasing=True)  # columns τ^0 … τ^5, (14)
    # float64 in and out (numpy's stubs say floating[Any])
    coeffs = cast(NDArray[np.float64], np.linalg.lstsq(X, Ra, rcond=None)[0])
    e = X @ coeffs - Ra
    cov, se, _, _, _ = covariance_from_jacobian(X, e)
    if cov is None:
        raise RecordingError(
            "the wax temperatures do not span the PTC range enough to fit a 5th-order polynomial"
        )
    return PTCFit(coeffs, se, cov, float(np.sqrt(np.mean(e**2))), int(Ta.size))


# -------------------------------------------------------- mechanical submodel
@nb.njit(cache=True)
def _mech_kernel(full, TP, h, nsub, y):  # pragma: no cover - numba
    # (19)-(21) of the model (axt211_dynamics.stroke_rate, constrain) by its RK4 stages,
    # with the wax temperature linear between the samples
    B, T = full.shape[0], TP.shape[0]
    for b in range(B):
        q = ax.coefficients(full[b])
        xP, xV = q[ax.Q_LO], 0.0  # rest: cartridge retracted, valve shut
        for k in range(T):
            y[b, k, 0] = xP
            y[b, k, 1] = xV
            if k + 1 == T:
                break
            Ta, Tb = TP[k], TP[k + 1]
            for s in range(nsub):
                x = (xP,)
                f = x
                acc = x
                for st in range(1, 5):
                    frac = (s + (0.0, 0.5, 0.5, 1.0)[st - 1]) / nsub
                    xs = rk4_stage_input(x, f, h, st)
                    f = (ax.stroke_rate(Ta + frac * (Tb - Ta), xs[0], q),)
                    acc = rk4_accumulate(acc, f, st)
                xP, xV = ax.constrain(rk4_finish(x, h, acc)[0], xV, q)


class AXT211Mechanics:
    """Mechanical submodel (19)-(21) of the AXT211 driven by the measured wax temperature.

    A :class:`~thermogym.identification.simmodel.SimModel`: the input is the
    recording's ``T_P`` column (linear between samples), the outputs are the
    cartridge stroke ``x_P`` and the valve stroke ``x_V`` [mm], integrated by
    the same fixed-step RK4 (step ≤ 1 s) as the full model, from rest. With
    ``c_backlash = 0`` the backlash (20) is disabled.

    Parameters
    ----------
    free : sequence of str, optional
        Parameters exposed to the optimiser (default all seven).
    fixed : mapping, optional
        Values of the others (default: the AXT211 nominal values).

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.recording import Recording
    >>> rec = Recording(np.arange(600.0), {"T_P": np.full(600, 80.0)})
    >>> m = AXT211Mechanics()
    >>> float(m.simulate(m.nominal[None], rec).outputs[0, -1, 1])
    4.5
    """

    name = "axt211-mechanics"
    version = "1"
    batched = True
    input_names: tuple[str, ...] = ("T_P",)
    output_names: tuple[str, ...] = ("x_P", "x_V")
    all_names = ("T_P0", "kP_a", "kP_b", "kP_c", "tau_P", "x_max", "c_backlash")
    max_step = 1.0

    def __init__(
        self, free: Sequence[str] | None = None, fixed: dict[str, float] | None = None
    ) -> None:
        self.param_names = tuple(free) if free is not None else self.all_names
        unknown = [n for n in self.param_names if n not in self.all_names]
        if unknown:
            raise ConfigError(f"{unknown} are not parameters of {self.name}: {self.all_names}")
        base = {n: _SPEC[n].nominal for n in self.all_names}
        for k, v in (fixed or {}).items():
            if k not in base:
                raise ConfigError(f"{k!r} is not a parameter of {self.name}: {self.all_names}")
            base[k] = float(v)
        self._base = np.array([base[n] for n in self.all_names])
        self._cols = np.array([self.all_names.index(n) for n in self.param_names])
        self.nominal = self._base[self._cols].copy()
        self.lower = np.array([_SPEC[n].lower for n in self.param_names])
        self.upper = np.array([_SPEC[n].upper for n in self.param_names])

    def full(self, theta: NDArray[np.float64]) -> NDArray[np.float64]:
        """All seven parameters (B, 7) with the free columns from ``theta``."""
        th = np.atleast_2d(np.asarray(theta, dtype=float))
        if th.shape[1] != self._cols.size:
            raise ShapeError(f"theta has {th.shape[1]} columns, expected {self._cols.size}")
        out = np.repeat(self._base[None], th.shape[0], axis=0)
        out[:, self._cols] = th
        return out

    def simulate(self, theta: NDArray[np.float64], experiment: Recording) -> SimBatch:
        """Simulate the batch on the experiment's measured ``T_P``."""
        full = self.full(theta)
        B = full.shape[0]
        if "T_P" not in experiment:
            raise RecordingError(
                f"experiment {experiment.experiment_id!r} has no column 'T_P' to drive the "
                "mechanical submodel"
            )
        TP = np.asarray(experiment["T_P"], dtype=float)
        if not np.isfinite(TP).all():
            raise RecordingError(
                f"experiment {experiment.experiment_id!r}: 'T_P' has missing samples; prepare it"
            )
        dt = experiment.dt
        n = max(1, int(np.ceil(dt / self.max_step - 1e-9)))
        y = np.empty((B, TP.size, 2))
        errors: list[str | None] = [None] * B
        bad = (full[:, 4] <= 0) | (full[:, 5] <= 0) | (full[:, 6] < 0)
        if bad.any():
            for i in np.flatnonzero(bad):
                errors[i] = "tau_P and x_max must be positive and c_backlash >= 0"
            full = np.where(bad[:, None], self._base[None], full)
        kern = np.repeat(_NOMINAL_FULL[None], B, axis=0)  # the model's full parameter vector
        kern[:, [ax.FULL_INDEX[k] for k in self.all_names]] = full
        _mech_kernel(kern, TP, dt / n, n, y)
        y[bad] = np.nan
        return SimBatch(y, errors)

    def close(self) -> None:
        """Nothing to release."""


# -------------------------------------------------------------- preparation
def smooth_disturbances(
    rec: Recording, window_s: float, columns: Sequence[str] = ("k_U", "T_U")
) -> Recording:
    """Moving-average the measured disturbances before they drive a simulation.

    The supply voltage and the ambient temperature change slowly, but their
    sensors add white noise (rig: 20 mV, 0.1 K). Fed into a simulation that
    noise becomes a slowly wandering error of the simulated temperatures — an
    errors-in-variables effect that biases the fit and makes the residuals
    correlated. A centred moving average over ``window_s`` reduces it by
    ``√(window / dt)``. The step is recorded in ``meta["preparation"]``.

    Parameters
    ----------
    rec : Recording
    window_s : float
        Averaging window [s]; 0 returns ``rec`` unchanged.
    columns : sequence of str
        Columns to smooth (those present).

    Returns
    -------
    Recording
    """
    if window_s <= 0:
        return rec
    n = max(1, round(window_s / rec.dt))
    if n % 2 == 0:
        n += 1
    new = {}
    for c in columns:
        if c in rec:
            x = np.asarray(rec[c], dtype=float)
            if not np.isfinite(x).all():
                raise RecordingError(
                    f"column {c!r} of {rec.experiment_id!r} has missing samples; prepare it first"
                )
            new[c] = uniform_filter1d(x, n, mode="nearest")
    out = rec.with_columns(new)
    out = out.replace(
        meta={
            **rec.meta,
            "preparation": [
                *rec.meta.get("preparation", []),
                {"step": "moving_average", "columns": sorted(new), "window_samples": n},
            ],
        }
    )
    return out


# ---------------------------------------------------------------- the result
@dataclass
class GreyboxResult:
    """Outcome of the AXT211 grey-box identification.

    Attributes
    ----------
    ptc : PTCFit
        Stage 1: PTC polynomial (14) by linear least squares.
    thermal : IdentificationResult
        Stage 2: thermodynamic submodel (17)-(18), PTC fixed.
    mechanical_no_backlash : IdentificationResult
        Stage 3a: mechanics (19)-(21) with the backlash disabled (global
        Monte Carlo start, then Gauss-Newton).
    backlash_search : dict
        Stage 3b: candidates and criteria of the backlash search.
    mechanical : IdentificationResult
        Stage 3c: mechanics refitted with the backlash, ``c_backlash`` free.
    joint : IdentificationResult or None
        Stage 4: every parameter refined together on the full coupled model
        (exact sensitivities), from the stage 1-3 values.
    stage_parameters : dict
        AXT211 parameters after stages 1-3 (the paper's procedure).
    parameters : dict
        Final AXT211 parameters (after stage 4 when run).
    fit : FitResult
    xi : list of dict
        Per validation test case: ξ (22) of P_PTC, T_P and x_V of the full
        coupled model with the final parameters, driven by measured u, k_U,
        T_U (Table II of paper 002).
    xi_submodel : list of dict
        ξ of each submodel driven by measured inputs (PTC and mechanics by
        the measured T_P), with the stage 1-3 parameters.
    xi_staged : list of dict
        ξ of the full coupled model with the stage 1-3 parameters (compare
        with ``xi``: when the model lacks physics, the joint refinement trades
        one submodel's accuracy for another's).
    recovered : dict
        Per parameter: fitted value, interval, truth and whether it is inside.
    start : dict
        Start values of the grey-box stages.
    level : float
    """

    ptc: PTCFit
    thermal: IdentificationResult
    mechanical_no_backlash: IdentificationResult
    backlash_search: dict[str, Any]
    mechanical: IdentificationResult
    joint: IdentificationResult | None
    stage_parameters: dict[str, float]
    parameters: dict[str, float]
    fit: FitResult
    xi: list[dict[str, Any]]
    xi_submodel: list[dict[str, Any]]
    xi_staged: list[dict[str, Any]] = field(default_factory=list)
    recovered: dict[str, dict[str, Any]] = field(default_factory=dict)
    start: dict[str, float] = field(default_factory=dict)
    level: float = 0.95

    def mean_xi(self, coupled: bool = True, staged: bool = False) -> dict[str, float]:
        """Mean ξ per submodel over the validation cases (paper: 0.93 / 0.95 / 0.84).

        ``coupled``: the full model (else each submodel on measured inputs);
        ``staged``: with the stage 1-3 parameters instead of the final ones.
        """
        rows = (self.xi_staged if staged else self.xi) if coupled else self.xi_submodel
        return {k: float(np.mean([r[k] for r in rows])) for k in ("PTC", "thermal", "mechanical")}

    def table(self) -> str:
        """Table II of paper 002 for the validation cases, plus recovered parameters."""
        lines = [
            f"{'test case':<22} {'PTC':>7} {'thermal':>8} {'mech':>7}   submodel-wise, stages 1-3:"
            " PTC thermal mech"
        ]
        for a, b in zip(self.xi, self.xi_submodel, strict=True):
            lines.append(
                f"{a['test_case']:<22} {a['PTC']:>7.4f} {a['thermal']:>8.4f} "
                f"{a['mechanical']:>7.4f}   {b['PTC']:.4f} {b['thermal']:.4f} "
                f"{b['mechanical']:.4f}"
            )
        m, s = self.mean_xi(True), self.mean_xi(False)
        lines.append(
            f"{'mean':<22} {m['PTC']:>7.4f} {m['thermal']:>8.4f} {m['mechanical']:>7.4f}   "
            f"{s['PTC']:.4f} {s['thermal']:.4f} {s['mechanical']:.4f}"
        )
        if self.xi_staged:
            g = self.mean_xi(True, staged=True)
            lines.append(
                f"{'mean, stages 1-3':<22} {g['PTC']:>7.4f} {g['thermal']:>8.4f} "
                f"{g['mechanical']:>7.4f}   (coupled model, before the joint refinement)"
            )
        lines.append(f"{'paper 002 (mean)':<22} {0.93:>7.2f} {0.95:>8.2f} {0.84:>7.2f}")
        if self.recovered:
            pct = round(100 * self.level)
            lines.append("")
            lines.append(
                f"{'parameter':<12} {'start':>10} {'stages 1-3':>11} {'final':>11} {'stderr':>10} "
                f"{f'{pct}% interval':>25} {'truth':>10}  inside"
            )
            for n, r in self.recovered.items():
                lines.append(
                    f"{n:<12} {self.start.get(n, float('nan')):>10.5g} "
                    f"{self.stage_parameters[n]:>11.6g} {r['value']:>11.6g} "
                    f"{r['stderr']:>10.3g} [{r['lower']:>10.5g}, {r['upper']:>10.5g}] "
                    f"{r['truth']:>10.5g}  {'yes' if r['inside'] else 'NO'}"
                )
        return "\n".join(lines)


def identify_axt211(
    train: Sequence[Recording],
    mech_train: Sequence[Recording],
    validation: Sequence[Recording],
    *,
    start: dict[str, float] | None = None,
    jac: str = "exact",
    level: float = 0.95,
    max_iter: int = 100,
    joint: bool = True,
    mc_samples: int = 1000,
    seed: int = 0,
    smooth_s: float = 120.0,
    progress: bool | None = None,
    truth: dict[str, float] | None = None,
) -> GreyboxResult:
    """Identify the AXT211 submodel by submodel and validate it (paper 002, VI-VII).

    Stages 1-3 follow the paper (PTC by linear least squares; thermodynamics
    by grey-box fitting with the PTC fixed; mechanics on the measured wax
    temperature with the backlash disabled, then the backlash). Stage 4
    (``joint=True``) refines every parameter together on the full coupled
    model — the simulated wax temperature is noise-free, which removes the
    errors-in-variables bias of fitting R against a *measured* temperature,
    and the uncertainty of one submodel then enters the others' intervals.

    Parameters
    ----------
    train : sequence of Recording
        Open-loop tests for the PTC and thermodynamic submodels.
    mech_train : sequence of Recording
        Tests for the mechanical submodel (e.g. the staircase and a step whose
        wax temperature crosses the whole stroke range).
    validation : sequence of Recording
        Other test cases, for ξ.
    start : dict, optional
        Start values of the thermal and mechanical parameters (default nominal).
    jac : {"exact", "fd", "auto"}
        Jacobian of the thermodynamic and joint fits (the mechanical submodel
        uses batched finite differences).
    level : float
        Confidence level.
    max_iter : int
        Gauss-Newton iterations per stage.
    joint : bool
        Run stage 4.
    mc_samples : int
        Monte Carlo samples that give the mechanics a global start (the stroke
        model is flat — x_V = 0 — wherever T_P0 lies above the measured
        temperatures, where a local method cannot move).
    seed : int
        Seed of the Monte Carlo start.
    smooth_s : float
        Window of the moving average applied to the measured supply voltage
        and ambient temperature before they drive simulations
        (:func:`smooth_disturbances`; 0: off).
    progress : bool, optional
    truth : dict, optional
        True parameters (rig data) to check the intervals against.

    Returns
    -------
    GreyboxResult
    """
    start = dict(start or {})
    # sensor noise of the measured disturbances, from the raw data (errors in variables)
    dist_noise = estimate_input_noise([*train, *mech_train], ["k_U", "T_U"])

    def prepare(r: Recording) -> Recording:
        return smooth_disturbances(r, smooth_s)

    train, mech_train, validation = (
        [prepare(r) for r in recs] for recs in (train, mech_train, validation)
    )
    # 1. PTC polynomial (14) by linear least squares
    ptc = fit_ptc_polynomial(train)
    # 2. thermodynamic submodel (17)-(18), PTC fixed at stage 1
    model = AXT211()
    pb_th = Problem(
        model,
        train,
        pairs=["T_P", "T_G"],
        free=[FreeParameter(n, start=start.get(n)) for n in THERMAL],
        fixed=ptc.parameters(),
        objective="mse",
    )
    th_res = run_identification(
        pb_th,
        "greybox",
        jac=jac,
        max_iter=max_iter,
        level=level,
        progress=progress,
        input_noise=dist_noise,
        input_prepare=prepare,
    )
    # 3a. mechanics with the backlash disabled (not differentiable, paper 002 VI-C):
    #     a batched Monte Carlo start, then Gauss-Newton (finite differences in one batch)
    mech = AXT211Mechanics(free=[*MECHANICAL, "c_backlash"])
    pb_m0 = Problem(
        mech,
        mech_train,
        pairs=["x_V"],
        free=[FreeParameter(n, start=start.get(n)) for n in MECHANICAL],
        fixed={"c_backlash": 0.0},
        objective="mse",
    )
    m0 = run_identification(
        pb_m0,
        "montecarlo",
        n_samples=mc_samples,
        batch_size=max(1, mc_samples // 4),
        seed=seed,
        polish=True,
        level=level,
        progress=progress,
        identifiability=False,
        keep_samples=False,
    )
    # 3b. backlash half-width by a derivative-free search, every candidate in one batch
    cands = np.linspace(0.0, 0.6, 61)
    pb_c = Problem(
        mech,
        mech_train,
        pairs=["x_V"],
        free={"c_backlash": (0.0, float(_SPEC["c_backlash"].upper))},
        fixed={n: m0.values[n] for n in MECHANICAL},
        objective="mse",
    )
    ev = pb_c.evaluate(cands[:, None])
    c_best = float(cands[int(np.argmin(ev.mse))])
    search = {"candidates": cands.tolist(), "mse": ev.mse.tolist(), "best": c_best}
    # 3c. mechanics refitted with the backlash, c free from the search result
    pb_m = Problem(
        mech,
        mech_train,
        pairs=["x_V"],
        free=[FreeParameter(n, start=m0.values[n]) for n in MECHANICAL]
        + [FreeParameter("c_backlash", start=max(c_best, 1e-3), lower=0.0, upper=1.0)],
        objective="mse",
    )
    m1 = run_identification(
        pb_m,
        "greybox",
        jac="fd",
        diff="central",
        max_iter=max_iter,
        level=level,
        progress=progress,
        input_noise={"T_P": _noise(th_res, 0, 0.1)},  # the measured T_P drives the submodel
    )
    stage = dict(zip(model.param_names, model.nominal.tolist(), strict=True))
    stage.update(ptc.parameters())
    stage.update(th_res.values)
    stage.update(m1.values)
    names = [*PTC, *THERMAL, *MECHANICAL, "c_backlash"]
    # uncertainty of the staged result: block diagonal over the submodels
    C = np.zeros((len(names), len(names)))
    C[:6, :6] = ptc.covariance
    ok = True
    for off, res in ((6, th_res), (10, m1)):
        u = res.uncertainty
        if u is None or u.covariance is None:
            ok = False
            continue
        k = u.covariance.shape[0]
        C[off : off + k, off : off + k] = u.covariance
    final = dict(stage)
    jres: IdentificationResult | None = None
    if joint:
        jres = _joint_refinement(
            model,
            [*train, *mech_train],
            stage,
            names,
            th_res,
            m1,
            ptc,
            jac,
            level,
            max_iter,
            progress,
            dist_noise,
            prepare,
        )
        final.update(jres.values)
        if jres.uncertainty is not None and jres.uncertainty.covariance is not None:
            C, ok = jres.uncertainty.covariance, True
        else:
            ok = False
    se = np.sqrt(np.clip(np.diag(C), 0, None))
    if jres is not None and jres.uncertainty is not None:
        se = jres.uncertainty.stderr
    xi_rows = [{"test_case": r.experiment_id, **_xi_coupled(model, final, r)} for r in validation]
    xi_sub = [{"test_case": r.experiment_id, **_xi_submodels(stage, r)} for r in validation]
    xi_staged = [{"test_case": r.experiment_id, **_xi_coupled(model, stage, r)} for r in validation]
    fit = FitResult.from_model(
        model,
        final,
        stderr=dict(zip(names, np.asarray(se, dtype=float).tolist(), strict=True)),
        covariance=np.asarray(C).tolist() if ok else None,
        covariance_names=names if ok else [],
        fixed=[n for n in model.param_names if n not in names],
        method="coordinator:greybox-submodels (paper 002)",
        settings={
            "stages": [
                "1 ptc: linear least squares (14) on measured T_P",
                "2 thermal: greybox (17)-(18), PTC fixed",
                "3 mechanical: montecarlo + greybox (19)-(21) without backlash, backlash "
                "search, greybox refit with backlash",
                *(["4 joint: greybox on the full coupled model"] if joint else []),
            ],
            "jac": jac,
            "confidence_level": level,
            "backlash_search_best": c_best,
            "stage_parameters": stage,
        },
        metrics={
            "validation": {
                r["test_case"]: {k: r[k] for k in ("PTC", "thermal", "mechanical")} for r in xi_rows
            },
            "train": {
                "ptc_rmse_ohm": ptc.rmse,
                "thermal_criterion": th_res.criterion,
                "mechanical_criterion": m1.criterion,
                **({"joint_criterion": jres.criterion} if jres is not None else {}),
            },
        },
        data=[data_entry(r, "train") for r in train]
        + [data_entry(r, "train-mechanics") for r in mech_train]
        + [data_entry(r, "validation") for r in validation],
    )
    recovered: dict[str, dict[str, Any]] = {}
    if truth is not None:
        if jres is not None and jres.uncertainty is not None:
            u = jres.uncertainty
            bounds = {n: (u.lower[i], u.upper[i]) for i, n in enumerate(u.names)}
        else:
            t = float(stats.t.ppf(0.5 + level / 2.0, max(ptc.n_points - 6, 1)))
            bounds = {n: (final[n] - t * se[i], final[n] + t * se[i]) for i, n in enumerate(names)}
        for i, n in enumerate(names):
            if n not in truth:
                continue  # no matching quantity in the true plant
            lo, hi = bounds[n]
            tv = float(truth[n])
            recovered[n] = {
                "value": float(final[n]),
                "stderr": float(se[i]),
                "lower": float(lo),
                "upper": float(hi),
                "truth": tv,
                "inside": bool(lo <= tv <= hi),
            }
    return GreyboxResult(
        ptc=ptc,
        thermal=th_res,
        mechanical_no_backlash=m0,
        backlash_search=search,
        mechanical=m1,
        joint=jres,
        stage_parameters=stage,
        parameters=final,
        fit=fit,
        xi=xi_rows,
        xi_submodel=xi_sub,
        xi_staged=xi_staged,
        recovered=recovered,
        start=start,
        level=level,
    )


def _joint_refinement(
    model: AXT211,
    recordings: Sequence[Recording],
    stage: dict[str, float],
    names: Sequence[str],
    th_res: IdentificationResult,
    m1: IdentificationResult,
    ptc: PTCFit,
    jac: str,
    level: float,
    max_iter: int,
    progress: bool | None,
    input_noise: dict[str, float],
    prepare: Any,
) -> IdentificationResult:
    """Stage 4: all parameters on the full model, pairs weighted by 1/noise variance."""
    # noise levels from the stages' residuals: maximum-likelihood weights w_j = N_j / σ_j²
    sig = {"R_PTC": ptc.rmse, "x_V": _noise(m1, 0, 0.005)}
    sig["T_P"], sig["T_G"] = _noise(th_res, 0, 0.1), _noise(th_res, 1, 0.1)
    pairs = ["T_P", "T_G", "R_PTC", "x_V"]
    free = []
    for n in names:
        p = _SPEC[n]
        lo, hi = (0.0, 1.0) if n == "c_backlash" else (p.lower, p.upper)
        v = float(stage[n])
        if n in PTC and not lo <= v <= hi:
            # stage 1's polynomial (linear least squares, unbounded) lies outside the
            # default box of the coefficients: widen the box around it rather than clip
            # the start, which would make another curve (a clipped polynomial can turn
            # negative in the cold and the heater then cools)
            half = max(0.5 * (hi - lo), abs(v))
            lo, hi = min(lo, v - half), max(hi, v + half)
        free.append(FreeParameter(n, start=float(np.clip(v, lo, hi)), lower=lo, upper=hi))
    pb0 = Problem(model, recordings, pairs=pairs, free=free, objective="mse")
    w = pb0.n_samples / np.array([sig[p] ** 2 for p in pairs])
    pb = Problem(
        model,
        recordings,
        pairs=[(p, p, float(wi / w.max())) for p, wi in zip(pairs, w, strict=True)],
        free=free,
        objective="mse",
    )
    return run_identification(
        pb,
        "greybox",
        jac=jac,
        max_iter=max_iter,
        level=level,
        progress=progress,
        input_noise=input_noise,
        input_prepare=prepare,
    )


def _noise(res: IdentificationResult, j: int, default: float) -> float:
    u = res.uncertainty
    if u is None or u.noise_std.size <= j or not np.isfinite(u.noise_std[j]):
        return default
    return float(u.noise_std[j])


def _xi_coupled(model: AXT211, params: dict[str, float], rec: Recording) -> dict[str, float]:
    """ξ (22) of the full coupled model on one test case (Table II of paper 002)."""
    sim = model.simulate(rec.exogenous_array(model), rec.dt, model.theta(params))
    out = {}
    for key, sig in (("PTC", "P_PTC"), ("thermal", "T_P"), ("mechanical", "x_V")):
        out[key] = float(accuracy_xi(rec[sig], sim.output(sig)[0]))
    return out


def _xi_submodels(params: dict[str, float], rec: Recording) -> dict[str, float]:
    """ξ of each submodel driven by measured inputs."""
    coeffs = np.array([params[n] for n in PTC])
    R = ptc_resistance(np.asarray(rec["T_P"]), coeffs)
    P = (np.asarray(rec["k_U"]) * np.asarray(rec["u"])) ** 2 / R  # (15) on measured T_P
    mech = AXT211Mechanics()
    th = np.array([[params[n] for n in AXT211Mechanics.all_names]])
    xv = mech.simulate(th, rec).outputs[0, :, 1]
    model = AXT211()
    sim = model.simulate(rec.exogenous_array(model), rec.dt, model.theta(params))
    return {
        "PTC": float(accuracy_xi(rec["P_PTC"], P)),
        "thermal": float(accuracy_xi(rec["T_P"], sim.output("T_P")[0])),
        "mechanical": float(accuracy_xi(rec["x_V"], xv)),
    }


# the kernels above inline compiled functions of other modules (derived cache dependencies)
module_kernels_depend_on(globals())
