"""Candidates, hypotheses and the nominal model they are built on.

A :class:`Candidate` is one effect of the vocabulary in one form at one place
(proposed by the catalogue, :mod:`.effects`); a :class:`Hypothesis` is a
fitted model: the nominal model plus a combination of candidates, with its
parameters, fits on training and held-out data and its score against the
model it extends. :class:`NominalSpec` builds the model of a combination.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.models.augmented import AugmentedModel
from thermogym.models.base import Model
from thermogym.models.registry import get_model

__all__ = ["Candidate", "Hypothesis", "NominalSpec"]


@dataclass(frozen=True)
class Candidate:
    """One effect in one form at one place: what the catalogue proposes.

    Attributes
    ----------
    effect : str
        Vocabulary name.
    form : str
        The physical form, in words (``"radiation (T⁴ in kelvin)"``).
    target : str
        Where it acts (a signal, ``"all temperatures"``, ``"plant"``).
    augmentations : tuple of dict
        Augmentation specs added around the model
        (:class:`~thermogym.models.augmented.AugmentedModel`).
    internal : tuple of str
        Effects of the plant's own equations switched on instead
        (``base_config["effects"]`` of a registered plant).
    starts : tuple of dict
        Starts of the extra parameters besides their neutral values (drawn
        inside the bounds; never a value a rig used).
    evidence : str
        The residual signature that speaks for it, in words.
    prior : float
        Signature score in [0, 1] (orders the screening; the fit decides).
    recorded : tuple of dict
        Per recording (training first, then held-out, as in the
        :class:`~.context.Context`), the values of the augmentations'
        parameters read from that recording's data (group ``"recorded"``: the
        times of disturbance events); empty when there are none.
    n_recorded : tuple of int
        Per recording, how many numbers were read from it (each counts as a
        fitted parameter of that recording in the information criterion).
    """

    effect: str
    form: str
    target: str
    augmentations: tuple[dict[str, Any], ...] = ()
    internal: tuple[str, ...] = ()
    starts: tuple[dict[str, float], ...] = ()
    evidence: str = ""
    prior: float = 0.0
    recorded: tuple[dict[str, float], ...] = ()
    n_recorded: tuple[int, ...] = ()

    @property
    def label(self) -> str:
        """``effect [form] (target)``."""
        return f"{self.effect} [{self.form}] ({self.target})"

    @property
    def key(self) -> tuple[str, str]:
        """(effect, target): two candidates with one key are alternatives."""
        return (self.effect, self.target)


@dataclass
class NominalSpec:
    """How to build the nominal model and the model of any combination of candidates.

    Attributes
    ----------
    base : str or Model
        Registered name or a model instance.
    base_config : dict
        Constructor arguments of a registered base model.
    augmentations : list of dict
        Augmentations that are part of the nominal model itself (the output
        offsets of a generic ``ss`` model).
    name : str
        The nominal model's name in reports (``strut``, ``ss``, ``user_plate``).
    """

    base: str | Model
    base_config: dict[str, Any] = field(default_factory=dict)
    augmentations: list[dict[str, Any]] = field(default_factory=list)
    name: str = ""

    @property
    def registered(self) -> bool:
        """Whether the base is a registered model (rebuilt by name)."""
        return isinstance(self.base, str)

    def build(self, candidates: Sequence[Candidate] = ()) -> Model:
        """The model with every candidate's effect switched on or wrapped around it."""
        internal = [e for c in candidates for e in c.internal]
        augs = [*self.augmentations, *[dict(a) for c in candidates for a in c.augmentations]]
        if isinstance(self.base, Model):
            if internal:
                raise ValueError("a model instance cannot switch on effects of its own")
            return AugmentedModel(self.base, None, augs) if augs else self.base
        cfg = dict(self.base_config)
        if internal:
            cfg["effects"] = [*cfg.get("effects", []), *internal]
        if augs:
            return AugmentedModel(self.base, cfg, augs)
        return get_model(self.base, **cfg)

    def config(self) -> dict[str, Any]:
        """JSON-able description (the instance's class name for a user's model)."""
        base = self.base if isinstance(self.base, str) else f"{type(self.base).__name__} instance"
        return {
            "base": base,
            "base_config": dict(self.base_config)
            if isinstance(self.base, str)
            else dict(self.base.config()),
            "augmentations": [dict(a) for a in self.augmentations],
        }


