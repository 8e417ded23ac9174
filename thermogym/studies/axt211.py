"""Paper 002 reproduced: the AXT211 grey-box identification on rig data.

:func:`reproduce_paper002` runs the virtual AXT211 rig's step, staircase and PWM
tests (:mod:`thermogym.rigs.axt211`) and identifies the model submodel by
submodel with :func:`thermogym.identification.greybox_axt211.identify_axt211`
from perturbed start values (sections VI-VII of ``002_dae2310635fe074e.txt``);
the result compares the fitted parameters with the rig's matching physical
quantities (:func:`rig_equivalents`): the rig's true plant is not the model, so
only some model parameters have a counterpart, and where a fitted value misses
it the parameter absorbs physics the model lacks.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from thermogym._checks import in_range
from thermogym.errors import ConfigError
from thermogym.identification.greybox_axt211 import (
    MECHANICAL,
    THERMAL,
    GreyboxResult,
    identify_axt211,
)
from thermogym.models.axt211 import AXT211_PARAMETERS
from thermogym.rigs import get_rig, to_recording

__all__ = ["RIG_MATCH", "GreyboxConfig", "reproduce_paper002", "rig_equivalents"]

_SPEC = {p.name: p for p in AXT211_PARAMETERS}

#: Model parameters with a matching physical quantity of the AXT211 rig's true plant
#: (:meth:`thermogym.rigs.axt211.AXT211Plant.derived`); the others (PTC polynomial, k_P
#: shape) describe curves the rig produces by other physics.
RIG_MATCH: dict[str, str] = {
    "C_P": "C_sensible",
    "lambda_PG": "G_to_housing",
    "C_G": "C_housing",
    "lambda_GU": "G_housing_air",
    "T_P0": "T_stroke_start",
    "tau_P": "tau_melt",
    "c_backlash": "play",
    "x_max": "stroke",
}


def rig_equivalents(rig: Any) -> dict[str, float]:
    """The rig specimen's values of the model parameters that have a physical match.

    Parameters
    ----------
    rig : AXT211Rig
        The rig (its plant, effects and specimen).

    Returns
    -------
    dict
        Model parameter name -> the matching quantity of the rig's true plant
        (:data:`RIG_MATCH`): the model's C_P against the rig's sensible capacity
        (the rig's charge also has latent heat), its λ_GU against the rig's loss
        conductance at 20 K, and so on. Where a fitted value departs from these,
        the model parameter absorbs physics it lacks.

    Examples
    --------
    >>> rig_equivalents(get_rig("axt211"))["C_P"]
    13.0
    """
    d = rig.plant().derived(rig.specimen)
    return {m: float(d[r][0]) for m, r in RIG_MATCH.items()}


@dataclass(frozen=True)
class GreyboxConfig:
    """Arguments of :func:`reproduce_paper002`.

    Attributes
    ----------
    seed : int
        Seed of the rig data and of the start perturbation.
    effects : tuple of str
        Physics the rig has and the model lacks (e.g. ``("phase_change",)``);
        none by default: the rig's plant is the model plus sensors.
    perturbation : float
        Start values are the nominal ones times ``1 + perturbation · U(−1, 1)``.
    train_steps : tuple of (float, float)
        (supply [V], ambient [°C]) of the step tests used for training.
    jac : {"exact", "fd", "auto"}
        Jacobian of the thermodynamic fit.
    level : float
        Confidence level of the intervals.
    max_iter : int
        Gauss-Newton iterations per stage.
    staircase_hold_s : float
        Hold time of each temperature step of the staircase test [s].
    joint : bool
        Refine every parameter together on the full model (stage 4).
    mc_samples : int
        Monte Carlo samples of the mechanics' global start.
    smooth_s : float
        Moving-average window for the measured disturbances [s] (0: off).
    """

    seed: int = 0
    effects: tuple[str, ...] = ()
    perturbation: float = 0.3
    train_steps: tuple[tuple[float, float], ...] = ((24.0, 25.0), (19.0, 0.0), (29.0, 50.0))
    jac: str = "exact"
    level: float = 0.95
    max_iter: int = 100
    staircase_hold_s: float = 1800.0
    joint: bool = True
    mc_samples: int = 1000
    smooth_s: float = 120.0


def _perturbed_start(
    names: Sequence[str], rng: np.random.Generator, perturbation: float
) -> dict[str, float]:
    out = {}
    for n in names:
        p = _SPEC[n]
        v = p.nominal * (1.0 + perturbation * rng.uniform(-1.0, 1.0))
        span = p.upper - p.lower
        out[n] = float(np.clip(v, p.lower + 0.01 * span, p.upper - 0.01 * span))
    return out


def reproduce_paper002(
    config: GreyboxConfig | None = None, *, progress: bool | None = None
) -> GreyboxResult:
    """Generate AXT211 rig data and identify the model as paper 002 does.

    Training: the step tests at ``config.train_steps`` (PTC, thermodynamics)
    and the closed-loop staircase plus the first training step (mechanics).
    Validation: the other step tests of the 19-29 V × 0-50 °C grid and the
    PWM test. Start values are the nominal ones perturbed by
    ``config.perturbation``; the result compares the fitted parameters with
    the rig's true ones.

    Parameters
    ----------
    config : GreyboxConfig, optional
    progress : bool, optional

    Returns
    -------
    GreyboxResult
    """
    cfg = config or GreyboxConfig()
    in_range("perturbation", cfg.perturbation, 0.0, 1.0, hi_open=True, error=ConfigError)
    rig = get_rig("axt211", cfg.effects)
    steps = [to_recording(r, "axt211") for r in rig.run("steps", seed=cfg.seed)]
    train_ids = {f"axt211-step-{v:g}V-{t:g}C" for v, t in cfg.train_steps}
    train = [r for r in steps if r.experiment_id in train_ids]
    if len(train) != len(train_ids):
        raise ConfigError(
            f"train_steps {list(cfg.train_steps)} are not all step tests of the rig "
            "(supply in 19/24/29 V, ambient in 0/25/50 °C)"
        )
    stair = [
        to_recording(r, "axt211")
        for r in rig.run("staircase", seed=cfg.seed + 1, hold_s=cfg.staircase_hold_s)
    ]
    pwm = [to_recording(r, "axt211") for r in rig.run("pwm", seed=cfg.seed + 2)]
    validation = [r for r in steps if r.experiment_id not in train_ids] + pwm
    truth = rig_equivalents(rig)
    rng = np.random.default_rng(cfg.seed)
    start = _perturbed_start([*THERMAL, *MECHANICAL], rng, cfg.perturbation)
    # the mechanics need a test whose wax temperature crosses the whole stroke range
    full_stroke = max(train, key=lambda r: float(np.nanmax(r["x_V"])))
    return identify_axt211(
        train,
        [*stair, full_stroke],
        validation,
        start=start,
        jac=cfg.jac,
        level=cfg.level,
        max_iter=cfg.max_iter,
        joint=cfg.joint,
        mc_samples=cfg.mc_samples,
        seed=cfg.seed,
        smooth_s=cfg.smooth_s,
        progress=progress,
        truth=truth,
    )
