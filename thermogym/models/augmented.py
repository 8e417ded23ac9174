"""A plant model plus the physics diagnosis found missing: the ``augmented`` model.

Description
-----------
:class:`AugmentedModel` wraps any base model — a registered thermogym plant,
``foptd``, ``ss``, or a user's own :class:`~thermogym.models.base.Model`
instance — and adds *augmentations*: effects of the vocabulary of DESIGN.md in
one of their physically allowed forms, written around the base model, each
with a few parameters whose neutral value switches it off. Effects a plant's
own equations can include (``phase_change`` of the AXT211,
``input_dependent_heat_transfer`` of the RC networks, ...) are not wrapped:
they are switched on in the base model through ``base_config = {"effects":
[...]}``. The forms are indexed in :mod:`thermogym.models._augment_kinds`.

The augmentations act in four places::

    u ──input side──► base model ──plant side──► y_true ──sensor side──► y
                 ▲                     │
                 └──── loop side ◄─────┘   (a heat flow fed back to a port)

============================================  ======  ==============================================
augmentation (effect, form)                   side    equation (``k`` sample, ``Δt`` period)
============================================  ======  ==============================================
transport_delay, input / output               input / ``u_i(t − τ)`` / ``y_j(t − τ)``
                                              sensor
unmeasured_disturbance, periodic/steps/smooth input   ``port += d(t)`` (per-recording course)
unmeasured_disturbance, events                input   ``port += A_s`` while an event is on (times
                                                      read from each recording)
supply_variation, steps / smooth              input   ``u_i (1 + s(t))`` (per-recording course)
input_nonlinearity, power                     input   ``u_ref (u/u_ref)^α``
input_nonlinearity, saturation                input   ``u (1 + c)/(1 + c|u|/u_ref)``
input_nonlinearity, limit                     input   ``sign(u) min(|u|, L)`` (hard limit)
input_nonlinearity, dead_zone                 input   ``max(|u| − d, 0) u_ref/(u_ref − d)``
input_nonlinearity, piecewise_linear          input   monotone map through fixed input knots
backlash, input / output                      input / play operator of half-width ``c``
                                              plant
missing_dynamics, input_lag                   input   ``τ ds/dt = u_i − s``, the plant sees ``s``
nonlinear_heat_transfer, radiation            loop    ``port −= κ [(T⁴ − T_r⁴)/(4T̄³) − (T − T_r)]``
nonlinear_heat_transfer, convection           loop    ``port −= κ [|Δ|^n/ΔT̄^(n−1) − Δ]``
input_dependent_heat_transfer, power          loop    ``port −= κ (|u_s|/u_ref)^m (T − T_r)``
time_varying_parameter, ramp/step/random_walk loop    ``port −= κ(t) (T − T_r)``
missing_dynamics, extra_node                  loop    ``port += κ (z − T)``, ``τ dz/dt = T − z``
phase_change, latent_heat                     loop    ``port −= κ g(T; T_m, w) dT/dt``
missing_dynamics, parallel                    plant   ``y_j += z``, ``T dz/dt = Σ_s K_s Δu_s − z``
sensor_lag                                    sensor  ``s[k+1] = a s[k] + (1 − a) y_j[k]``
sensor_offset / sensor_drift                  sensor  ``y_j += b`` / ``y_j += r t / 1 h``
============================================  ======  ==============================================

A loop term is a heat flow expressed in kelvin at the ambient port (``port``
is the ambient temperature input: a loss lowers the ambient the node sees) or
converted to the heat input's unit (``scale``); temperatures are in °C
unless the output's unit is K (radiation uses kelvin). Legacy forms without a
``form`` key (static corrections of the rise, exact at steady state) keep
rebuilding older FitResults.

**Loop side: waveform relaxation.** The base model cannot see inside itself
in this wrapper, so a term fed back from its output is solved on the whole
trajectory: ``y⁰ = base(u)``, ``yⁱ⁺¹ = base(u + term(yⁱ))`` (Anderson-accelerated) until the
largest change is below ``1e-8`` of the output's scale; a loop strong enough
to need more than a dozen passes is fed back sample by sample with the base
model's own ``step`` instead (exact), or relaxed up to
:data:`MAX_RELAXATION` passes when the base model cannot step (a set that
does not converge is returned as NaN). The base model is strictly proper
(``y[k]`` depends on inputs before ``k``), so each pass makes one more sample
exact and the fixed point is the sample-by-sample feedback that
:meth:`AugmentedModel.step` computes.

Per-recording parameters (group ``"local"``) are fitted in every recording
by the diagnosis; a model used elsewhere (environments) runs with them at
their neutral values.

Step-wise use (environments): :meth:`AugmentedModel.step` and
:meth:`AugmentedModel.output` carry the augmentations' states (lag values,
delay history, elapsed time) after the base states, so stepping reproduces
:meth:`AugmentedModel.simulate`. A ``transport_delay`` needs ``history``
samples of memory (set when the model is built by diagnosis).

The model is registered as ``augmented`` (see :func:`register`), so
``FitResult.build_model()`` rebuilds it from ``model_config``::

    {"base": "strut", "base_config": {}, "augmentations": [
        {"effect": "sensor_lag", "signal": "T_nut"}]}

Version History
---------------
* v1: initial release; forms, the loop side and per-recording parameters
  added without a version change (older configurations rebuild as before).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.errors import ConfigError, ParameterError, ShapeError
from thermogym.models._augment_base import LOCAL, RECORDED, _Aug
from thermogym.models._augment_input import _Delay
from thermogym.models._augment_kinds import AUGMENTATIONS, kind_of
from thermogym.models._augment_loop import _Loop
from thermogym.models._augment_plant import RESIDUAL_TERMS, term_tag
from thermogym.models.base import Model
from thermogym.models.fastnet import ExtraNodeNetwork
from thermogym.models.registry import get_model, model_names, register_model

__all__ = [
    "AUGMENTATIONS",
    "LOCAL",
    "MAX_RELAXATION",
    "RECORDED",
    "RESIDUAL_TERMS",
    "AugmentedModel",
    "register",
    "term_tag",
]

#: Most waveform-relaxation passes of the loop side.
MAX_RELAXATION = 60
#: Relaxation stops when no output changes by more than this share of its scale.
_RELAX_TOL = 1e-8
#: Relaxation passes after which a base model that can step is stepped instead.
_PASSES_BEFORE_STEPPING = 30
#: Iterates Anderson acceleration of the relaxation mixes.
_AA_MEMORY = 5
_SIDES = ("input", "loop", "plant", "sensor")


class AugmentedModel(Model):
    """A base model with effects the diagnosis added around it.

    Parameters
    ----------
    base : str or Model
        Registered name of the base model, or a model instance (a user's own
        :class:`~thermogym.models.base.Model`; its FitResult then names the
        instance's ``name`` and ``config()``, which rebuild it only where that
        model is registered).
    base_config : dict, optional
        Constructor arguments of a base model given by name (e.g. its ``effects``).
    augmentations : sequence of dict
        ``{"effect": NAME, "signal": COLUMN, "form": FORM, ...}`` for each added
        effect (see the module docstring); further keys per form: ``port`` and
        ``reference`` (loop side), ``source``, ``u_ref``, ``knots``,
        ``span``/``segments`` (courses), ``history`` (dead times), ``sources``
        (parallel path), ``terms`` and ``input`` (residual_ode), ``bounds``
        ({suffix: [lo, hi]}).

    Raises
    ------
    ConfigError
        Unknown augmentation, form, signal, option, or a parameter name that
        clashes with the base model's.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.models.augmented import AugmentedModel
    >>> m = AugmentedModel("foptd", {"inputs": ["u"], "outputs": ["y"], "T": 100.0},
    ...                    [{"effect": "sensor_offset", "signal": "y"}])
    >>> m.param_names
    ('K_y', 'T_y', 'tau_y', 'offset_y')
    >>> sim = m.simulate(np.ones((50, 1)), 1.0, {"offset_y": 2.0})
    >>> float(sim.output("y")[0, 0])
    2.0
    """

    name = "augmented"
    version = "1"

    def __init__(
        self,
        base: str | Model,
        base_config: Mapping[str, Any] | None = None,
        augmentations: Sequence[Mapping[str, Any]] = (),
    ) -> None:
        if isinstance(base, Model):
            if isinstance(base, AugmentedModel):
                raise ConfigError("an augmented model cannot wrap another augmented model")
            if base_config:
                raise ConfigError(
                    "base_config is given with a model instance; configure the instance itself"
                )
            self._base_name = base.name
            self._base_config = dict(base.config())
            self.base = base
        else:
            if base == self.name:
                raise ConfigError("an augmented model cannot wrap another augmented model")
            self._base_name = str(base)
            self._base_config = dict(base_config or {})
            self.base = get_model(self._base_name, **self._base_config)
        self.max_step = self.base.max_step
        augmentations = list(augmentations)
        # missing dynamics of an RC network as an extra heat capacity at a node (fastnet)
        nodal = [s for s in augmentations if isinstance(s, Mapping) and s.get("node")]
        if len(nodal) > 1:
            raise ConfigError("at most one extra node (missing_dynamics with 'node') per model")
        if nodal:
            spec = nodal[0]
            if spec.get("effect") != "missing_dynamics":
                raise ConfigError(f"'node' belongs to missing_dynamics, not {spec.get('effect')!r}")
            self.base = ExtraNodeNetwork(self.base, str(spec["node"]), spec.get("bounds"))
            augmentations = [s for s in augmentations if s is not spec]
        self._nodal = [dict(s) for s in nodal]
        augs: list[_Aug] = []
        for i, spec in enumerate(augmentations):
            if not isinstance(spec, Mapping) or "effect" not in spec:
                raise ConfigError(
                    f"augmentation {i} is {spec!r:.80}; expected a dict with 'effect'"
                )
            augs.append(kind_of(spec)(spec, self.base))
        order = list(AUGMENTATIONS)
        self._augs = sorted(augs, key=lambda a: (_SIDES.index(a.side), order.index(a.effect)))
        self._specs = [dict(a.spec) for a in self._augs]
        params = list(self.base.parameters)
        index = {p.name: i for i, p in enumerate(params)}
        owner: dict[str, str] = {}
        self._nb = len(self.base.parameters)
        self._nx = len(self.base.state_names)
        states = list(self.base.state_names)
        free0 = [True] * self._nx
        self._slices: list[tuple[NDArray[np.int64], slice]] = []
        j = self._nx
        for a in self._augs:
            cols = []
            for prm in a.params:
                if prm.name in index:
                    # a shared parameter: only the same effect with a 'share' tag uses a name twice
                    if owner.get(prm.name) != a.effect or not a.spec.get("share"):
                        raise ConfigError(
                            f"augmentation parameter {prm.name!r} clashes with the base model's "
                            "or appears twice (each effect once per signal, or one 'share' tag)"
                        )
                else:
                    index[prm.name] = len(params)
                    owner[prm.name] = a.effect
                    params.append(prm)
                cols.append(index[prm.name])
            self._slices.append((np.array(cols, dtype=np.int64), slice(j, j + a.n_states)))
            j += a.n_states
            states.extend(a.state_names())
            free0.extend(a.x0_free)
        self._x0_free = np.array(free0, dtype=bool)
        super().__init__(self.base.signals, params, states)

    # ----------------------------------------------------------------- metadata
    @property
    def augmentations(self) -> list[dict[str, Any]]:
        """The augmentation specs, in application order (an extra node first)."""
        return [*(dict(s) for s in self._nodal), *(dict(s) for s in self._specs)]

    @property
    def effects(self) -> tuple[str, ...]:
        """Effects this model adds, wrapped ones first, then the base model's own."""
        own = tuple(getattr(self.base, "effects", ()))
        nodal = ["missing_dynamics"] if self._nodal else []
        return tuple(dict.fromkeys(nodal + [a.effect for a in self._augs] + list(own)))

    @property
    def forms(self) -> list[tuple[str, str, str]]:
        """``(effect, form in words, signal)`` of every augmentation."""
        return [(a.effect, a.describe(), a.signal) for a in self._augs]

    @property
    def n_base_states(self) -> int:
        """Number of the base model's states (they come first)."""
        return self._nx

    @property
    def x0_free(self) -> NDArray[np.bool_]:
        """Per state, whether its initial value may be estimated from data."""
        return self._x0_free.copy()

    @property
    def local_params(self) -> tuple[str, ...]:
        """Parameters fitted per recording (group ``"local"``)."""
        return tuple(p.name for p in self.parameters if p.group == LOCAL)

    @property
    def recorded_params(self) -> tuple[str, ...]:
        """Per-recording values read from the data, never fitted (group ``"recorded"``)."""
        return tuple(p.name for p in self.parameters if p.group == RECORDED)

    def courses(
        self, theta: NDArray[np.float64], n: int, dt: float
    ) -> list[tuple[str, str, NDArray[np.float64]]]:
        """Per-recording courses (a disturbance, a supply's wander) over ``n`` samples.

        Returns
        -------
        list of (effect, signal, ndarray (B, n))
        """
        th = np.atleast_2d(theta)
        t = dt * np.arange(n)[None, :]
        out = []
        for a, (ps, _) in zip(self._augs, self._slices, strict=True):
            c = a.course(th[:, ps], np.repeat(t, th.shape[0], axis=0))
            if c is not None:
                out.append((a.effect, a.signal, np.asarray(c, dtype=float)))
        return out

    def config(self) -> dict[str, Any]:
        """Constructor arguments (stored in FitResults)."""
        return {
            "base": self._base_name,
            "base_config": dict(self._base_config),
            "augmentations": self.augmentations,
        }

    def _validate_theta(self, theta: NDArray[np.float64]) -> None:
        self.base._validate_theta(np.ascontiguousarray(theta[:, : self._nb]))
        for a, (ps, _) in zip(self._augs, self._slices, strict=True):
            for j, prm in enumerate(a.params):
                col = theta[:, ps][:, j]
                if prm.lower >= 0 and (col < 0).any():
                    raise ParameterError(
                        f"parameter {prm.name!r} is {float(col.min())!r}; it must be >= 0"
                    )
                if prm.unit == "s" and prm.lower > 0 and (col <= 0).any():
                    raise ParameterError(
                        f"parameter {prm.name!r} is {float(col.min())!r} s; it must be positive"
                    )

    # ------------------------------------------------------------------ numerics
    def _input_now(self, x, u, theta, dt, entering=None):
        ue = np.array(u, dtype=float, copy=True)
        for i, (a, (ps, ss)) in enumerate(zip(self._augs, self._slices, strict=True)):
            if a.side == "input":
                if entering is not None:
                    entering[i] = ue[:, a.col].copy()
                ue[:, a.col] = a.now(ue[:, a.col], u, theta[:, ps], x[:, ss], dt)
        return ue

    def augment_state(
        self,
        x_base: NDArray[np.float64],
        theta: NDArray[np.float64],
        u0: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Full initial state from a base state: the augmentations start at rest.

        Parameters
        ----------
        x_base : ndarray, shape (B, n_base_states)
        theta : ndarray, shape (B, P)
        u0 : ndarray, shape (B, n_u)
            Exogenous signals at the first sample.

        Returns
        -------
        ndarray, shape (B, n_states)
        """
        th = np.atleast_2d(theta)
        xb = np.atleast_2d(np.asarray(x_base, dtype=float))
        u0 = np.atleast_2d(np.asarray(u0, dtype=float))
        B = max(th.shape[0], xb.shape[0], u0.shape[0])
        th, xb, u0 = (np.broadcast_to(a, (B, *a.shape[1:])) for a in (th, xb, u0))
        x = np.zeros((B, len(self.state_names)))
        x[:, : self._nx] = xb
        # input-side states first (delay history holds u0), then the base output at rest
        for a, (ps, ss) in zip(self._augs, self._slices, strict=True):
            if a.side == "input":
                x[:, ss] = a.init(th[:, ps], u0, np.zeros((B, 0)))
        ue = self._input_now(x, u0, th, None)
        y = self.base._output(np.ascontiguousarray(xb), ue, np.ascontiguousarray(th[:, : self._nb]))
        for a, (ps, ss) in zip(self._augs, self._slices, strict=True):
            if a.side == "loop":
                x[:, ss] = a.init(th[:, ps], u0, y)
        for a, (ps, ss) in zip(self._augs, self._slices, strict=True):
            if a.side in ("plant", "sensor"):
                x[:, ss] = a.init(th[:, ps], u0, y)
                y = y.copy()
                y[:, a.col] = a.now(y[:, a.col], u0, th[:, ps], x[:, ss], 1.0)
        return x

    def initial_state(
        self, theta: NDArray[np.float64], u0: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """The base model's initial state with the augmentations at rest."""
        th = np.atleast_2d(theta)
        xb = self.base.initial_state(np.ascontiguousarray(th[:, : self._nb]), np.atleast_2d(u0))
        return self.augment_state(xb, th, u0)

    def _relax(self, tb, ue, dt, xb, theta, x0, return_states):
        """Base simulation with the loop terms, by accelerated waveform relaxation.

        The fixed point ``y = G(y) = base(u + term(y))`` of each parameter set
        is found by Anderson acceleration (memory :data:`_AA_MEMORY`, Walker &
        Ni 2011): from the last iterates' residuals ``f = G(y) − y`` it mixes
        ``y⁺ = G(y) − ΔG γ`` with ``γ = argmin ‖f − ΔF γ‖``, which for a loop
        that is nearly linear converges in a few passes where plain relaxation
        needs one per decade of accuracy times ``1/ln(1/ρ)``.
        """
        loops = [
            (a, ps, ss)
            for a, (ps, ss) in zip(self._augs, self._slices, strict=True)
            if a.side == "loop"
        ]
        y, xs = self.base._simulate(tb, ue, dt, xb, return_states)
        if not loops:
            return y, xs
        B = tb.shape[0]
        ub = np.broadcast_to(ue, (B, *ue.shape[1:]))
        y = np.array(y, dtype=float, copy=True)
        xs = None if xs is None else np.array(xs, copy=True)
        # The loop terms read only their own output columns: the fixed point is iterated on
        # those (the other outputs follow from them), which keeps the Anderson history small
        # for a model with many outputs (the spindle's 7: 7 times less to copy per pass).
        cols = sorted({a.col for a, _, _ in loops})
        scale = _RELAX_TOL * (1.0 + np.nanmax(np.abs(y[:, :, cols]), axis=(1, 2)))
        active = np.ones(B, dtype=bool)
        L = y.shape[1] * len(cols)
        m = _AA_MEMORY
        hist_f = np.zeros((B, m + 1, L))  # residuals f = G(x) − x of the last iterates
        hist_g = np.zeros((B, m + 1, L))
        n_hist = np.zeros(B, dtype=np.int64)
        x_it = y.copy()  # the iterate the loop terms are computed from
        for _ in range(MAX_RELAXATION):
            idx = np.flatnonzero(active)
            if idx.size == 0:
                break
            u_it = np.array(ub[idx], dtype=float, copy=True)
            x_now = x_it[idx]
            for a, ps, ss in loops:
                u_it[:, :, a.port] += a.term(x_now, ub[idx], theta[idx][:, ps], x0[idx][:, ss], dt)
            bad = ~np.isfinite(u_it).all(axis=(1, 2))
            if bad.any():
                y[idx[bad]] = np.nan
                active[idx[bad]] = False
                idx, u_it, x_now = idx[~bad], u_it[~bad], x_now[~bad]
                if idx.size == 0:
                    break
            g, xs_new = self.base._simulate(
                np.ascontiguousarray(tb[idx]),
                u_it,
                dt,
                np.ascontiguousarray(xb[idx]),
                return_states,
            )
            g = np.asarray(g, dtype=float)
            gl = g[:, :, cols]
            f = gl - x_now[:, :, cols]
            change = np.nanmax(np.abs(f), axis=(1, 2))
            y[idx] = g
            if xs is not None:
                xs[idx] = xs_new
            done = (change <= scale[idx]) | ~np.isfinite(change)
            active[idx[done]] = False
            go = idx[~done]
            if go.size == 0:
                continue
            # Anderson mixing, batched: γ = argmin ‖f − ΔF γ‖ by the small normal equations
            fg, gg = f[~done].reshape(go.size, L), gl[~done].reshape(go.size, L)
            hist_f[go, :-1] = hist_f[go, 1:]
            hist_g[go, :-1] = hist_g[go, 1:]
            hist_f[go, -1], hist_g[go, -1] = fg, gg
            n_hist[go] = np.minimum(n_hist[go] + 1, m + 1)
            k = int(n_hist[go].min())
            nxt = gg
            if k > 1:
                dF = np.diff(hist_f[go, -k:], axis=1)  # (b, k−1, L)
                dG = np.diff(hist_g[go, -k:], axis=1)
                A = np.einsum("bil,bjl->bij", dF, dF)
                rhs = np.einsum("bil,bl->bi", dF, fg)
                reg = 1e-10 * np.trace(A, axis1=1, axis2=2)[:, None, None] + 1e-300
                try:
                    gamma = np.linalg.solve(A + reg * np.eye(k - 1)[None], rhs[..., None])[..., 0]
                    mixed = gg - np.einsum("bil,bi->bl", dG, gamma)
                    nxt = np.where(np.isfinite(mixed).all(axis=1)[:, None], mixed, gg)
                except np.linalg.LinAlgError:
                    nxt = gg
            x_go = g[~done]
            x_go[:, :, cols] = nxt.reshape(go.size, y.shape[1], len(cols))
            x_it[go] = x_go
            if _ + 1 == _PASSES_BEFORE_STEPPING and active.any():
                rest = np.flatnonzero(active)
                stepped = self._stepwise(tb, ue, dt, xb, theta, x0, rest, loops, return_states)
                if stepped is not None:
                    y[rest], xr = stepped
                    if xs is not None:
                        xs[rest] = xr
                    active[rest] = False
        y[active] = np.nan  # did not converge: a failed set
        return y, xs

    def _stepwise(self, tb, ue, dt, xb, theta, x0, idx, loops, return_states):
        """The loop fed back sample by sample with the base model's own step (exact)."""
        B, T = idx.size, ue.shape[1]
        ub = np.broadcast_to(ue, (tb.shape[0], *ue.shape[1:]))[idx]
        th, tbi = theta[idx], np.ascontiguousarray(tb[idx])
        x = np.array(xb[idx], dtype=float, copy=True)
        s = {id(a): np.array(x0[idx][:, ss], copy=True) for a, ps, ss in loops}
        y = np.empty((B, T, len(self.output_names)))
        xs = np.empty((B, T, x.shape[1])) if return_states else None
        try:
            for k in range(T):
                uk = np.ascontiguousarray(ub[:, k])
                yk = self.base._output(x, uk, tbi)
                y[:, k] = yk
                if xs is not None:
                    xs[:, k] = x
                up = uk.copy()
                for a, ps, _ss in loops:
                    up[:, a.port] += a.term_now(yk, uk, th[:, ps], s[id(a)], dt)
                for a, ps, _ss in loops:
                    s[id(a)] = a.advance(yk[:, a.col], uk, th[:, ps], s[id(a)], dt)
                x = self.base._step(x, up, tbi, dt)
        except NotImplementedError:
            return None  # the base model cannot step: relaxation goes on
        return y, xs

    def _simulate(self, theta, u, dt, x0, return_states):
        B, T = theta.shape[0], u.shape[1]
        tb = np.ascontiguousarray(theta[:, : self._nb])
        entering: list[NDArray[np.float64] | None] = [None] * len(self._augs)
        ue = u
        if any(a.side == "input" for a in self._augs):
            ue = np.array(np.broadcast_to(u, (B, *u.shape[1:])), dtype=float, copy=True)
            for i, (a, (ps, ss)) in enumerate(zip(self._augs, self._slices, strict=True)):
                if a.side == "input":
                    if return_states:
                        entering[i] = ue[:, :, a.col].copy()
                    a.apply(ue, u, theta[:, ps], x0[:, ss], dt)
            self.base._exog_batch(ue)  # the transformed inputs must stay finite
        xb = np.ascontiguousarray(x0[:, : self._nx])
        y, xs = self._relax(tb, ue, dt, xb, theta, x0, return_states)
        y = np.array(y, dtype=float, copy=True)
        uu = np.asarray(u)
        ueb = np.broadcast_to(ue, (B, *ue.shape[1:]))
        for i, (a, (ps, ss)) in enumerate(zip(self._augs, self._slices, strict=True)):
            if a.side == "loop" and return_states:
                entering[i] = y[:, :, a.col].copy()
            if a.side in ("plant", "sensor"):
                if return_states:
                    entering[i] = y[:, :, a.col].copy()
                a.apply(y, uu, theta[:, ps], x0[:, ss], dt)
        if not return_states:
            return y, None
        # augmentation states along the trajectory, stepped from the values entering them
        full = np.empty((B, T, len(self.state_names)))
        full[:, :, : self._nx] = xs
        x = np.array(x0, dtype=float, copy=True)
        ub = np.broadcast_to(uu, (B, *uu.shape[1:]))
        for k in range(T):
            full[:, k, self._nx :] = x[:, self._nx :]
            kn = min(k + 1, T - 1)
            for i, (a, (ps, ss)) in enumerate(zip(self._augs, self._slices, strict=True)):
                uk = ueb[:, k] if a.side == "loop" else ub[:, k]
                x[:, ss] = a.advance(
                    entering[i][:, k], uk, theta[:, ps], x[:, ss], dt, entering[i][:, kn]
                )
        return y, full

    def _step(self, x, u, theta, dt):
        th, x, u = (
            np.ascontiguousarray(
                np.broadcast_to(a, (max(len(theta), len(x), len(u)), *a.shape[1:]))
            )
            for a in (theta, x, u)
        )
        if x.shape[1] != len(self.state_names):
            raise ShapeError(f"x has shape {x.shape}, expected (B, {len(self.state_names)})")
        for a, (ps, _) in zip(self._augs, self._slices, strict=True):
            if isinstance(a, _Delay):
                a.check(th[:, ps], dt)
        entering: dict[int, NDArray[np.float64]] = {}
        ue = self._input_now(x, u, th, dt, entering)
        xb = x[:, : self._nx]
        tb = th[:, : self._nb]
        y = self.base._output(xb, ue, tb)
        xn = x.copy()
        u_port = ue.copy()
        for a, (ps, ss) in zip(self._augs, self._slices, strict=True):
            if isinstance(a, _Loop):
                u_port[:, a.port] += a.term_now(y, ue, th[:, ps], x[:, ss], dt)
        xn[:, : self._nx] = self.base._step(xb, u_port, tb, dt)
        for i, (a, (ps, ss)) in enumerate(zip(self._augs, self._slices, strict=True)):
            if a.side == "input":
                xn[:, ss] = a.advance(entering[i], u, th[:, ps], x[:, ss], dt)
            elif a.side == "loop":
                xn[:, ss] = a.advance(y[:, a.col], ue, th[:, ps], x[:, ss], dt)
        # plant and sensor sides: the value entering each augmentation now and at the next
        # sample (a sensor's lag of a continuous signal needs both)
        y_next = self.base._output(
            np.ascontiguousarray(xn[:, : self._nx]), ue, np.ascontiguousarray(tb)
        )
        for a, (ps, ss) in zip(self._augs, self._slices, strict=True):
            if a.side not in ("plant", "sensor"):
                continue
            v, vn = y[:, a.col], y_next[:, a.col]
            xn[:, ss] = a.advance(v, u, th[:, ps], x[:, ss], dt, vn)
            y = y.copy()
            y[:, a.col] = a.now(v, u, th[:, ps], x[:, ss], dt)
            y_next = y_next.copy()
            y_next[:, a.col] = a.now(vn, u, th[:, ps], xn[:, ss], dt)
        return xn

    def _output(self, x, u, theta):
        th, x, u = (
            np.ascontiguousarray(
                np.broadcast_to(a, (max(len(theta), len(x), len(u)), *a.shape[1:]))
            )
            for a in (theta, x, u)
        )
        ue = self._input_now(x, u, th, 1.0)
        y = np.array(self.base._output(x[:, : self._nx], ue, th[:, : self._nb]), copy=True)
        for a, (ps, ss) in zip(self._augs, self._slices, strict=True):
            if a.side in ("plant", "sensor"):
                y[:, a.col] = a.now(y[:, a.col], u, th[:, ps], x[:, ss], 1.0)
        return y


def register() -> None:
    """Register :class:`AugmentedModel` as ``augmented`` in the model registry.

    The registry registers it with the built-in models; this function is kept
    for code that registers explicitly (idempotent).
    """
    if "augmented" not in model_names():  # model_names() loads the built-in models first
        register_model("augmented", AugmentedModel)


#: Read by :mod:`thermogym.models.registry` with the other built-in models.
MODELS: dict[str, type[Model]] = {"augmented": AugmentedModel}
