"""The ``report`` stage of :func:`.run.diagnose`: the report assembled.

Named effects and their shares, fits before and after, residual tests after, the
alternatives the data do not tell apart, the nominal and the augmented model's
FitResults.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from thermogym.fitresult import FitResult, data_entry
from thermogym.identification.diagnosis.effects import CATALOGUE
from thermogym.identification.diagnosis.hypothesis import Hypothesis
from thermogym.identification.diagnosis.report import DiagnosisReport
from thermogym.identification.diagnosis.run_state import _need, _Run
from thermogym.identification.diagnosis.select import (
    Selection,
    _added,
    nrmse_table,
    recorded_names,
    shares,
)
from thermogym.identification.diagnosis.stages_nominal import _tests
from thermogym.models.augmented import AugmentedModel
from thermogym.models.base import Model
from thermogym.vocabulary import EFFECT_NAMES


# ------------------------------------------------------------------ stage: report
def _stage_report(st: _Run) -> DiagnosisReport:
    h = _need(st.nominal, "nominal fit")
    model = _need(st.model, "model")
    spec = _need(st.spec, "nominal spec")
    tests = _need(st.tests, "residual tests")
    o = st.opts
    outs = st.outs
    exo = list(model.exogenous_names)
    units = {s.name: s.unit for s in model.signals}
    fit_before_tr = nrmse_table(outs, [e.y for e in st.tr], h.sims_train)
    fit_before_va = nrmse_table(outs, [e.y for e in st.va], h.sims_val)
    data = [data_entry(r, "train") for r in st.tr_list] + [
        data_entry(r, "validation") for r in st.va_list
    ]
    nominal_fit = _build_fit(
        model,
        h,
        method=f"diagnosis nominal ({st.method})",
        settings={
            "x0": st.x0,
            "weights": dict(zip(outs, _need(st.weights, "output weights").tolist(), strict=True)),
            "dt": o["dt"],
            "calibrated": list(st.calibrated),
        },
        metrics={"train": {"nrmse": fit_before_tr}, "validation": {"nrmse": fit_before_va}},
        data=data,
        notes="nominal model of thermogym diagnosis",
    )
    tests_tr, tests_va = tests["train"], tests["validation"]
    alpha_adj = tests["alpha_adj"]
    sel = st.selection or Selection()
    steps = sel.steps
    # the combination is reported largest share first: the effect that removes most of the
    # held-out error is named first, whichever round kept it
    sh = shares(h, steps) if steps else []
    order = sorted(range(len(steps)), key=lambda i: -(sh[i] if math.isfinite(sh[i]) else -math.inf))
    physics = []
    for i in order:
        e = _added(steps[i]).effect
        if e in EFFECT_NAMES and e not in physics:
            physics.append(e)
    par = st.parameters
    if physics:
        named = list(physics)
        if par.get("significant"):
            named.append("parameter_error")
    elif par.get("significant"):
        named = ["parameter_error"]
    elif st.detected and st.arx and not st.arx.get("nominal_adequate", True):
        named = ["unexplained"]
    else:
        named = ["none"]
    report = DiagnosisReport(
        model=spec.name,
        model_config=spec.config(),
        outputs=list(outs),
        exogenous=exo,
        units=units,
        mismatch_detected=named != ["none"],
        alpha=o["alpha"],
        detection={
            "train": {
                x: {**t.to_dict(alpha_adj), "significant": tests["sig_tr"][x]}
                for x, t in tests_tr.items()
            },
            "validation": {
                x: {**t.to_dict(alpha_adj), "significant": tests["sig_va"][x]}
                for x, t in tests_va.items()
            },
            "alpha_per_test": alpha_adj,
            "materiality": {"min_snr": o["min_snr"], "min_rel": o["min_rel"]},
            "residual_structure": st.detected,
        },
        located=st.located,
        nominal_fit=nominal_fit,
        fit_before={"train": fit_before_tr, "validation": fit_before_va},
        notes=st.notes,
    )
    report.named_effects = named
    if st.data is not None and st.data.skipped:
        report.complete = False
        report.incomplete = [
            f"time limit of {o['time_limit']:g} s: " + st.data.skipped[0],
            *st.data.skipped[1:],
        ]
    report.parameters = par
    report.baseline = {k: v for k, v in st.arx.items() if k != "sims"}
    report.nominal_adequate = bool(st.arx.get("nominal_adequate", True))
    report.scheme = st.data.scheme if st.data else ""
    report.stages = {k: round(v, 3) for k, v in st.seconds.items()}
    report.selection = sel.summary()
    report.series = [
        {"name": e.name, "role": r, "time": e.time, "measured": e.y, "nominal": s, "u": e.u}
        for e, r, s in zip(
            [*st.tr, *st.va],
            ["train"] * len(st.tr) + ["validation"] * len(st.va),
            [*h.sims_train, *h.sims_val],
            strict=True,
        )
    ]
    report.regime_values = st.regs
    report.tests_before = {"train": tests_tr, "validation": tests_va}
    if st.ctx is not None:
        report.signatures = st.ctx.features
    report.hypotheses = [x.to_dict() for x in sel.first_round]
    for i, x in enumerate(report.hypotheses):
        x["rank"] = i + 1
        x["explanation"] = CATALOGUE[x["effect"]].explanation if x["effect"] in CATALOGUE else ""
    report.combination = []
    if steps:
        final = steps[-1]
        for s, share in ((steps[i], sh[i]) for i in order):
            c = _added(s)
            report.combination.append(
                {
                    "effect": c.effect,
                    "form": c.form,
                    "target": c.target,
                    "evidence": c.evidence,
                    "share_of_explained_error": share,
                    "delta_ic": s.delta_ic,
                    "params": final.params_table(
                        [
                            p
                            for p in final.extra
                            if p in s.extra
                            and p not in (steps[0].extra if s is not steps[0] else ())
                        ]
                        if s is not steps[0]
                        else list(s.extra)
                    ),
                    "baseline": s.baseline,
                    "notes": s.notes,
                }
            )
        first = steps[0]
        top = steps[order[0]]
        top_c = _added(top)
        report.alternatives = _alternatives(first, sel, physics)
        report.best = {
            "effect": top_c.effect,
            "form": top_c.form,
            "target": top_c.target,
            "explanation": CATALOGUE[top_c.effect].explanation if top_c.effect in CATALOGUE else "",
            "evidence": top_c.evidence,
            "params": final.params_table([p for p in final.extra]),
            "fit_before": fit_before_tr,
            "fit_after": final.fit_after,
            "validation_before": fit_before_va,
            "validation_after": final.validation_after,
            "explained": final.explained,
            "delta_ic": top.delta_ic,
            "named_effects": named,
            "notes": [n for s in steps for n in s.notes],
        }
        events = _events_read(final, [e.name for e in (*st.tr, *st.va)])
        if events:
            report.best["events"] = events
        _finalise(report, final, st, data)
    else:
        eff = named[0]
        text = {
            "none": CATALOGUE["none"].explanation,
            "parameter_error": CATALOGUE["parameter_error"].explanation,
            "unexplained": "A significant mismatch remains that none of the hypotheses tried "
            "explains on held-out data, and a plain ARX predicts the held-out data better than "
            "the nominal model: the model lacks something outside the catalogue, or the data "
            "cannot separate the candidates (see the ranked hypotheses).",
        }[eff]
        report.best = {"effect": eff, "target": "", "explanation": text, "named_effects": named}
        if eff == "parameter_error":
            report.best["params"] = {
                p: r for p, r in par.get("parameters", {}).items() if r.get("moved")
            }
    report.seconds = time.perf_counter() - st.t0
    st.say(f"named: {', '.join(named)} ({report.seconds:.1f} s)")
    return report


#: Largest held-out ΔIC difference between two hypotheses the data do not tell apart (Kass &
#: Raftery 1995: below 6 on the BIC scale is weaker than "strong" evidence).
ALTERNATIVE_DIC = 6.0


def _alternatives(
    first: Hypothesis, sel: Selection, named: Sequence[str] = ()
) -> list[dict[str, Any]]:
    """Other effects the first round fitted about as well as the first one kept.

    Jointly refitted (not only screened) hypotheses of another effect whose held-out
    ΔIC is within :data:`ALTERNATIVE_DIC` of the first kept one's and that remove
    at least 90 % of the error it removes: the data do not tell them apart, and
    the report names the experiment that would. Effects already in the combination
    (``named``) are not alternatives to it; each entry says which effect it is an
    alternative to (``instead_of``).
    """
    out: list[dict[str, Any]] = []
    if first.last is None or not math.isfinite(first.delta_ic):
        return out
    seen = {first.last.effect, *named}
    for h in sel.first_round:
        c = h.last
        if c is None or h.screened or not h.ok or c.effect in seen:
            continue
        if not math.isfinite(h.delta_ic) or h.delta_ic > first.delta_ic + ALTERNATIVE_DIC:
            continue
        if first.explained > 0 and h.explained < 0.9 * first.explained:
            continue
        seen.add(c.effect)
        entry = CATALOGUE.get(c.effect)
        out.append(
            {
                "effect": c.effect,
                "form": c.form,
                "target": c.target,
                "delta_ic": h.delta_ic,
                "explained": h.explained,
                "instead_of": first.last.effect,
                "tell_apart": (
                    f"{entry.experiment('')} (for {c.effect}); "
                    f"{CATALOGUE[first.last.effect].experiment('')} (for {first.last.effect})"
                    if entry is not None and first.last.effect in CATALOGUE
                    else ""
                ),
            }
        )
    return out


def _finalise(
    report: DiagnosisReport, final: Hypothesis, st: _Run, data: list[dict[str, Any]]
) -> None:
    spec = _need(st.spec, "nominal spec")
    o = st.opts
    outs = st.outs
    exo = list(_need(st.model, "model").exogenous_names)
    alpha_adj = _need(st.tests, "residual tests")["alpha_adj"]
    tests_tr = _tests(outs, st.tr, final.sims_train, o["alpha"], o["max_lag"], exo)
    tests_va = _tests(outs, st.va, final.sims_val, o["alpha"], o["max_lag"], exo)
    report.detection_after = {
        "train": {x: t.to_dict(alpha_adj) for x, t in tests_tr.items()},
        "validation": {x: t.to_dict(alpha_adj) for x, t in tests_va.items()},
    }
    report.tests_after = {"train": tests_tr, "validation": tests_va}
    for s, sim in zip(report.series, [*final.sims_train, *final.sims_val], strict=True):
        s["augmented"] = sim
    model = _need(final.model, "kept hypothesis' model")
    theta = _need(final.theta, "kept hypothesis' values")
    if isinstance(model, AugmentedModel) and any(
        a["effect"] == "transport_delay" for a in model.augmentations
    ):
        # keep enough history for step-wise use of the fitted dead times
        cfg = model.config()
        dtm = min(e.dt for e in st.tr)
        for a in cfg["augmentations"]:
            if a["effect"] == "transport_delay":
                pname = ("delay_out_" if a.get("form") == "output" else "delay_") + a["signal"]
                d = float(theta[model.param_index(pname)])
                a["history"] = math.ceil(d / dtm) + 2
        base = model.base if not spec.registered else cfg["base"]
        model2 = AugmentedModel(
            base, None if not spec.registered else cfg["base_config"], cfg["augmentations"]
        )
        theta = np.array(
            [
                theta[model.param_index(p)]
                if p in model.param_names
                else model2.nominal[model2.param_index(p)]
                for p in model2.param_names
            ]
        )
        model = model2
    h2 = Hypothesis(
        candidates=final.candidates,
        model=model,
        free=final.free,
        bounds=final.bounds,
        theta=theta,
        outcome=final.outcome,
    )
    report.augmented_fit = _build_fit(
        model,
        h2,
        method="thermogym diagnosis: " + " + ".join(c.effect for c in final.candidates),
        settings={
            "named_effects": report.named_effects,
            "forms": [c.form for c in final.candidates],
            "targets": [c.target for c in final.candidates],
            "x0": st.x0,
            "scheme": report.scheme,
            "nominal_model": spec.name,
            "local_parameters_neutral": list(final.local),
            # event times read from each recording: neutral (no events) in the model saved
            "recorded_parameters_neutral": recorded_names(final.model) if final.model else [],
        },
        metrics={
            "train": {"nrmse": final.fit_after},
            "validation": {"nrmse": final.validation_after},
        },
        data=data,
        notes="; ".join(
            CATALOGUE[c.effect].explanation[:80] for c in final.candidates if c.effect in CATALOGUE
        ),
    )


def _events_read(final: Hypothesis, names: list[str]) -> list[dict[str, Any]]:
    """Disturbance events the final model read from each recording, with their sizes.

    ``[{"recording", "port", "events": [{"on_s", "off_s", "amplitude"}, ...]}, ...]``
    (times since the recording's start; training recordings first).
    """
    out: list[dict[str, Any]] = []
    vals = [*final.local_train, *final.local_val]
    if len(vals) != len(names):
        return out
    for c in final.candidates:
        if not c.recorded:
            continue
        port = c.augmentations[0]["signal"]
        for name, v in zip(names, vals, strict=True):
            rows, k = [], 0
            while f"dist_on{k}_{port}" in v:
                on, off = v[f"dist_on{k}_{port}"], v[f"dist_off{k}_{port}"]
                sg = v[f"dist_sg{k}_{port}"]
                amp = v.get(f"dist_ev{'neg' if sg < 0 else 'pos'}_{port}", math.nan)
                if off > on and sg != 0:
                    rows.append({"on_s": on, "off_s": off, "amplitude": amp})
                k += 1
            out.append({"recording": name, "port": port, "events": rows})
    return out


def _build_fit(
    model: Model,
    h: Hypothesis,
    *,
    method: str,
    settings: dict[str, Any],
    metrics: dict[str, Any],
    data: list[dict[str, Any]],
    notes: str,
) -> FitResult:
    stderr = {p: math.nan for p in model.param_names}
    cov, cov_names = None, []
    out = h.outcome
    if out is not None:
        stderr.update({p: v for p, v in out.stderr.items() if p in stderr})
        if out.covariance is not None and all(p in model.param_names for p in out.covariance_names):
            cov = np.asarray(out.covariance).tolist()
            cov_names = list(out.covariance_names)
    b = {p.name: [p.lower, p.upper] for p in model.parameters}
    for p, (lo, hi) in h.bounds.items():
        if p in b:
            b[p] = [float(lo), float(hi)]
    th = np.asarray(h.theta, dtype=float).reshape(-1)
    for i, p in enumerate(model.param_names):
        lo, hi = b[p]
        b[p] = [min(lo, float(th[i])), max(hi, float(th[i]))]
    free = [p for p in h.free if p in model.param_names]
    return FitResult.from_model(
        model,
        th,
        stderr=stderr,
        covariance=cov,
        covariance_names=cov_names,
        bounds=b,
        fixed=[p for p in model.param_names if p not in free],
        method=method,
        settings=settings,
        metrics=metrics,
        data=data,
        notes=notes,
    )
