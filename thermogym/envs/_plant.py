"""Which dynamics an environment runs: the identified model or the virtual rig.

``params`` and ``plant`` of every environment are resolved here:

* ``plant="model"`` (default): the identified model. ``params`` is a
  :class:`~thermogym.fitresult.FitResult`, the path of its JSON file or its
  dict (:func:`thermogym.fitresult.load_fit`); without it the package's
  nominal parameters are used. The FitResult must be of a model the
  environment can run (its name is checked, and its version by
  :meth:`FitResult.build_model`).
* ``plant="rig"``: the virtual test rig's true plant. For a rig with a true
  plant of its own (:class:`thermogym.rigs.base.TruePlant`: the AXT211, room,
  strut and spindle rigs) the environment steps that plant, one specimen drawn from its
  manufacturing spread, and measures through the rig's sensors
  (:mod:`thermogym.envs._rig`); :attr:`Plant.model` is then only the nominal
  model (shapes and names), not what runs (the strut and spindle envs step
  their rigs' plants in :mod:`thermogym.envs._network`). Nothing of the rig's
  effects is visible to the controller except through the measurements.

Environments read FitResults through :mod:`thermogym.fitresult` only; they
never import :mod:`thermogym.identification` (DESIGN.md dependency rule).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import nonnegative
from thermogym.errors import ConfigError, ParameterError
from thermogym.fitresult import FitResult, load_fit
from thermogym.models.base import Model

__all__ = ["ParamsLike", "Plant", "is_overrides", "make_sampler", "resolve_plant", "rig_only"]

ParamsLike = FitResult | str | os.PathLike[str] | Mapping[str, Any] | None
PLANTS = ("model", "rig")
SAMPLING = ("covariance", "bounds", "relative")


@dataclass
class Plant:
    """Resolved dynamics of an environment.

    Attributes
    ----------
    model : Model
        The model whose step kernels the environment calls.
    theta : ndarray, shape (1, P)
        Parameter set of the episode when nothing randomises it.
    kind : {"model", "rig"}
    fit : FitResult
        The FitResult the parameters come from (a nominal one built with
        :meth:`FitResult.from_model` when none was given).
    rig_effects : tuple of EffectSpec
        Effects the rig carries (``plant="rig"`` only).
    sensors : dict
        Rig sensor specifications by signal name (``plant="rig"`` only).
    rig : Rig or None
        The rig (``plant="rig"`` only).
    true_plant : TruePlant or None
        The rig's true plant, when it has one (``plant="rig"``).
    specimens : Specimens or None
        The specimen of the true plant (one).
    """

    model: Model
    theta: NDArray[np.float64]
    kind: str
    fit: FitResult
    rig_effects: tuple[Any, ...] = ()
    sensors: dict[str, Any] = field(default_factory=dict)
    rig: Any = None
    true_plant: Any = None
    specimens: Any = None

    def sensor_errors(
        self, channels: Sequence[str], n: int
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Offset and drift per hour of the first ``len(channels)`` of ``n`` observations.

        From the rig's ``sensor_offset`` and ``sensor_drift`` effects (their
        settings over the rig's defaults, as the rig applies them) on an
        observed channel; zeros elsewhere and for the identified model.
        """
        offset = np.zeros(n)
        drift = np.zeros(n)
        for eff in self.rig_effects:
            if eff.name not in ("sensor_offset", "sensor_drift"):
                continue
            s = {**self.rig.effect_defaults.get(eff.name, {}), **eff.params}
            if s.get("signal") not in channels:
                continue
            j = list(channels).index(s["signal"])
            key = "offset" if eff.name == "sensor_offset" else "rate"
            try:
                v = float(s[key])
            except (KeyError, TypeError, ValueError):
                raise ConfigError(
                    f"rig effect {eff.name}: {key} is {s.get(key)!r}; expected a number"
                ) from None
            (offset if key == "offset" else drift)[j] = v
        return offset, drift


def is_overrides(params: ParamsLike) -> bool:
    """Whether ``params`` is a plain ``{parameter: value}`` mapping, not a FitResult dict.

    A FitResult dict has its required keys ``model`` and ``parameters``; a
    mapping of names to numbers (``{"C_P": 20}``) sets those parameters of the
    environment's default model.

    Examples
    --------
    >>> is_overrides({"C_P": 20.0}), is_overrides({"model": "tclab", "parameters": {}})
    (True, False)
    """
    if not isinstance(params, Mapping) or not params:
        return False
    if "parameters" in params or "model" in params or "format" in params:
        return False
    return all(isinstance(k, str) for k in params)


def load_params(params: ParamsLike, models: Sequence[str], env: str) -> FitResult | None:
    """Load ``params`` and check that it is a FitResult of one of ``models``."""
    if params is None:
        return None
    fit = load_fit(params)
    if fit.model not in models:
        raise ConfigError(
            f"{env}: params is a FitResult of model {fit.model!r}; this environment runs "
            f"model(s) {list(models)}"
        )
    return fit


