"""Engine base of the machine-tool environments (spindle, strut): linear thermal plants.

The spindle and strut plants are linear in their states and inputs (thermal
RC networks, eq 13 of ``000_24627a5308ee07db.txt``, or the N4SID state space
of ``001_6d13a2cd04f5de5e.txt`` eq 3), so one control period is an exact
zero-order-hold update::

    x[k+1] = A_d x[k] + B_d u[k],     y[k] = H x[k] + D u[k] + h_0

with ``(A_d, B_d)`` from :meth:`ThermalNetworkModel.discrete` (matrix
exponential) or from the state-space matrices raised to the control period.
The step kernels do this update in compiled code; the matrices are computed
once per parameter set.

A network with nonlinear effects (a FitResult of a model with
``input_nonlinearity``, ``input_dependent_heat_transfer``,
``nonlinear_heat_transfer``, ``time_varying_parameter``) is advanced instead
by the network's own compiled fixed-step RK4 kernel
(:meth:`thermogym.models.thermal_network.ThermalNetworkModel.integrate`) before the step kernel
measures and rewards.

With ``plant="rig"`` (:func:`network_plant`) the engine steps the rig's true
plant (:class:`thermogym.rigs.base.TruePlant`: the strut's or the spindle's,
written apart from the models, one specimen) for all active plants at once,
and its state holds the rig's noise-free outputs, which the step kernel
measures with the rig's sensors (white noise, quantisation, the sensor
offsets and drifts of its effects). The nominal model only lends its signal
names; it does not run.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray

from thermogym.envs._base import C_K, Engine
from thermogym.envs._plant import ParamsLike, Plant, resolve_plant
from thermogym.errors import ConfigError
from thermogym.models.linear import StateSpaceModel
from thermogym.models.lti import lti_output, lti_update
from thermogym.models.thermal_network import ThermalNetworkModel

__all__ = ["LTIEngine", "lti_output", "lti_step", "network_plant"]


def network_plant(
    env: str,
    *,
    params: ParamsLike,
    plant: str,
    models: Sequence[str],
    default: Any,
    rig: str,
    rig_effects: Sequence[Any],
    stepwise_effects: Sequence[str],
    specimen_seed: int | None = None,
) -> Plant:
    """The plant of a machine-tool environment (:func:`~thermogym.envs._plant.resolve_plant`).

    With ``plant="rig"`` the returned :class:`Plant` carries the rig, its true
    plant and its specimen: the rig's own strut or spindle, or one drawn from
    its spread with ``specimen_seed``; its ``model`` is the nominal model
    (names only).
    """
    specimen = None
    if plant == "rig" and specimen_seed is not None:
        if isinstance(specimen_seed, bool) or not isinstance(specimen_seed, int | np.integer):
            raise ConfigError(f"{env}: specimen_seed is {specimen_seed!r}; expected an integer")
        from thermogym.rigs import get_rig  # the rigs (~0.4 s) load only for plant='rig'

        r = get_rig(rig)
        specimen = r.plant().draw_specimens(np.random.default_rng(int(specimen_seed)), 1)
    return resolve_plant(
        env, params=params, plant=plant, models=models, default=default, rig=rig,
        rig_effects=rig_effects, stepwise_effects=stepwise_effects, specimen=specimen,
    )  # fmt: skip


@nb.njit(cache=True, inline="always")
def lti_step(x, u, At, Bt, tmp):  # pragma: no cover - numba
    """``x ← A_d x + B_d u`` for one plant in place (transposed matrices).

    :func:`thermogym.models.lti.lti_update`; ``tmp`` is scratch of length n.
    """
    lti_update(At, Bt, x, u, tmp)
    for i in range(x.shape[0]):
        x[i] = tmp[i]


class LTIEngine(Engine):
    """Engine of a linear thermal plant; subclasses add actions, KPIs and rewards.

    Parameters
    ----------
    B : int
    plant : Plant
    outputs : sequence of str
        Model outputs the environment needs, in kernel order.
    inputs : tuple of (str, str)
        Names of the manipulated input and of the ambient disturbance.
    dt : float
        Control period [s].
    n_acc : int
        Accumulator floats per plant.
    """

    def __init__(
        self,
        B: int,
        plant: Plant,
        outputs: Sequence[str],
        inputs: tuple[str, str],
        dt: float,
        n_acc: int,
    ) -> None:
        super().__init__(B, plant, n_acc)
        m = plant.model
        self._dt_ctrl = float(dt)
        #: The rig's true plant (``plant="rig"``) or None; its state is :attr:`xr`.
        self.rig_plant: Any = getattr(plant, "true_plant", None) if plant.kind == "rig" else None
        missing = [o for o in outputs if o not in m.output_names]
        if missing:
            raise ConfigError(
                f"{self.name}: the model {m.name!r} lacks output(s) {missing}; it has "
                f"{list(m.output_names)}"
            )
        self.oidx = np.array([m.output_names.index(o) for o in outputs], dtype=np.int64)
        exo = list(m.exogenous_names)
        if inputs[0] not in exo:
            raise ConfigError(
                f"{self.name}: the model {m.name!r} has no input {inputs[0]!r}; exogenous "
                f"signals are {exo}"
            )
        # a model without the ambient input predicts rises above ambient (prepared data)
        self.ambient_added = inputs[1] not in exo
        self.uidx = np.array(
            [exo.index(inputs[0]), -1 if self.ambient_added else exo.index(inputs[1])],
            dtype=np.int64,
        )
        if len(exo) != 2 - int(self.ambient_added):
            raise ConfigError(
                f"{self.name}: the model {m.name!r} has exogenous signals {exo}; expected "
                f"{list(inputs)}"
            )
        nx = len(m.state_names)
        ny = len(outputs)
        if self.rig_plant is not None:
            rp = self.rig_plant
            missing = [o for o in outputs if o not in rp.output_names]
            if missing:
                raise ConfigError(f"{self.name}: the rig's plant lacks output(s) {missing}")
            # the engine's state holds the rig's outputs (identity output map)
            self.rig_oidx = np.array([rp.output_names.index(o) for o in outputs], dtype=np.int64)
            self.xr = np.zeros((B, len(rp.state_names)))
            self._rig_spec = plant.specimens  # type: ignore[attr-defined]
            self._rig_specs: dict[int, Any] = {}
            nx = ny
        self.x = np.zeros((B, nx))
        # the plant's discrete matrices, transposed (the layout of thermogym.models.lti)
        self.At = np.zeros((B, nx, nx))
        self.Bt = np.zeros((B, 2, nx))
        self.Ct = np.zeros((B, nx, ny))
        self.Dt = np.zeros((B, 2, ny))
        self.h0 = np.zeros((B, ny))
        self.linear = np.ones(B, dtype=np.bool_)
        self.all_linear = True
        self.scratch = np.zeros((B, 2 + nx))  # per plant: u (2), then x scratch (n)
        self._nets: dict[int, Any] = {}
        self._ss_steps = 1  # model samples per control period (a state-space model)
        if isinstance(m, StateSpaceModel):
            if m.dt is None:
                raise ConfigError(
                    f"{self.name}: the state-space model has no sample period (dt is None); "
                    f"the environment steps it every control_period {self._dt_ctrl} s, so it "
                    "needs a discrete model with its dt"
                )
            r = self._dt_ctrl / m.dt
            if abs(r - round(r)) > 1e-9 or round(r) < 1:
                raise ConfigError(
                    f"{self.name}: control_period {self._dt_ctrl} s is not a whole multiple of "
                    f"the state-space model's sample period {m.dt} s"
                )
            self._ss_steps = round(r)
        elif not isinstance(m, ThermalNetworkModel):
            raise ConfigError(f"{self.name}: model {m.name!r} is not a linear thermal model")

    def _set_theta_row(self, b: int, theta: NDArray[np.float64]) -> None:
        m = self.model
        if self.rig_plant is not None:
            # the rig's outputs are the state: y = x, advanced by the rig, not by (A_d, B_d)
            n = self.x.shape[1]
            self.linear[b] = False
            self.At[b] = np.eye(n)
            self.Bt[b] = 0.0
            self.Ct[b] = np.eye(n)
            self.Dt[b] = 0.0
            self.h0[b] = 0.0
            self.all_linear = False
            return
        if isinstance(m, StateSpaceModel):
            mats = m.matrices(theta)
            A, Bm, C, D = mats.A[0], mats.B[0], mats.C[0], mats.D[0]
            steps = self._ss_steps
            Ad = np.linalg.matrix_power(A, steps)
            Bd = sum((np.linalg.matrix_power(A, i) for i in range(steps)), np.zeros_like(A)) @ Bm
            H, h0 = C, np.zeros(C.shape[0])
            self.linear[b] = True
        else:
            full = m.full_theta(theta)  # type: ignore[attr-defined]
            self.linear[b] = m.is_linear(full)  # type: ignore[attr-defined]
            net = m.network(full)  # type: ignore[attr-defined]
            H, h0, D = net.H, net.h0[0], np.zeros((net.H.shape[0], 2))
            if self.linear[b]:
                Ad3, Bd3, _ = m.discrete(theta, self._dt_ctrl)  # type: ignore[attr-defined]
                Ad, Bd = Ad3[0], Bd3[0]
            else:
                Ad, Bd = np.eye(len(m.state_names)), np.zeros((len(m.state_names), 2))
                self._nets[b] = (
                    net,
                    m.effect_values(full),  # type: ignore[attr-defined]
                    m.rk4_substeps(net, self._dt_ctrl, self.u_max),  # type: ignore[attr-defined]
                )
        for j, col in enumerate(self.uidx):
            if col >= 0:
                self.Bt[b, j] = Bd[:, col]
                self.Dt[b, j] = D[self.oidx, col]
            else:
                self.Bt[b, j] = 0.0
                self.Dt[b, j] = 1.0  # outputs are rises: add the ambient
        self.At[b] = Ad.T
        self.Ct[b] = H[self.oidx].T
        self.h0[b] = h0[self.oidx]
        self.all_linear = bool(self.linear.all())

    #: Largest manipulated input (bounds the RK4 step of a nonlinear network).
    u_max: float = 1.0

    def _rig_specimens(self, n: int) -> Any:
        sp = self._rig_specs.get(n)
        if sp is None:
            sp = self._rig_specs[n] = self._rig_spec.take(np.zeros(n, dtype=np.int64))
        return sp

    def rest_state(self, b: int, u0: NDArray[np.float64]) -> NDArray[np.float64]:
        """Steady state for constant exogenous ``u0 = [input, ambient]``."""
        if self.rig_plant is not None:
            rp, sp = self.rig_plant, self._rig_specimens(1)
            x = rp.initial_state(sp, np.asarray(u0, dtype=float))
            if u0[0] > 0.0:  # warm: two days at the input from rest (steady within them)
                x = rp.simulate(np.tile(u0, (49, 1)), 3600.0, sp, x0=x).states[:, -1]
            self.xr[b] = x[0]
            return rp.outputs(x, u0, sp)[0, self.rig_oidx]
        if not self.linear[b]:
            # a network at rest: every node at the air temperature
            return np.full(self.x.shape[1], float(u0[1]))
        n = self.x.shape[1]
        return np.linalg.solve(np.eye(n) - self.At[b].T, self.Bt[b].T @ u0)

    def advance_nonlinear(self, u: NDArray[np.float64]) -> None:
        """RK4 step of the active plants whose network is nonlinear (``u``: (B, 2))."""
        if self.rig_plant is not None:
            rows = np.flatnonzero(self.active)
            if rows.size == 0:
                return
            rp, sp = self.rig_plant, self._rig_specimens(rows.size)
            xr = rp.step(self.xr[rows], u[rows], self._dt_ctrl, sp)
            self.xr[rows] = xr
            self.x[rows] = rp.outputs(xr, u[rows], sp)[:, self.rig_oidx]
            return
        for b in np.flatnonzero(self.active & ~self.linear):
            net, eff, nsub = self._nets[int(b)]
            m = self.model
            U = np.empty((1, 2, 2))
            U[0, :, 0] = u[b, 0]
            U[0, :, 1] = u[b, 1]
            _, xs = m.integrate(  # type: ignore[attr-defined]
                net, eff, self.x[b : b + 1], U, self._dt_ctrl, int(nsub),
                t0=float(self.ctr[b, C_K] * self._dt_ctrl), return_states=True,
            )  # fmt: skip
            self.x[b] = xs[0, 1]