@dataclass
class Hypothesis:
    """A fitted model: the nominal model plus a combination of candidates.

    Attributes
    ----------
    candidates : tuple of Candidate
        The combination (empty: the nominal model).
    model : Model
        The model simulated (a fast equivalent may have been fitted).
    free : tuple of str
        Parameters fitted (shared and per-recording).
    bounds : dict
        Bounds of the free parameters.
    theta : ndarray, shape (P,)
        Fitted parameters (per-recording ones at their neutral values).
    outcome : FitOutcome or None
        The training fit.
    extra : tuple of str
        Shared parameters the last candidate added.
    local : tuple of str
        Per-recording parameters of the model.
    sims_train, sims_val : list of ndarray
        Simulated outputs (T, n_y) per recording (held-out: per-recording
        parameters and initial state estimated on the held-out recording).
    local_train, local_val : list of dict
        Per-recording parameter values.
    chi2_train, chi2_val : float
        Whitened likelihood-ratio statistic against the parent (:mod:`.scoring`).
    wsse_train, wsse_val : float
        Weighted squared simulation error.
    n_val : int
        Held-out residual samples.
    k_global, k_local : int
        Shared parameters and per-recording parameters the candidates added
        (over the nominal model).
    k_recorded_train, k_recorded_val : int
        Numbers the candidates read from the training and from the held-out
        recordings, summed over them (:attr:`Candidate.n_recorded`).
    delta_ic : float
        Information criterion against the model it extends (negative: better).
    score : float
        ``−delta_ic``.
    explained : float
        Share of the systematic held-out error of the nominal model it removes.
    screened : bool
        Fitted with the nominal parameters held (a quick first look).
    error : str
        Why it could not be fitted (empty when it was).
    seconds : float
    """

    candidates: tuple[Candidate, ...]
    model: Model | None = None
    free: tuple[str, ...] = ()
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    theta: NDArray[np.float64] | None = None
    outcome: Any = None
    extra: tuple[str, ...] = ()
    local: tuple[str, ...] = ()
    sims_train: list[NDArray[np.float64]] = field(default_factory=list, repr=False)
    sims_val: list[NDArray[np.float64]] = field(default_factory=list, repr=False)
    local_train: list[dict[str, float]] = field(default_factory=list, repr=False)
    local_val: list[dict[str, float]] = field(default_factory=list, repr=False)
    chi2_train: float = math.nan
    chi2_val: float = math.nan
    wsse_train: float = math.nan
    wsse_val: float = math.nan
    n_val: int = 0
    k_global: int = 0
    k_local: int = 0
    k_recorded_train: int = 0
    k_recorded_val: int = 0
    delta_ic: float = math.inf
    score: float = -math.inf
    delta_ic_train: float = math.inf
    explained: float = 0.0
    screened: bool = False
    error: str = ""
    seconds: float = 0.0
    fit_before: dict[str, float] = field(default_factory=dict)
    fit_after: dict[str, float] = field(default_factory=dict)
    validation_before: dict[str, float] = field(default_factory=dict)
    validation_after: dict[str, float] = field(default_factory=dict)
    intervals: dict[str, dict[str, Any]] = field(default_factory=dict)
    baseline: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def last(self) -> Candidate | None:
        """The candidate this hypothesis added last (None for the nominal model)."""
        return self.candidates[-1] if self.candidates else None

    @property
    def ok(self) -> bool:
        """Fitted, with a finite held-out error."""
        return not self.error and math.isfinite(self.wsse_val)

    def value(self, name: str) -> float:
        """Fitted value of a parameter."""
        assert self.model is not None and self.theta is not None
        return float(self.theta[self.model.param_index(name)])

    def params_table(self, names: Sequence[str]) -> dict[str, dict[str, Any]]:
        """``{name: {value, stderr, unit, description, interval, identifiable}}``."""
        out: dict[str, dict[str, Any]] = {}
        if self.model is None or self.theta is None:
            return out
        se = self.outcome.stderr if self.outcome is not None else {}
        for p in names:
            spec = self.model.parameters[self.model.param_index(p)]
            row: dict[str, Any] = {
                "value": self.value(p),
                "stderr": float(se.get(p, math.nan)),
                "unit": spec.unit,
                "description": spec.description,
            }
            if p in self.intervals:
                row.update(self.intervals[p])
            out[p] = row
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary of the last candidate (the ranked hypotheses of a report)."""
        c = self.last
        d: dict[str, Any] = {
            "effect": c.effect if c else "none",
            "form": c.form if c else "",
            "target": c.target if c else "",
            "evidence": c.evidence if c else "",
            "combination": [x.effect for x in self.candidates],
            "forms": [x.form for x in self.candidates],
            "params": self.params_table(self.extra),
            "n_extra": self.k_global,
            "n_local_per_recording": self.k_local,
            "n_read_from_data": self.k_recorded_train + self.k_recorded_val,
            "local_params": list(self.local),
            "fit_before": self.fit_before,
            "fit_after": self.fit_after,
            "validation_before": self.validation_before,
            "validation_after": self.validation_after,
            "delta_ic": self.delta_ic,
            "delta_ic_train": self.delta_ic_train,
            "chi2_heldout": self.chi2_val,
            "score": self.score,
            "explained": self.explained,
            "screened": self.screened,
            "seconds": self.seconds,
        }
        if self.baseline:
            d["baseline"] = self.baseline
        if self.notes:
            d["notes"] = list(self.notes)
        if self.error:
            d["error"] = self.error
        return d


def merge_values(
    model: Model, theta: Mapping[str, float] | NDArray[np.float64], other: Model
) -> NDArray[np.float64]:
    """``other``'s nominal vector with the values ``model`` shares with it by name."""
    out = other.nominal.copy()
    items: Iterable[tuple[str, Any]]
    if isinstance(theta, Mapping):
        items = theta.items()
    else:
        items = zip(model.param_names, np.asarray(theta, dtype=float).reshape(-1), strict=True)
    for p, v in items:
        if p in other.param_names:
            out[other.param_index(p)] = float(v)
    return out
