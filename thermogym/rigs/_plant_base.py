"""Plumbing shared by the machine-tool rigs' true plants (spindle, strut); no plant equations.

:class:`NetworkPlant` is the part of :class:`~thermogym.rigs._spindle_plant.SpindlePlant`
and :class:`~thermogym.rigs._strut_plant.StrutPlant` that is not their physics: the
switches and concealed effects as dictionaries, the segment counts of the
distributed bodies, the per-:class:`~thermogym.rigs.base.Specimens` cache of the
kernel arrays, the rest state, one batched step, the input-level effects
(``transport_delay``, ``unmeasured_disturbance``), the heat balance's totals and
the simulation loop around a compiled kernel. Each plant keeps its geometry, its
network (``_build``) and its kernels; :class:`MachineRig` is the rig side: the rig's
own specimen and :meth:`~MachineRig.with_specimen`. The helpers below build kernel
arrays the same way for both plants (same operations in the same order, so the
plants' numbers are unchanged).

Examples
--------
>>> import numpy as np
>>> link_flags(np.array([0, 1]), np.array([2, 3]), {(1, 3)}).tolist()
[0, 1]
>>> node_totals(np.array([0]), np.array([1]), np.ones((1, 1)), np.array([1]), 2.0,
...             np.zeros((1, 2))).tolist()
[[2.0, 2.0]]
"""

from __future__ import annotations

import math
from abc import abstractmethod
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, ClassVar, Generic, Protocol, Self, TypeVar

import numpy as np
from numpy.typing import NDArray

from thermogym._checks import integer
from thermogym.errors import ConfigError, ShapeError, UnknownNameError
from thermogym.rigs._convection import h_free_cylinder, h_radiation
from thermogym.rigs.base import EffectSpec, PlantRun, Rig, Specimens, TruePlant

__all__ = [
    "MachineRig",
    "NetworkArrays",
    "NetworkPlant",
    "air_coefficients",
    "link_flags",
    "node_totals",
]


class NetworkArrays(Protocol):
    """What :class:`NetworkPlant` reads of a plant's kernel arrays (a frozen dataclass)."""

    @property
    def C(self) -> NDArray[np.float64]:
        """Heat capacities (B, n_nodes) [J/K]."""

    @property
    def rho(self) -> NDArray[np.float64]:
        """Bound of the fastest rate of each specimen (B,) [1/s]."""


ArraysT = TypeVar("ArraysT", bound=NetworkArrays)
PlantT = TypeVar("PlantT", bound=TruePlant)


def link_flags(
    ei: NDArray[np.int64], ej: NDArray[np.int64], pairs: set[tuple[int, int]]
) -> NDArray[np.int64]:
    """1 for each link ``(ei[e], ej[e])`` among ``pairs``, else 0, shape (E,)."""
    return np.array(
        [int((a, b) in pairs) for a, b in zip(ei.tolist(), ej.tolist(), strict=True)],
        dtype=np.int64,
    )


def node_totals(
    ei: NDArray[np.int64],
    ej: NDArray[np.int64],
    eg: NDArray[np.float64],
    eflag: NDArray[np.int64],
    factor: float,
    start: NDArray[np.float64],
) -> NDArray[np.float64]:
    """``start`` (B, nn) plus each node's link conductances, flagged links times ``factor``.

    The Gershgorin sum of an integrator's rate bound; ``start`` is not changed.
    """
    tot = start.copy()
    for e, (a, b) in enumerate(zip(ei.tolist(), ej.tolist(), strict=True)):
        g = eg[:, e] * (factor if eflag[e] else 1.0)
        tot[:, a] += g
        tot[:, b] += g
    return tot


