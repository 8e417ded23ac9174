"""Virtual test rigs: true plants written apart from the models, protocols and sensors.

A rig stands in for a device that has no public recordings. It has three parts:

* a **true plant** (:class:`TruePlant`): the rig's own physics, written in the
  rig module and never taken from :mod:`thermogym.models` (a rig may share
  signal names and units with a model, so its recordings carry the model's
  column names, but never a model's equations, kernels or parameter tables).
  It is richer than the identified model; each thing it has that the model
  lacks is a row of the rig's table (:class:`ExtraPhysics`) with its physical
  source, its size and an on/off switch. Its physical parameters
  (:class:`PhysicalParameter`) carry the manufacturing spread from which
  specimens are drawn (:class:`Specimens`). Batched over B specimens::

      specimens = plant.draw_specimens(rng, n)       # or plant.nominal(n)
      x = plant.initial_state(specimens, u0)          # (B, n_x)
      x = plant.step(x, u, dt, specimens)            # fixed internal sub-steps
      y = plant.outputs(x, u, specimens)             # (B, n_y), noise-free
      h = plant.hidden(x, specimens)                 # truths no sensor records
      run = plant.simulate(u, dt, specimens, x0=None, t0=0.0)

* **sensors** (:mod:`thermogym.rigs.sensors`): white and coloured noise,
  quantisation, lags, spikes and dropouts of the papers' hardware;
* **protocols** (:class:`Protocol`): the papers' experiments, returning
  :class:`RigRun` objects that :func:`thermogym.rigs.to_recording` turns into
  recordings.

Concealed effects (``effects``, names of :data:`EFFECT_NAMES`) are written in
the rig's own physics (a plant parameter or switch, an input the sensors do
not see, a sensor fault); they are never borrowed from the diagnosis'
augmentations, and recorded metadata never names them.
"""

from __future__ import annotations

import inspect
import math
import re
import textwrap
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from thermogym._checks import nonnegative, positive
from thermogym.errors import ConfigError, ParameterError, ShapeError, UnknownNameError
from thermogym.rigs.sensors import Sensor
from thermogym.vocabulary import EFFECT_NAMES

__all__ = [
    "EFFECT_NAMES",
    "EffectSpec",
    "ExtraPhysics",
    "PhysicalParameter",
    "PlantRun",
    "Protocol",
    "Rig",
    "RigRun",
    "Specimens",
    "TruePlant",
    "Turns",
    "extras_table",
    "first_order_lag",
    "parse_effect",
]

#: Effects that act on a sensor rather than on the plant (applied by :meth:`Rig.sensor`).
SENSOR_EFFECTS = ("sensor_lag", "sensor_offset", "sensor_drift")


# ------------------------------------------------------------------------ effects
@dataclass(frozen=True)
class EffectSpec:
    """An effect to include in a rig: vocabulary name and keyword settings.

    Parameters
    ----------
    name : str
        One of :data:`EFFECT_NAMES`.
    params : mapping
        Settings, e.g. ``{"tau": 60.0, "signal": "T_P"}``.
    """

    name: str
    params: Mapping[str, Any] = field(default_factory=dict)


def _value(text: str) -> Any:
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def parse_effect(spec: str | EffectSpec) -> EffectSpec:
    """Parse ``NAME[:k=v,...]`` into an :class:`EffectSpec`.

    Examples
    --------
    >>> parse_effect("sensor_lag:tau=60,signal=T_P")
    EffectSpec(name='sensor_lag', params={'tau': 60, 'signal': 'T_P'})
    """
    if isinstance(spec, EffectSpec):
        return spec
    name, _, rest = spec.partition(":")
    name = name.strip()
    if name not in EFFECT_NAMES:
        raise UnknownNameError(f"unknown effect {name!r}; the vocabulary is {list(EFFECT_NAMES)}")
    params: dict[str, Any] = {}
    for item in filter(None, (s.strip() for s in rest.split(","))):
        if not re.match(r"^[A-Za-z_][A-Za-z0-9_]*=.+$", item):
            raise ConfigError(f"effect setting {item!r} in {spec!r} is not of the form key=value")
        k, v = item.split("=", 1)
        params[k] = _value(v)
    return EffectSpec(name, params)