def resolve_plant(
    env: str,
    *,
    params: ParamsLike,
    plant: str,
    models: Sequence[str],
    default: Callable[[], Model] | ParamsLike,
    rig: str | None,
    rig_effects: Sequence[Any] = (),
    stepwise_effects: Sequence[str] = (),
    specimen: Mapping[str, float] | Any | None = None,
    rig_options: Mapping[str, Any] | None = None,
) -> Plant:
    """Resolve ``params`` / ``plant`` keywords into a :class:`Plant`.

    Parameters
    ----------
    env : str
        Environment name for messages.
    params : FitResult, path, dict or None
    plant : {"model", "rig"}
    models : sequence of str
        Model names the environment can run.
    default : callable or FitResult-like
        Nominal model factory, or the FitResult used when ``params`` is None.
    rig : str or None
        Rig name of :func:`thermogym.rigs.get_rig` (None: no rig).
    rig_effects : sequence
        ``NAME[:k=v,...]`` effects of the rig.
    stepwise_effects : sequence of str
        The rig effects the environment can apply step by step (the others act
        on whole recordings: delays, lags, hidden disturbances).
    specimen : mapping or Specimens, optional
        The rig's specimen (manufacturing spread): parameter overrides, or a
        :class:`~thermogym.rigs.base.Specimens` of one for a true-plant rig.
    rig_options : mapping, optional
        Keyword arguments of the rig's constructor (e.g. ``valve`` of the room rig).

    Raises
    ------
    ConfigError
        Unknown ``plant``, ``params`` with ``plant="rig"``, ``rig_effects``
        with ``plant="model"`` or not available step-wise, no rig for this
        environment, a FitResult of another model.
    """
    if plant not in PLANTS:
        raise ConfigError(f"{env}: plant is {plant!r}; expected one of {PLANTS}")
    bad = [e for e in rig_effects if str(e).split(":")[0] not in stepwise_effects]
    if bad:
        raise ConfigError(
            f"{env}: rig effect(s) {bad} are not available step-wise in environments; "
            f"available: {list(stepwise_effects)}"
        )
    if plant == "model":
        if rig_effects:
            raise ConfigError(
                f"{env}: rig_effects {list(rig_effects)} apply to plant='rig' only; the "
                "identified model has no concealed physics"
            )
        overrides: dict[str, Any] = {}
        if is_overrides(params):
            # params={"C_P": 20}: plain values on top of the environment's default model
            overrides = dict(params)  # type: ignore[arg-type]
            params = None
        fit = load_params(params, models, env)
        if fit is None and not callable(default):
            fit = load_params(default, models, env)
        if fit is None:
            if not callable(default):  # default=None: nothing to run
                raise ConfigError(f"{env}: no parameters given and no nominal model")
            model = default()
            fit = FitResult.from_model(model, method="nominal", notes="package nominal values")
        else:
            model = fit.build_model()
        theta = fit.theta(model)
        if overrides:
            theta = model.theta(theta, **overrides)  # unknown names: ParameterError, listed
            fit = FitResult.from_model(
                model,
                theta[0],
                method=f"{fit.method or 'nominal'} with overrides",
                notes=f"parameters set by the caller: {sorted(overrides)}",
            )
        return Plant(model, theta, "model", fit)
    if params is not None:
        raise ConfigError(
            f"{env}: params is given with plant='rig'; the rig is the true plant and has its "
            "own parameters (use plant='model' to run a FitResult)"
        )
    if rig is None:
        raise ConfigError(
            f"{env}: there is no virtual rig for this plant (its real plant is physical "
            "hardware); use plant='model'"
        )
    from thermogym.rigs import get_rig  # the rigs (~0.4 s) load only for plant='rig'

    r = get_rig(rig, rig_effects, **dict(rig_options or {}))
    if specimen is not None and (not isinstance(specimen, Mapping) or specimen):
        r = r.with_specimen(specimen)
    # every rig has a true plant of its own (Rig.plant raises ConfigError for one without):
    # the environment steps it; the model stays nominal
    if callable(default):
        model = default()
    else:
        nominal = load_params(default, models, env)
        if nominal is None:
            raise ConfigError(f"{env}: no nominal model (default is None)")
        model = nominal.build_model()
    spec = r.specimen
    # the model's nominal parameters (shapes and names only) and, in its arrays, the rig
    # specimen's physical parameters: the fingerprint tells one rig specimen from another
    fit = FitResult.from_model(
        model,
        method="nominal",
        notes=f"plant='rig': the virtual rig {rig!r} runs, not this model",
        arrays={"rig_specimen": [float(spec[n][0]) for n in spec.names]},
        settings={"rig": rig, "rig_specimen_names": list(spec.names)},
    )
    return Plant(
        model, fit.theta(model), "rig", fit, tuple(r.effects), dict(r.sensors), r,
        r.plant(), r.specimen,
    )  # fmt: skip