def air_coefficients(
    D: NDArray[np.float64], eps: NDArray[np.float64], dt_design: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Free convection and radiation [W/(m² K)] of each node, linearised at ``dt_design`` [K].

    Free convection of a horizontal cylinder of diameter ``D`` at a rise of
    ``dt_design``; radiation of emissivity ``eps`` between 25 °C ± ``dt_design``/2.
    """
    hnat = np.array([h_free_cylinder(dt_design, d) for d in D])
    hrad = np.array([h_radiation(25.0 + dt_design / 2, 25.0 - dt_design / 2, e) for e in eps])
    return hnat, hrad


class NetworkPlant(TruePlant, Generic[ArraysT]):
    """A true plant whose node network is built per batch of specimens and run compiled.

    Subclasses set the :class:`~thermogym.rigs.base.TruePlant` class attributes,
    :attr:`spread` and :attr:`kernels`, call :meth:`_set_states` in their
    ``__init__``, and implement :meth:`_build` (the kernel arrays),
    :meth:`_kernel_arrays`, :meth:`_flags` and :meth:`_par` (the kernels'
    arguments), ``initial_state``, ``outputs`` and ``hidden``.

    Parameters
    ----------
    off : iterable of str
        Rows of :attr:`extras` to switch off.
    effects : sequence of str or EffectSpec
        Concealed effects of the plant (:attr:`supported_effects`).
    """

    #: The specimen spread: factor -> (low, high, what it multiplies).
    spread: ClassVar[dict[str, tuple[float, float, str]]] = {}
    #: The compiled kernels: the simulation
    #: ``(x0, U, dt, nsub, *arrays, flags, par, y, xs, keep)`` and the heat balance
    #: ``(X, U, *arrays, flags, par, rec, dxdt)`` (arrays: :meth:`_kernel_arrays`).
    kernels: ClassVar[tuple[Any, Any]]
    #: Nodes of the network (the first states).
    n_nodes: int
    n_states: int

    def __init__(
        self, *, off: Iterable[str] = (), effects: Sequence[str | EffectSpec] = ()
    ) -> None:
        super().__init__(off=off, effects=effects)
        #: Switches of the rig's table by name.
        self.physics = dict(self.switches)
        #: Settings of the concealed effects by name.
        self.concealed = {e.name: self.effect(e.name) or {} for e in self.effects}
        self._cache: dict[int, tuple[Any, ArraysT]] = {}

    def _segments(self, switch: str, counts: Mapping[str, tuple[int, int]]) -> tuple[int, ...]:
        """Segment counts: ``{name: (given, coarse)}``, the given ones (checked) or coarse.

        The coarse counts (about the model's resolution) when the row ``switch``
        of the rig's table is off.
        """
        if self.physics[switch]:
            return tuple(integer(k, n, lo=1) for k, (n, _) in counts.items())
        return tuple(c for _, c in counts.values())

    def _set_states(self, names: Iterable[str]) -> None:
        """Set :attr:`state_names` and :attr:`n_states`."""
        self.state_names = tuple(names)  # type: ignore[misc]
        self.n_states = len(self.state_names)

    # ------------------------------------------------------------ kernel arrays
    def arrays(self, specimens: Specimens) -> ArraysT:
        """Kernel arrays for a batch of specimens (cached per Specimens object)."""
        hit = self._cache.get(id(specimens))
        if hit is not None and hit[0] is specimens:
            return hit[1]
        missing = [k for k in self.spread if k not in specimens]
        if missing:
            raise UnknownNameError(
                f"{self.name} specimens lack {missing}; they need {list(self.spread)} "
                f"({type(self).__name__}.nominal)"
            )
        arr = self._build({k: specimens[k] for k in self.spread})
        if len(self._cache) > 8:
            self._cache.clear()
        self._cache[id(specimens)] = (specimens, arr)
        return arr

    @abstractmethod
    def _build(self, sp: dict[str, NDArray[np.float64]]) -> ArraysT:
        """The kernel arrays of specimens ``sp`` (factor name -> (B,))."""

    @abstractmethod
    def _kernel_arrays(self, arr: ArraysT, simulate: bool) -> tuple[Any, ...]:
        """The arguments of the plant's kernels between the inputs and ``flags``.

        Those of the simulation (``simulate``) or of the heat balance.
        """

    @abstractmethod
    def _flags(self) -> NDArray[np.int64]:
        """The kernels' switches (the rig's table, the concealed effects)."""

    @abstractmethod
    def _par(self) -> NDArray[np.float64]:
        """The kernels' scalar parameters."""

    # ------------------------------------------------------------------ contract
    def _rest(self, specimens: Specimens, u0: NDArray[np.float64]) -> NDArray[np.float64]:
        """Every state at the ambient ``u0[..., 1]``, shape (B, n_x)."""
        B = specimens.n
        u0 = np.asarray(u0, dtype=float)
        Ta = np.broadcast_to(u0[..., 1] if u0.ndim else u0, (B,))
        return np.repeat(Ta[:, None], self.n_states, axis=1)

    def step(
        self,
        x: NDArray[np.float64],
        u: NDArray[np.float64],
        dt: float | NDArray[np.float64],
        specimens: Specimens,
    ) -> NDArray[np.float64]:
        """The state (B, n_x) after ``dt`` seconds with ``u`` (B, 2) or (2,) held."""
        B = specimens.n
        d = self.substeps(dt, self.max_step, B)
        if np.any(d != d[0]):
            raise ShapeError(f"the {self.name} plant steps every specimen by the same dt")
        if d[0] == 0.0:
            return np.array(x, dtype=float, copy=True)
        U = np.repeat(np.broadcast_to(np.asarray(u, dtype=float), (B, 2))[:, None], 2, axis=1)
        xs = np.empty((B, 2, self.n_states))
        y = np.empty((B, 2, len(self.output_names)))
        self._kernel(np.asarray(x, dtype=float), U, float(d[0]), specimens, y, xs, True)
        return xs[:, 1].copy()

    def plant_inputs(self, u: NDArray[np.float64], dt: float, t0: float) -> NDArray[np.float64]:
        """The inputs the plant sees: the logged input shifted, the ambient disturbed.

        ``transport_delay``: the log of the manipulated input (column 0) runs
        ``delay`` seconds behind the temperature logger, so the plant moved that
        much earlier than logged. ``unmeasured_disturbance``: an
        air-conditioning cycle in the ambient (column 1) that its sensor does
        not see.
        """
        s = self.effect("transport_delay")
        d = self.effect("unmeasured_disturbance")
        if s is None and d is None:
            return u
        ua = np.array(u, dtype=float, copy=True)
        T = ua.shape[1]
        if s is not None:
            shift = float(s.get("delay", 600.0)) / dt
            k = np.arange(T)
            for b in range(ua.shape[0]):
                ua[b, :, 0] = np.interp(k + shift, k, ua[b, :, 0], right=ua[b, -1, 0])
        if d is not None:
            dd = self.effect_defaults["unmeasured_disturbance"]
            t = t0 + dt * np.arange(T)
            amp = float(d.get("amplitude", dd["amplitude"]))
            per = float(d.get("period", dd["period"]))
            ua[:, :, 1] += amp * np.sin(2 * np.pi * t / per + float(d.get("phase", 0.0)))
        return ua

    def rate_bound(self, specimens: Specimens) -> float:
        """Bound of the fastest rate of the batch [1/s] (Gershgorin)."""
        return float(self.arrays(specimens).rho.max())

    def heat_flows(
        self, x: NDArray[np.float64], u: NDArray[np.float64], specimens: Specimens
    ) -> dict[str, NDArray[np.float64]]:
        """Heat balance at state ``x`` (B, n_x) with inputs ``u`` (B, 2) or (2,).

        Returns
        -------
        dict
            ``source`` (B, n_nodes) heat generated in each node [W]; ``g_air``
            (B, n_nodes) its conductance to the ambient (air, and the bench where
            the plant has one) [W/K]; ``generated`` and ``to_air`` (B,) their
            totals [W]; ``stored`` (B,) ``Σ C dT/dt`` [W]; ``dTdt`` (B, n_nodes)
            each node's rate [K/s].
        """
        arr = self.arrays(specimens)
        B, nn = specimens.n, self.n_nodes
        X = np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), (B, self.n_states)))
        U = np.ascontiguousarray(np.broadcast_to(np.asarray(u, dtype=float), (B, 2)))
        rec = np.zeros((B, 2, nn))
        dxdt = np.zeros((B, self.n_states))
        flows = self.kernels[1]
        flows(X, U, *self._kernel_arrays(arr, False), self._flags(), self._par(), rec, dxdt)
        return {
            "source": rec[:, 0],
            "g_air": rec[:, 1],
            "generated": rec[:, 0].sum(axis=1),
            "to_air": np.sum(rec[:, 1] * (X[:, :nn] - U[:, 1:2]), axis=1),
            "stored": np.sum(arr.C * dxdt[:, :nn], axis=1),
            "dTdt": dxdt[:, :nn].copy(),
        }

    def _simulate(
        self,
        u: NDArray[np.float64],
        dt: float,
        specimens: Specimens,
        x: NDArray[np.float64],
        t0: float,
    ) -> PlantRun:
        B, T, _ = u.shape
        y = np.empty((B, T, len(self.output_names)))
        xs = np.empty((B, T, self.n_states))
        self._kernel(x, u, dt, specimens, y, xs, True)
        hid = self.hidden(xs, specimens)
        t = t0 + dt * np.arange(T, dtype=np.float64)
        return PlantRun(t, u, y, xs, hid, self.output_names)

    def _kernel(
        self,
        x: NDArray[np.float64],
        U: NDArray[np.float64],
        dt: float,
        specimens: Specimens,
        y: NDArray[np.float64],
        xs: NDArray[np.float64],
        keep: bool,
    ) -> None:
        arr = self.arrays(specimens)
        if x.shape != (specimens.n, self.n_states):
            raise ShapeError(f"x has shape {x.shape}, expected ({specimens.n}, {self.n_states})")
        nsub = max(1, math.ceil(dt * float(arr.rho.max())))
        simulate = self.kernels[0]
        simulate(
            np.ascontiguousarray(x), np.ascontiguousarray(U), float(dt), nsub,
            *self._kernel_arrays(arr, True), self._flags(), self._par(), y, xs, keep,
        )  # fmt: skip