# ---------------------------------------------------------------- the rig's tables
@dataclass(frozen=True)
class ExtraPhysics:
    """One row of a rig's table: physics the rig has and the identified model lacks.

    Parameters
    ----------
    name : str
        Switch name (``TruePlant(off=[name])`` switches it off).
    what : str
        The physics, in a sentence.
    source : str
        Its physical source: a paper section, a handbook correlation, a datasheet figure.
    size : str
        How large it is, with numbers.
    off : str
        What the plant does when it is switched off.
    """

    name: str
    what: str
    source: str
    size: str
    off: str


@dataclass(frozen=True)
class PhysicalParameter:
    """A physical parameter of a true plant, with its manufacturing spread.

    Parameters
    ----------
    name : str
    nominal : float
        Value of the nominal specimen.
    unit : str
    description : str
    source : str
        Provenance of the nominal value.
    spread : float
        Size of the spread: relative standard deviation (``kind="relative"``),
        absolute standard deviation (``"absolute"``) or half-width of a uniform
        draw (``"uniform"``); 0: the same on every specimen.
    kind : {"relative", "absolute", "uniform"}
    spread_source : str
        Provenance of the spread.
    lower, upper : float
        Physical limits; draws are clipped to them.
    """

    name: str
    nominal: float
    unit: str
    description: str
    source: str
    spread: float = 0.0
    kind: str = "relative"
    spread_source: str = ""
    lower: float = -np.inf
    upper: float = np.inf

    def draw(self, rng: np.random.Generator, n: int) -> NDArray[np.float64]:
        """``n`` values from the spread (one standard normal or uniform each, always drawn)."""
        if self.kind == "uniform":
            z = rng.uniform(-1.0, 1.0, n)
            v = self.nominal + self.spread * z
        else:
            z = rng.standard_normal(n)
            if self.kind == "relative":
                v = self.nominal * (1.0 + self.spread * z)
            elif self.kind == "absolute":
                v = self.nominal + self.spread * z
            else:
                raise ConfigError(
                    f"parameter {self.name!r}: spread kind {self.kind!r}; expected 'relative', "
                    "'absolute' or 'uniform'"
                )
        return np.clip(v, self.lower, self.upper)


