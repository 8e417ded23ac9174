"""The papers' rigs as plant families of the suite, through their public API only.

``get_rig(name, effects).run(protocol, seed=...)`` makes the recordings. An
effect the rig carries in its own physics is requested by its vocabulary name
with the rig's default size (the rigs are being rewritten, so the suite
names no rig-internal setting). Effects the rig does not cover, or whose
size the suite wants to set, are made here on the rig's noise-free truth
(``RigRun.truth``), keeping the rig's own measurement noise:

* sensor lag, offset and drift on a recorded output;
* a transport delay as a clock skew between the input log and the sensors;
* an unmeasured disturbance as the part of the ambient the ambient sensor
  does not see (the sensor sits where a draught or air-conditioning cycle
  does not reach; the plant sees it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from thermogym.recording import Recording
from thermogym.rigs import get_rig, to_recording
from thermogym.rigs.base import RigRun

from .effects import Hidden, clock_skew, first_order_lag
from .signals import effect_share, periodic

__all__ = ["RIGS", "RigSetup", "rig_recordings"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class RigSetup:
    """How a rig's recordings are made and handed to the diagnosis.

    Parameters
    ----------
    train, validate : (protocol, options)
        Rig protocols of the training and held-out recordings.
    diagnose : mapping
        Options for ``diagnose`` (``dt``: the comparison period).
    spread : tuple of str
        Model parameters a control's specimen draws 10-30 % off nominal.
    specimen : mapping
        Overrides every case of the rig uses (e.g. no backlash unless it is the effect).
    """

    train: tuple[str, Mapping[str, Any]]
    validate: tuple[str, Mapping[str, Any]]
    diagnose: Mapping[str, Any] = field(default_factory=dict)
    spread: tuple[str, ...] = ()
    specimen: Mapping[str, float] = field(default_factory=dict)


RIGS: dict[str, RigSetup] = {
    # paper 000 section 4.1: fitted at 20 m/min, validated at 25 and 30 m/min (the 25 m/min
    # run starts with the drive still warm: not at rest)
    "strut": RigSetup(
        ("steps", {"feed_rates": (20.0,)}),
        ("steps", {"feed_rates": (25.0, 30.0)}),
        {},
        ("r_motor", "r_bearing", "r_nut", "r_spindle_air", "r_tube_air"),
    ),
    # paper 002: power steps at 19-29 V and 0-50 °C for training, the PWM test held out; the
    # nominal model is fitted without backlash, so the rig has none unless it is the effect
    "axt211": RigSetup(
        ("steps", {}),
        ("pwm", {}),
        {"dt": 5.0},
        ("C_P", "lambda_PG", "C_G", "lambda_GU", "kP_b", "kP_c", "tau_P"),
        {"c_backlash": 0.0},
    ),
    # paper 001: run-in days at 4000-8000 rpm for training, 4500/5300/7800 rpm held out
    "spindle": RigSetup(
        ("run-in", {"raw": False, "folds": (1,)}),
        ("validation", {"raw": False}),
        {"dt": 120.0},
        (
            "q_rear",
            "q_front",
            "q_belt",
            "C_shaft",
            "C_bearing",
            "C_inner",
            "C_outer",
            "G_bs",
            "G_bh",
            "G_io",
            "G_outer",
            "g_outer",
        ),
    ),
}

#: Effects made here (on the rig's truth) rather than by the rig itself.
POST_HOC = (
    "sensor_lag",
    "sensor_offset",
    "sensor_drift",
    "transport_delay",
    "unmeasured_disturbance",
)


def _post_hoc(run: RigRun, h: Hidden, rng: np.random.Generator) -> RigRun:
    """Apply one suite-made effect to a rig run (noise of the rig kept)."""
    cols = dict(run.columns)
    t = np.asarray(run.time, dtype=float)
    sig = h.where
    if sig not in cols:
        raise KeyError(f"rig run {run.experiment_id!r} has no column {sig!r}: {list(cols)}")
    x = np.asarray(cols[sig], dtype=float)
    truth = np.asarray(run.truth.get(sig, x), dtype=float)
    noise = x - truth  # the rig's own measurement error, kept
    if h.effect == "sensor_lag":
        dt = float(np.median(np.diff(t)))
        cols[sig] = first_order_lag(truth, float(h.params["tau"]), dt) + noise
    elif h.effect == "sensor_offset":
        cols[sig] = x + float(h.params["offset"])
    elif h.effect == "sensor_drift":
        cols[sig] = x + float(h.params["rate"]) * (t - t[0]) / 3600.0
    elif h.effect == "transport_delay":
        # the input log's clock runs `delay` s behind the sensors' clock
        cols[sig] = clock_skew(t, x, float(h.params["delay"]))
    elif h.effect == "unmeasured_disturbance":
        # the plant saw the logged ambient; the log now misses a cycle the plant felt
        d = float(h.params["amplitude_K"]) * periodic(
            t,
            float(h.params["period"]),
            rng.uniform(0, 2 * math.pi),
            sharpness=float(h.get("sharpness", 0.0)),
        )
        cols[sig] = x - d
    else:  # pragma: no cover - guarded by POST_HOC
        raise ValueError(h.effect)
    return replace(run, columns=cols)


def _spread(rig: Any, setup: RigSetup, rng: np.random.Generator, control: bool) -> tuple[Any, str]:
    """The rig with this case's specimen: a control's constants off nominal, then overrides.

    Rigs with a true plant of their own (``rig.plant().draw_specimens``, issue 14)
    draw a control's specimen from their own manufacturing spread. Rigs built
    on the model class take the model's positive constants of
    :attr:`RigSetup.spread`, each 10-30 % off nominal (random sign).
    """
    plant = rig.plant()
    if hasattr(plant, "draw_specimens"):
        note = ""
        if control:
            rig = rig.with_specimen(plant.draw_specimens(rng, 1))
            note = "specimen drawn from the rig's own manufacturing spread"
        if setup.specimen:
            try:
                rig = rig.with_specimen(dict(setup.specimen))
            except (KeyError, ValueError) as e:  # thermogym's errors subclass these
                note += f"; overrides {dict(setup.specimen)} not applied: {e}"
        return rig, note.lstrip("; ")
    from thermogym.models.registry import get_model

    over: dict[str, float] = dict(setup.specimen)
    note = ""
    if control and setup.spread:
        model = get_model(rig.model_name)
        nominal = dict(zip(model.param_names, model.nominal, strict=True))
        for k in setup.spread:
            over[k] = nominal[k] * (1.0 + rng.choice([-1.0, 1.0]) * rng.uniform(0.1, 0.3))
        note = "specimen constants drawn 10-30 % off nominal: " + ", ".join(
            f"{k}={v:.4g}" for k, v in over.items()
        )
    if not over:
        return rig, note
    return rig.with_specimen(over), note


def _truth_outputs(runs: Sequence[RigRun], names: Sequence[str]) -> dict[str, Array]:
    out: dict[str, list[Array]] = {n: [] for n in names}
    for r in runs:
        for n in names:
            if n in r.truth:
                out[n].append(np.asarray(r.truth[n], dtype=float))
    return {n: np.concatenate(v) for n, v in out.items() if v}


def _share(with_effect: Mapping[str, Array], without: Mapping[str, Array]) -> tuple[float, float]:
    """The largest share (and RMS size) over outputs: :func:`signals.effect_share`."""
    best = (0.0, 0.0)
    for n, y in with_effect.items():
        if n in without and y.shape == without[n].shape:
            best = max(best, effect_share(y, without[n]))
    return best


def _posthoc_share(
    h: Hidden, runs: Sequence[RigRun], outputs: Sequence[str]
) -> tuple[float, float]:
    """Share of output variance of a suite-made effect, on the rig's noise-free truth.

    Sensor errors: exact, on their signal. A clock skew of D seconds: the
    outputs against themselves D seconds later (what the skewed log implies
    for a time-invariant plant). An unmeasured ambient cycle d(t): mean(d²)
    on the temperature outputs, an upper bound (the ambient reaches a thermal
    node with a DC gain of at most 1 and is filtered on its way).
    """
    on: dict[str, list[Array]] = {}
    off: dict[str, list[Array]] = {}
    rng = np.random.default_rng(0)
    for r in runs:
        t = np.asarray(r.time, dtype=float)
        for n in outputs:
            y = np.asarray(r.truth[n], dtype=float)
            if h.effect in ("sensor_lag", "sensor_offset", "sensor_drift"):
                if n != h.where:
                    continue
                fake = replace(r, columns={n: y}, truth={n: y})
                y_on = np.asarray(_post_hoc(fake, h, rng).columns[n], dtype=float)
            elif h.effect == "transport_delay":
                y_on = np.interp(t + float(h.params["delay"]), t, y)
            else:  # unmeasured ambient cycle: it reaches the temperatures only
                if r.units.get(n) != "°C":
                    continue
                d = float(h.params["amplitude_K"]) * periodic(t, float(h.params["period"]), 0.0)
                y_on = y + d
            on.setdefault(n, []).append(y_on)
            off.setdefault(n, []).append(y)
    return _share(
        {n: np.concatenate(v) for n, v in on.items()},
        {n: np.concatenate(v) for n, v in off.items()},
    )


def rig_recordings(
    rig_name: str, hidden: Sequence[Hidden], seed: int, *, control: bool = False
) -> tuple[list[Recording], list[Recording], dict[str, Any], dict[str, Any]]:
    """Training and held-out recordings of a rig case, the diagnose options, and facts.

    Returns
    -------
    train, validate : list of Recording
    options : dict
        Keyword arguments for ``diagnose`` (``dt``).
    facts : dict
        ``share``: each effect's share of the output variance on the training
        data (noise-free truth), and ``all`` for the effects together (their
        larger one for a combination: an approximation); ``rms`` the same as
        RMS sizes in the output's unit; ``note``.
    """
    setup = RIGS[rig_name]
    internal = [h for h in hidden if h.effect not in POST_HOC or h.form == "rig"]
    external = [h for h in hidden if h not in internal]
    rng = np.random.default_rng(seed + 7919)

    def make(with_internal: Sequence[Hidden]) -> tuple[list[RigRun], list[RigRun], str]:
        rig = get_rig(rig_name, [h.effect for h in with_internal])
        over = dict(setup.specimen)
        if any(h.effect == "backlash" for h in with_internal):
            over.pop("c_backlash", None)
        rig, note = _spread(
            rig, replace(setup, specimen=over), np.random.default_rng(seed + 104729), control
        )
        (p_tr, o_tr), (p_va, o_va) = setup.train, setup.validate
        return rig.run(p_tr, seed=seed, **o_tr), rig.run(p_va, seed=seed + 1000, **o_va), note

    train, val, note = make(internal)
    outputs = [k for k, v in train[0].roles.items() if v == "output" and k in train[0].truth]
    sizes: dict[str, tuple[float, float]] = {}
    if hidden:
        base_runs = make([])[0] if internal else train
        base = _truth_outputs(base_runs, outputs)
        for h in internal:
            alone = train if len(internal) == 1 else make([h])[0]
            sizes[h.effect] = _share(_truth_outputs(alone, outputs), base)
        for h in external:
            sizes[h.effect] = _posthoc_share(h, base_runs, outputs)
        if len(hidden) == 1:
            sizes["all"] = next(iter(sizes.values()))
        else:  # effects on different signals or paths: the larger one (an approximation)
            sizes["all"] = max(sizes.values())
    for h in external:
        train = [_post_hoc(r, h, rng) for r in train]
        val = [_post_hoc(r, h, rng) for r in val]
    return (
        [to_recording(r, rig_name) for r in train],
        [to_recording(r, rig_name) for r in val],
        dict(setup.diagnose),
        {
            "share": {k: v[0] for k, v in sizes.items()},
            "rms": {k: v[1] for k, v in sizes.items()},
            "note": note,
        },
    )