def make_sampler(
    fit: FitResult,
    model: Model,
    method: str,
    *,
    scale: float = 1.0,
    names: Sequence[str] | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
) -> Callable[[np.random.Generator], NDArray[np.float64]]:
    """Build a parameter sampler ``sampler(rng) -> theta (1, P)`` for domain randomisation.

    Parameters
    ----------
    fit : FitResult
        Centre (and covariance / bounds) of the distribution.
    model : Model
        The model the parameter sets are for.
    method : {"covariance", "bounds", "relative"}
        ``"covariance"``: multivariate normal with the FitResult's covariance
        or standard errors (:meth:`FitResult.sample`, ``"normal"``);
        ``"bounds"``: uniform within the FitResult's bounds (or ``bounds``)
        for the parameters ``names`` (default: those not fixed);
        ``"relative"``: uniform within ``value · (1 ± scale)`` for ``names``.
    scale : float
        Standard-deviation multiplier (``"covariance"``) or relative
        half-width (``"relative"``).
    names : sequence of str, optional
        Parameters to randomise (``"bounds"``, ``"relative"``).
    bounds : mapping, optional
        ``{name: (lower, upper)}`` replacing the FitResult's bounds (``"bounds"``).

    Raises
    ------
    ConfigError
        Unknown method.
    ParameterError
        Unknown names, nothing to randomise, or no valid draw in 20 attempts.
    """
    if method not in SAMPLING:
        raise ConfigError(f"randomisation method is {method!r}; expected one of {SAMPLING}")
    nonnegative("randomisation scale", scale, text=False)
    fit._check_model(model, check_version=False)
    if names is not None:
        unknown = [n for n in names if n not in model.param_names]
        if unknown:
            raise ParameterError(
                f"cannot randomise {unknown}: not parameters of model {model.name!r} "
                f"({list(model.param_names)})"
            )
    centre = model.theta(fit.parameters)[0]
    if method == "covariance":
        if fit.covariance is None and not any(np.isfinite(list(fit.stderr.values()))):
            if fit.method == "n4sid" or fit.model == "ss":
                raise ParameterError(
                    "randomisation 'covariance' needs a FitResult with a covariance or standard "
                    f"errors; this {fit.method or fit.model!r} fit has none (N4SID estimates no "
                    "parameter covariance). Fits that carry one: `thermogym identify ssest` "
                    "(N4SID refined by prediction-error minimisation), arx, armax, oe, bj, "
                    "sopdt and foptd; re-identify with `identify ssest`, or randomise with "
                    "'relative' (each parameter uniform within ±scale of its value)"
                )
            raise ParameterError(
                "randomisation 'covariance' needs a FitResult with a covariance or standard "
                f"errors; this {fit.method or fit.model!r} fit has none (use 'bounds' or "
                "'relative')"
            )

        def draw(rng: np.random.Generator) -> NDArray[np.float64]:
            return model.theta(fit.sample(1, rng, method="normal", scale=scale))

    else:
        free = [n for n in (names or model.param_names) if n not in fit.fixed]
        if method == "bounds":
            src = {**fit.bounds, **dict(bounds or {})}
            lohi = {n: src[n] for n in free if n in src and np.all(np.isfinite(src[n]))}
            if bounds:
                bad = [n for n in bounds if n not in model.param_names]
                if bad:
                    raise ParameterError(f"bounds name unknown parameter(s) {bad}")
        else:
            lohi = {}
            for n in free:
                v = centre[model.param_index(n)]
                lohi[n] = (v - scale * abs(v), v + scale * abs(v))
        if not lohi:
            raise ParameterError(f"randomisation {method!r}: no parameter with finite bounds")
        cols = np.array([model.param_index(n) for n in lohi], dtype=np.int64)
        lo = np.array([lohi[n][0] for n in lohi])
        hi = np.array([lohi[n][1] for n in lohi])

        def draw(rng: np.random.Generator) -> NDArray[np.float64]:
            th = centre.copy()
            th[cols] = rng.uniform(lo, hi)
            return model.theta(th)

    def sampler(rng: np.random.Generator) -> NDArray[np.float64]:
        last: Exception | None = None
        for _ in range(20):  # a draw outside the physical domain is drawn again
            try:
                return draw(rng)
            except ParameterError as e:
                last = e
        raise ParameterError(f"no valid parameter set in 20 draws; last: {last}") from last

    return sampler


def rig_only(env: str, what: str) -> ConfigError:
    """The error for a model-only operation on the rig (parameters, randomisation)."""
    return ConfigError(
        f"{env}: {what} is not available with plant='rig': the rig's true plant is not a model "
        "with parameters (use plant='model'; the rig's specimen is set by specimen_seed)"
    )