class Specimens:
    """Physical parameters of B specimens of a true plant: name -> array of shape (B,).

    Parameters
    ----------
    values : mapping of str to array_like
        One value (broadcast) or B values per parameter.

    Examples
    --------
    >>> s = Specimens({"C": [1.0, 2.0], "G": 0.5})
    >>> s.n, s["G"].tolist()
    (2, [0.5, 0.5])
    >>> s.take([1]).to_dicts()
    [{'C': 2.0, 'G': 0.5}]
    """

    def __init__(self, values: Mapping[str, ArrayLike]) -> None:
        arrays = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in values.items()}
        sizes = {a.size for a in arrays.values()}
        n = max(sizes) if sizes else 1
        bad = [k for k, a in arrays.items() if a.ndim != 1 or a.size not in (1, n)]
        if bad:
            raise ShapeError(
                f"specimen values {bad} have shapes {[arrays[k].shape for k in bad]}; expected "
                f"(1,) or ({n},)"
            )
        self._v = {k: np.broadcast_to(a, (n,)).copy() for k, a in arrays.items()}
        self.n = n

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names."""
        return tuple(self._v)

    def __getitem__(self, name: str) -> NDArray[np.float64]:
        try:
            return self._v[name]
        except KeyError:
            raise UnknownNameError(
                f"no specimen parameter {name!r}; parameters are {list(self._v)}"
            ) from None

    def __contains__(self, name: object) -> bool:
        return name in self._v

    def __len__(self) -> int:
        return self.n

    def __repr__(self) -> str:
        return f"Specimens(n={self.n}, names={list(self._v)})"

    def take(self, idx: Sequence[int] | NDArray[np.int64] | int) -> Specimens:
        """The specimens at ``idx`` (an index keeps a batch of one)."""
        i = np.atleast_1d(np.asarray(idx, dtype=np.int64))
        return Specimens({k: v[i] for k, v in self._v.items()})

    def replace(self, values: Mapping[str, ArrayLike]) -> Specimens:
        """A copy with some parameters replaced (unknown names raise)."""
        unknown = [k for k in values if k not in self._v]
        if unknown:
            raise UnknownNameError(
                f"no specimen parameter(s) {unknown}; parameters are {list(self._v)}"
            )
        return Specimens({**self._v, **{k: np.asarray(v, dtype=float) for k, v in values.items()}})

    def array(self, names: Sequence[str]) -> NDArray[np.float64]:
        """Values of ``names`` as a (B, len(names)) array (kernel layout)."""
        return np.ascontiguousarray(np.column_stack([self[k] for k in names]))

    def to_dicts(self) -> list[dict[str, float]]:
        """One ``{name: value}`` per specimen."""
        return [{k: float(v[i]) for k, v in self._v.items()} for i in range(self.n)]

    @classmethod
    def stack(cls, items: Sequence[Specimens]) -> Specimens:
        """Concatenate batches of specimens of the same plant."""
        names = items[0].names
        return cls({k: np.concatenate([s[k] for s in items]) for k in names})


def extras_table(extras: Sequence[ExtraPhysics], width: int = 92) -> str:
    """A rig's table as a numpydoc definition list (for module docstrings and reports).

    Examples
    --------
    >>> print(extras_table([ExtraPhysics("lag", "a lag", "datasheet", "3 s", "none")]))
    lag
        a lag. Source: datasheet. Size: 3 s. Off: none.
    """
    out = []
    for e in extras:
        text = f"{e.what}. Source: {e.source}. Size: {e.size}. Off: {e.off}."
        out.append(e.name)
        out.extend(textwrap.wrap(text, width, initial_indent="    ", subsequent_indent="    "))
    return "\n".join(out)


# --------------------------------------------------------------------- true plants
@dataclass
class PlantRun:
    """A simulation of a true plant on a uniform grid.

    Attributes
    ----------
    time : ndarray, shape (T,)
    inputs : ndarray, shape (B, T, n_u)
        The exogenous signals the plant saw (after input-level effects).
    outputs : ndarray, shape (B, T, n_y)
        Noise-free outputs at the sensors' locations.
    states : ndarray, shape (B, T, n_x)
    hidden : dict of str to ndarray (B, T)
        Truths no sensor records.
    output_names : tuple of str
    """

    time: NDArray[np.float64]
    inputs: NDArray[np.float64]
    outputs: NDArray[np.float64]
    states: NDArray[np.float64]
    hidden: dict[str, NDArray[np.float64]]
    output_names: tuple[str, ...]

    def output(self, name: str) -> NDArray[np.float64]:
        """One output, shape (B, T)."""
        try:
            return self.outputs[..., self.output_names.index(name)]
        except ValueError:
            raise UnknownNameError(
                f"no output {name!r}; outputs are {list(self.output_names)}"
            ) from None


class TruePlant(ABC):
    """The physics of a rig, batched over specimens (subclass per rig).

    Subclasses set the class attributes and implement :meth:`initial_state`,
    :meth:`step`, :meth:`outputs` and :meth:`hidden`; :meth:`simulate` steps
    sample by sample unless a subclass provides a faster loop.

    Parameters
    ----------
    off : iterable of str
        Names of :attr:`extras` to switch off.
    effects : sequence of str or EffectSpec
        Concealed effects of the plant (those in :attr:`supported_effects`);
        sensor effects are the rig's business, not the plant's.
    """

    name: ClassVar[str] = "plant"
    #: Exogenous inputs, in column order of ``u`` (recording column names).
    input_names: ClassVar[tuple[str, ...]] = ()
    #: Noise-free outputs at the sensors' locations (recording column names).
    output_names: ClassVar[tuple[str, ...]] = ()
    #: Truths no sensor records (for virtual-sensor checks and KPIs).
    hidden_names: ClassVar[tuple[str, ...]] = ()
    state_names: ClassVar[tuple[str, ...]] = ()
    units: ClassVar[dict[str, str]] = {}
    #: Longest internal sub-step [s] (fixed steps: a sample of dt takes ceil(dt / max_step)).
    max_step: ClassVar[float] = 1.0
    #: Physical parameters with their spread.
    parameters: ClassVar[tuple[PhysicalParameter, ...]] = ()
    #: The rig's table: what it has that the identified model lacks.
    extras: ClassVar[tuple[ExtraPhysics, ...]] = ()
    #: Concealed effects the plant's physics can carry.
    supported_effects: ClassVar[tuple[str, ...]] = ()
    #: Default settings of the effects.
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {}

    def __init__(
        self, *, off: Iterable[str] = (), effects: Sequence[str | EffectSpec] = ()
    ) -> None:
        off = tuple(off)
        names = [e.name for e in self.extras]
        unknown = [n for n in off if n not in names]
        if unknown:
            raise UnknownNameError(
                f"{self.name}: no extra physics {unknown} to switch off; the table has {names}"
            )
        self.switches: dict[str, bool] = {n: n not in off for n in names}
        self.effects = tuple(parse_effect(e) for e in effects)
        bad = [e.name for e in self.effects if e.name not in self.supported_effects]
        if bad:
            raise UnknownNameError(
                f"true plant {self.name!r} cannot carry effect(s) {bad}; it supports "
                f"{list(self.supported_effects)}"
            )

    # ---- switches and effects
    def is_on(self, name: str) -> bool:
        """Whether extra physics ``name`` is switched on."""
        try:
            return self.switches[name]
        except KeyError:
            raise UnknownNameError(
                f"{self.name}: no extra physics {name!r}; the table has {list(self.switches)}"
            ) from None

    def effect(self, name: str) -> dict[str, Any] | None:
        """Settings of concealed effect ``name`` over its defaults, or None when absent."""
        for e in self.effects:
            if e.name == name:
                return {**self.effect_defaults.get(name, {}), **e.params}
        return None

    # ---- specimens
    @classmethod
    def parameter_names(cls) -> tuple[str, ...]:
        """Names of the physical parameters, in kernel order."""
        return tuple(p.name for p in cls.parameters)

    def nominal(self, n: int = 1) -> Specimens:
        """``n`` copies of the nominal specimen."""
        return Specimens({p.name: np.full(n, p.nominal) for p in self.parameters})

    def draw_specimens(self, rng: np.random.Generator, n: int) -> Specimens:
        """``n`` specimens drawn from the spread of :attr:`parameters`.

        Every parameter draws ``n`` numbers in table order, whatever its spread,
        so that a change of one spread leaves the others' draws unchanged.
        """
        return Specimens({p.name: p.draw(rng, int(n)) for p in self.parameters})

    # ---- dynamics
    @abstractmethod
    def initial_state(self, specimens: Specimens, u0: NDArray[np.float64]) -> NDArray[np.float64]:
        """Rest state for the exogenous values ``u0`` (B, n_u) or (n_u,); shape (B, n_x)."""

    @abstractmethod
    def step(
        self,
        x: NDArray[np.float64],
        u: NDArray[np.float64],
        dt: float | NDArray[np.float64],
        specimens: Specimens,
    ) -> NDArray[np.float64]:
        """The state after ``dt`` seconds (a scalar or one per specimen) with ``u`` held."""

    @abstractmethod
    def outputs(
        self, x: NDArray[np.float64], u: NDArray[np.float64], specimens: Specimens
    ) -> NDArray[np.float64]:
        """Noise-free outputs (B, n_y) in state ``x`` with inputs ``u``."""

    @abstractmethod
    def hidden(
        self, x: NDArray[np.float64], specimens: Specimens
    ) -> dict[str, NDArray[np.float64]]:
        """Truths no sensor records, each of shape (B,)."""

    def plant_inputs(self, u: NDArray[np.float64], dt: float, t0: float) -> NDArray[np.float64]:
        """The inputs the plant sees, from those given (input-level effects; default: the same).

        Parameters
        ----------
        u : ndarray, shape (B, T, n_u)
        dt, t0 : float
            Sample period and time of the first sample [s].
        """
        return u

    def simulate(
        self,
        u: ArrayLike,
        dt: float,
        specimens: Specimens,
        x0: NDArray[np.float64] | None = None,
        t0: float = 0.0,
    ) -> PlantRun:
        """Simulate B specimens on a uniform grid.

        Parameters
        ----------
        u : array_like, shape (T, n_u) or (B, T, n_u)
            Exogenous signals (shared by every specimen, or one set each), held
            over each sample period.
        dt : float
            Sample period [s].
        specimens : Specimens
        x0 : ndarray, shape (B, n_x), optional
            Initial state (default :meth:`initial_state` for the first inputs).
        t0 : float
            Time of the first sample [s].

        Returns
        -------
        PlantRun
        """
        ua = self._batch_inputs(u, specimens.n)
        dt = positive("dt", dt, unit="s")
        ua = self.plant_inputs(ua, dt, t0)
        B = ua.shape[0]
        x = self.initial_state(specimens, ua[:, 0]) if x0 is None else np.array(x0, dtype=float)
        if x.shape != (B, len(self.state_names)):
            raise ShapeError(f"x0 has shape {x.shape}, expected ({B}, {len(self.state_names)})")
        return self._simulate(ua, dt, specimens, x, t0)

    def _simulate(
        self,
        u: NDArray[np.float64],
        dt: float,
        specimens: Specimens,
        x: NDArray[np.float64],
        t0: float,
    ) -> PlantRun:
        # generic loop: one batched step per sample
        B, T, _ = u.shape
        ys = np.empty((B, T, len(self.output_names)))
        xs = np.empty((B, T, len(self.state_names)))
        hid = {k: np.empty((B, T)) for k in self.hidden_names}
        for k in range(T):
            xs[:, k] = x
            ys[:, k] = self.outputs(x, u[:, k], specimens)
            for name, v in self.hidden(x, specimens).items():
                hid[name][:, k] = v
            if k + 1 < T:
                x = self.step(x, u[:, k], dt, specimens)
        return PlantRun(t0 + dt * np.arange(T, dtype=np.float64), u, ys, xs, hid, self.output_names)

    def _batch_inputs(self, u: ArrayLike, n: int) -> NDArray[np.float64]:
        ua = np.asarray(u, dtype=float)
        m = len(self.input_names)
        if ua.ndim == 2:
            ua = np.broadcast_to(ua[None], (n, *ua.shape))
        if ua.ndim != 3 or ua.shape[0] != n or ua.shape[2] != m:
            raise ShapeError(
                f"u has shape {np.shape(u)}; expected (T, {m}) or ({n}, T, {m}) with columns "
                f"{list(self.input_names)}"
            )
        if not np.isfinite(ua).all():
            raise ShapeError("u has non-finite values")
        return np.ascontiguousarray(ua)

    @staticmethod
    def substeps(dt: float | NDArray[np.float64], max_step: float, n: int) -> NDArray[np.float64]:
        """``dt`` as one non-negative value per specimen (checked)."""
        d = np.broadcast_to(np.asarray(dt, dtype=float), (n,))
        if not np.all(np.isfinite(d)) or np.any(d < 0):
            raise ShapeError(f"dt = {d.tolist()!r} s, expected finite values >= 0")
        return np.ascontiguousarray(d)


class Turns:
    """The turns of one state of every specimen over the sub-steps of a true plant's steps.

    A true plant whose ``step`` takes ``turns=`` notes there, in time order, every value of
    state ``column`` after one of its integration sub-steps that does not lie strictly
    between the values before and after it: the local maxima and minima of the sub-step
    series (and the points of a plateau). The series starts at :meth:`start` (that first
    value is the caller's; so is the last, the state after the last step), and may run over
    several steps (a heater's on and off parts). Any hysteresis turning-point filter finds
    the same turning points from the first value, the noted ones and the last as from every
    sub-step value, at a fraction of them.

    Parameters
    ----------
    column : int
        State column (of ``x``) whose turns are noted.
    n : int
        Number of specimens.
    capacity : int
        Most values noted per specimen between starts: the number of sub-steps is enough
        (each notes at most one).

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.rigs.axt211 import AXT211Plant
    >>> plant, spec = AXT211Plant(), AXT211Plant().nominal()
    >>> x = plant.initial_state(spec, np.array([0.0, 24.0, 25.0]))
    >>> col = plant.state_names.index("T_w")
    >>> turns = Turns(col, 1, capacity=250)
    >>> turns.start(x)
    >>> x = plant.step(x, [1.0, 24.0, 25.0], 60.0, spec, turns=turns)   # heats: rises
    >>> x = plant.step(x, [0.0, 24.0, 25.0], 60.0, spec, turns=turns)   # cools down
    >>> v = turns.noted(0)
    >>> len(v) >= 1 and bool(v.max() > x[0, col])   # the peak while it cooled
    True
    """

    def __init__(self, column: int, n: int, capacity: int) -> None:
        self.column = int(column)
        self.state = np.zeros((int(n), 3))  # last value, its direction (2: none yet), count
        self.values = np.zeros((int(n), max(int(capacity), 1)))

    def start(self, x: NDArray[np.float64]) -> None:
        """Start every specimen's series at its state row in ``x`` (the value is not noted)."""
        self.state[:, 0] = x[:, self.column]
        self.state[:, 1] = 2.0
        self.state[:, 2] = 0.0

    def count(self, b: int) -> int:
        """Number of values noted for specimen ``b`` since :meth:`start`."""
        n = int(self.state[b, 2])
        if n > self.values.shape[1]:
            raise ShapeError(
                f"{n} turns noted for specimen {b}, room for {self.values.shape[1]}: "
                "give Turns a capacity of at least the number of sub-steps"
            )
        return n

    def noted(self, b: int) -> NDArray[np.float64]:
        """The values noted for specimen ``b`` since :meth:`start`, in time order."""
        return self.values[b, : self.count(b)]


# ------------------------------------------------------------------- protocols
@dataclass
class RigRun:
    """One recorded experiment of a rig, before it becomes a Recording.

    Attributes
    ----------
    experiment_id : str
    time : ndarray, shape (N,)
    columns : dict of str to ndarray
        Recorded signals (NaN where a channel has no sample).
    units, roles : dict
    meta : dict
        Protocol, conditions, seed — never the effects.
    truth : dict of str to ndarray
        Noise-free values of hidden and measured signals on ``time`` (kept for
        tests and virtual-sensor evaluation; not written to recordings).
    """

    experiment_id: str
    time: NDArray[np.float64]
    columns: dict[str, NDArray[np.float64]]
    units: dict[str, str]
    roles: dict[str, str]
    meta: dict[str, Any] = field(default_factory=dict)
    truth: dict[str, NDArray[np.float64]] = field(default_factory=dict)


@dataclass(frozen=True)
class Protocol:
    """A named experiment programme of a rig.

    Parameters
    ----------
    name : str
    description : str
    run : callable
        ``run(rig, rng, **options) -> list[RigRun]``.
    """

    name: str
    description: str
    run: Callable[..., list[RigRun]]


class Rig:
    """Base class of the virtual test rigs (protocols, sensors, effects, specimen).

    Parameters
    ----------
    effects : sequence of str or EffectSpec
        Concealed effects beyond the nominal rig (see :attr:`supported_effects`).
    off : iterable of str
        Extra physics of the true plant to switch off (names of its table).
    """

    name: str = "rig"
    #: The true plant's class (None for a rig that does not have one of its own).
    plant_cls: ClassVar[type[TruePlant] | None] = None
    #: Protocols by name.
    protocols: ClassVar[dict[str, Protocol]] = {}
    #: Sensors by recorded signal.
    sensors: ClassVar[dict[str, Sensor]] = {}
    #: Effects this rig can carry.
    supported_effects: tuple[str, ...] = ()
    #: Default magnitudes of the effects.
    effect_defaults: ClassVar[dict[str, dict[str, Any]]] = {}

    def __init__(
        self, effects: Sequence[str | EffectSpec] = (), *, off: Iterable[str] = ()
    ) -> None:
        self.effects = tuple(parse_effect(e) for e in effects)
        bad = [e.name for e in self.effects if e.name not in self.supported_effects]
        if bad:
            raise UnknownNameError(
                f"rig {self.name!r} cannot carry effect(s) {bad}; it supports "
                f"{list(self.supported_effects)}"
            )
        self.off = tuple(off)
        self._specimen: Specimens | None = None
        if self.plant_cls is not None:
            self.plant()  # checks the switch names now

    def effect(self, name: str) -> EffectSpec | None:
        """The requested effect called ``name``, if any."""
        for e in self.effects:
            if e.name == name:
                return e
        return None

    def _settings(self, name: str) -> dict[str, Any] | None:
        e = self.effect(name)
        if e is None:
            return None
        return {**self.effect_defaults.get(name, {}), **e.params}

    # ---- the true plant and its specimen
    def plant(self) -> TruePlant:
        """The true plant with this rig's plant effects and switches."""
        if self.plant_cls is None:
            raise ConfigError(f"rig {self.name!r} has no true plant of its own")
        plant_effects = [
            EffectSpec(e.name, {**self.effect_defaults.get(e.name, {}), **e.params})
            for e in self.effects
            if e.name not in SENSOR_EFFECTS
        ]
        return self.plant_cls(off=self.off, effects=plant_effects)

    @property
    def specimen(self) -> Specimens:
        """The specimen this rig holds (nominal unless :meth:`with_specimen` set one)."""
        if self._specimen is None:
            return self.plant().nominal(1)
        return self._specimen

    def with_specimen(self, values: Mapping[str, float] | Specimens) -> Rig:
        """A copy of this rig whose plant is one particular specimen.

        ``values``: a :class:`Specimens` of one specimen, or overrides of the
        nominal parameters by name.
        """
        other = type(self)(self.effects, off=self.off)
        if isinstance(values, Specimens):
            if values.n != 1:
                raise ShapeError(f"with_specimen takes one specimen; got {values.n}")
            other._specimen = values
        else:
            other._specimen = self.specimen.replace(dict(values))
        return other

    # ---- sensors
    def sensor(self, signal: str) -> Sensor:
        """The sensor of ``signal`` with this rig's sensor effects applied."""
        s = self.sensors.get(signal, Sensor())
        for name in SENSOR_EFFECTS:
            st = self._settings(name)
            if st is None or st.get("signal") != signal:
                continue
            key = {"sensor_lag": "tau", "sensor_offset": "offset", "sensor_drift": "rate"}[name]
            try:
                v = float(st[key])
            except (KeyError, TypeError, ValueError):
                raise ConfigError(
                    f"rig effect {name}: {key} is {st.get(key)!r}; expected a number"
                ) from None
            if name == "sensor_lag":
                s = s.replace(lag=nonnegative("sensor_lag tau", v, unit="s"))
            elif name == "sensor_offset":
                s = s.replace(offset=s.offset + v)
            else:
                s = s.replace(drift=s.drift + v)
        return s

    def check_sensor_effects(self, signals: Iterable[str]) -> None:
        """Raise when a sensor effect names a signal the rig does not record."""
        names = list(signals)
        for name in SENSOR_EFFECTS:
            st = self._settings(name)
            if st is not None and st.get("signal") not in names:
                raise ConfigError(
                    f"effect {name!r} names signal {st.get('signal')!r}; the rig records {names}"
                )

    def measure(
        self,
        values: Mapping[str, ArrayLike],
        rng: np.random.Generator,
        time: ArrayLike | None = None,
    ) -> dict[str, NDArray[np.float64]]:
        """Record noise-free ``values`` through each signal's sensor."""
        return {
            name: self.sensor(name).measure(np.asarray(x, dtype=float), rng, time)
            for name, x in values.items()
        }

    # ---- protocols
    def run(self, protocol: str, *, seed: int = 0, **options: Any) -> list[RigRun]:
        """Run a protocol and return its recorded experiments.

        Parameters
        ----------
        protocol : str
            Name in :attr:`protocols`.
        seed : int
            Seed of every random draw (noise, ambient, specimen spread).
        **options
            Protocol options (e.g. ``speeds=[4000]``).
        """
        try:
            proto = self.protocols[protocol]
        except KeyError:
            raise UnknownNameError(
                f"rig {self.name!r} has no protocol {protocol!r}; protocols are "
                f"{list(self.protocols)}"
            ) from None
        accepted = [
            n
            for n, prm in inspect.signature(proto.run).parameters.items()
            if prm.kind == prm.KEYWORD_ONLY
        ]
        unknown = [k for k in options if k not in accepted]
        if unknown:
            raise ConfigError(
                f"protocol {protocol!r} of rig {self.name!r} has no option(s) {unknown}; "
                f"options are {accepted}"
            )
        if isinstance(seed, bool | np.bool_) or not isinstance(seed, int | np.integer) or seed < 0:
            raise ConfigError(f"seed is {seed!r}; expected a whole number >= 0")
        defaults = inspect.signature(proto.run).parameters
        for k, v in options.items():
            _check_option(f"protocol {protocol!r} of rig {self.name!r}", k, v, defaults[k].default)
        rng = np.random.default_rng(seed)
        runs = proto.run(self, rng, **options)
        for r in runs:
            r.meta.setdefault("rig", self.name)
            r.meta.setdefault("protocol", protocol)
            r.meta.setdefault("seed", seed)
        return runs


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float | np.integer | np.floating) and not isinstance(
        v, bool | np.bool_
    )


def _check_option(where: str, key: str, value: Any, default: Any) -> None:
    """Refuse a protocol option of another type than its default (a number, a list of them)."""
    if isinstance(default, bool):
        if not isinstance(value, bool | np.bool_):
            raise ConfigError(f"{where}: option {key} = {value!r:.60}; expected True or False")
    elif _is_number(default):
        if not _is_number(value) or not math.isfinite(float(value)):
            raise ConfigError(f"{where}: option {key} = {value!r:.60}; expected a finite number")
        if isinstance(default, int) and float(value) != int(value):
            raise ConfigError(f"{where}: option {key} = {value!r:.60}; expected a whole number")
    elif isinstance(default, list | tuple) and default and all(_is_number(x) for x in default):
        items = [value] if _is_number(value) else value
        if (
            isinstance(items, str | bytes)
            or not hasattr(items, "__len__")
            or len(items) == 0
            or not all(_is_number(x) and math.isfinite(float(x)) for x in items)
        ):
            raise ConfigError(
                f"{where}: option {key} = {value!r:.60}; expected a list of finite numbers like "
                f"{list(default)}"
            )


def first_order_lag(x: NDArray[np.float64], tau: float, dt: float) -> NDArray[np.float64]:
    """Exact discrete first-order lag of a sampled signal (held between samples).

    Parameters
    ----------
    x : ndarray, shape (T,)
    tau : float
        Time constant [s].
    dt : float
        Sample period [s].
    """
    from scipy.signal import lfilter  # scipy.signal (~1 s) only when a sensor lag is applied

    a = float(np.exp(-dt / tau))
    # y[k+1] = a y[k] + (1 − a) x[k], y[0] = x[0] (the sensor starts in equilibrium); in
    # scipy's transposed direct form the initial condition zi is y[0] itself
    y, _ = lfilter([0.0, 1.0 - a], [1.0, -a], x, zi=[x[0]])
    return y


def _check_parameters(params: Sequence[PhysicalParameter]) -> None:
    # used by the rig modules' tests: nominal values inside their limits, known spread kinds
    for p in params:
        if not (p.lower <= p.nominal <= p.upper):
            raise ParameterError(f"{p.name} = {p.nominal!r} outside [{p.lower}, {p.upper}]")