class MachineRig(Rig, Generic[PlantT]):
    """A rig around a :class:`NetworkPlant` (``PlantT``) holding one specimen from its spread.

    Parameters
    ----------
    effects : sequence of str or EffectSpec
        Concealed effects (``NAME[:k=v,...]``, see the rig's module docstring).
    off : iterable of str
        Rows of the plant's table to switch off.
    """

    #: Seed of the rig's own specimen.
    specimen_seed: ClassVar[int] = 0
    #: Signals the rig records (a sensor effect must name one of them).
    recorded: ClassVar[tuple[str, ...]] = ()
    #: What the rig is not, for the message on unknown specimen factors.
    not_model: ClassVar[str] = "the rig is not the model: it has no model parameters"

    def __init__(
        self, effects: Sequence[str | EffectSpec] = (), *, off: Iterable[str] = ()
    ) -> None:
        super().__init__(effects, off=off)
        self.check_sensor_effects(self.recorded)

    def plant(self) -> PlantT:
        """The true plant with this rig's plant effects and switches."""
        return super().plant()  # type: ignore[return-value]

    @property
    def specimen(self) -> Specimens:
        """The rig's specimen: drawn from the plant's spread with :attr:`specimen_seed`.

        Unless :meth:`with_specimen` set another.
        """
        if self._specimen is None:
            rng = np.random.default_rng(self.specimen_seed)
            self._specimen = self.plant().draw_specimens(rng, 1)
        return self._specimen

    def with_specimen(self, values: Mapping[str, float] | Specimens | str) -> Self:
        """A copy with another specimen: ``"nominal"``, a :class:`Specimens` of one, or factors.

        Factors (names of the plant's spread) left out keep this rig's values.
        """
        if isinstance(values, str):
            if values != "nominal":
                raise ConfigError(f"specimen {values!r}; expected 'nominal', a dict or Specimens")
            values = self.plant().nominal(1)
        elif not isinstance(values, Specimens):
            spread = getattr(self.plant_cls, "spread", {})
            bad = [k for k in values if k not in spread]
            if bad:
                raise UnknownNameError(
                    f"{self.name} specimen factor(s) {bad} unknown; factors are {list(spread)} "
                    f"({self.not_model})"
                )
        return super().with_specimen(values)  # type: ignore[return-value]
