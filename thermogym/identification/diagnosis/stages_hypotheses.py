"""The stages of :func:`.run.diagnose` that propose and test hypotheses.

``hypotheses`` (the residual's signatures; the catalogue's candidate effects and
forms), ``selection`` (forward selection on held-out data, a generic extra state
beside each kept effect, the sparse regression when nothing fits) and
``identifiability`` (an interval for every reported parameter, or the experiment
that would identify it).
"""

from __future__ import annotations

from collections.abc import Sequence

from thermogym.identification.diagnosis.context import Context, signatures
from thermogym.identification.diagnosis.effects import CATALOGUE, candidates_for
from thermogym.identification.diagnosis.hypothesis import Candidate, Hypothesis
from thermogym.identification.diagnosis.identify import intervals
from thermogym.identification.diagnosis.proposers import course_baseline, generic_fix
from thermogym.identification.diagnosis.run_state import _need, _Run
from thermogym.identification.diagnosis.select import (
    Selection,
    _added,
    fit_hypothesis,
    forward_selection,
    passes,
)
from thermogym.identification.diagnosis.sindy import sparse_candidates


# ------------------------------------------------------------------ stage: hypotheses
def _stage_hypotheses(st: _Run) -> None:
    if not st.detected:
        return
    h = _need(st.nominal, "nominal fit")
    model = _need(st.model, "model")
    weights = _need(st.weights, "output weights")
    all_exps = [*st.tr, *st.va]
    share = {d["signal"]: d["share_of_error"] for d in st.located["signals"]}
    units = {s.name: s.unit for s in model.signals}
    no_units = all(units.get(o, "1") in ("1", "", None) for o in st.outs)
    st.ctx = Context(
        model=model,
        spec=_need(st.spec, "nominal spec"),
        theta=_need(h.theta, "nominal fit's values"),
        free=h.free,
        outputs=tuple(st.outs),
        time=[e.time for e in all_exps],
        dt=[e.dt for e in all_exps],
        u=[e.u for e in all_exps],
        y=[e.y for e in all_exps],
        sim=[*h.sims_train, *h.sims_val],
        is_train=[True] * len(st.tr) + [False] * len(st.va),
        sigma=st.sigma,
        scale={o: 1.0 / float(weights[j]) for j, o in enumerate(st.outs)},
        share=share,
        regimes=st.located["all_regimes"],
        assumed_celsius=no_units,
    )
    if no_units:
        st.notes.append(
            "the outputs carry no unit: heat-transfer hypotheses took them as temperatures in °C "
            "(give units in the recording's sidecar to decide otherwise)"
        )
    st.ctx.features = signatures(st.ctx)
    if st.data is not None:
        ctx = st.ctx
        st.data.course_baseline = lambda n: course_baseline(ctx, n)
    cands = candidates_for(st.ctx, list(st.opts["candidates"]) if st.opts["candidates"] else None)
    if st.opts["max_candidates"]:
        # the N a user asks for span the catalogue: a form's other places (a disturbance
        # beside the heater as well as through the surroundings) come after every form's
        # first, each group in the catalogue's order
        forms: set[tuple[str, str]] = set()
        first: list[Candidate] = []
        more: list[Candidate] = []
        for c in cands:
            (more if (c.effect, c.form) in forms else first).append(c)
            forms.add((c.effect, c.form))
        cands = [*first, *more][: st.opts["max_candidates"]]
    st.candidates = cands
    st.say(f"{len(cands)} candidate effects and forms")


# ------------------------------------------------------------------ stage: selection
def _stage_selection(st: _Run) -> None:
    if not st.detected or not st.candidates:
        st.selection = Selection()
        return
    spec = _need(st.spec, "nominal spec")
    nominal = _need(st.nominal, "nominal fit")
    data = _need(st.data, "scoring data")
    ctx = _need(st.ctx, "signature context")
    sel = forward_selection(spec, nominal, st.candidates, data, max_effects=st.opts["max_effects"])
    # a generic extra state with as many parameters beside each kept effect (item 6)
    parent = nominal
    for h in sel.steps:
        last = _added(h)
        if data.expired:
            data.skip(f"no generic-fix baseline beside {last.label}")
            continue
        n = max(2, h.k_global - parent.k_global)
        g = generic_fix(ctx, n)
        if last.effect == "missing_dynamics" and last.form == g.form:
            parent = h
            continue
        gh = fit_hypothesis(spec, parent, g, data, nominal)
        h.baseline = {
            **h.baseline,
            "generic_fix": f"{g.form} ({gh.k_global - parent.k_global} parameters)",
            "delta_ic": gh.delta_ic,
            "validation_after": gh.validation_after,
            "physics_favoured": bool(not gh.ok or h.delta_ic < gh.delta_ic),
        }
        if not h.baseline["physics_favoured"]:
            h.notes.append(
                "the evidence does not favour a physical explanation: a generic extra state "
                "with as many parameters fits the held-out data as well or better"
            )
        parent = h
    if not sel.steps and st.opts["sparse"]:
        if data.expired:
            data.skip("the sparse regression of the residual not tried")
        else:
            _sparse(st, sel)
    st.selection = sel


def _sparse(st: _Run, sel: Selection) -> None:
    spec = _need(st.spec, "nominal spec")
    nominal = _need(st.nominal, "nominal fit")
    data = _need(st.data, "scoring data")
    ctx = _need(st.ctx, "signature context")
    try:
        cands = sparse_candidates(ctx)
    except Exception as e:  # pysindy missing or failing: said, not fatal
        st.notes.append(f"sparse regression not run: {type(e).__name__}: {e}")
        return
    best = None
    for c in cands:
        h = fit_hypothesis(spec, nominal, c, data, nominal)
        sel.first_round.append(h)
        if passes(h, nominal, len(cands), data) and (best is None or h.delta_ic < best.delta_ic):
            best = h
    if best is not None:
        sel.steps.append(best)


# ------------------------------------------------------------------ stage: identifiability
def _stage_identifiability(st: _Run) -> None:
    final = st.selection.final if st.selection is not None else None
    if final is None:  # nothing kept
        return
    names = [p for p in final.free if p in final.extra or p in st.calibrated]
    if st.data is not None and st.data.expired:
        # their Jacobian is P + 1 more simulations of every recording, past the limit (5 s on
        # the spindle's 8 days); values are reported without intervals, and the report says so
        st.data.skip("intervals of the reported parameters not computed")
        final.notes.append(
            "intervals not computed: the time limit had passed (a longer time limit gives them)"
        )
        return
    exp = _experiments(final, names, st)
    weights = _need(st.weights, "output weights")
    try:
        final.intervals.update(intervals(final, names, st.tr, weights, st.x0, experiment=exp))
    except Exception as e:  # reported, not fatal
        final.notes.append(f"intervals not computed: {type(e).__name__}: {e}")


def _experiments(final: Hypothesis, names: Sequence[str], st: _Run) -> dict[str, str]:
    """Per parameter, the experiment that would identify it (from the effect that owns it)."""
    out: dict[str, str] = {}
    owner: dict[str, str] = {}
    spec = _need(st.spec, "nominal spec")
    for c in final.candidates:
        sub = spec.build([x for x in final.candidates if x is not c])
        for p in _need(final.model, "kept hypothesis' model").param_names:
            if p not in sub.param_names:
                owner[p] = c.effect
    for p in names:
        eff = owner.get(p, "parameter_error")
        text = CATALOGUE[eff].experiment(p) if eff in CATALOGUE else "a richer excitation"
        if eff == "input_dependent_heat_transfer" or "second level" in text:
            src = _source_of(final, p)
            if src:
                text = f"a second level of {src} in the training data"
        out[p] = text
    return out


def _source_of(final: Hypothesis, p: str) -> str | None:
    for c in final.candidates:
        for a in c.augmentations:
            if a.get("source") and a.get("signal") and p.endswith(str(a["signal"])):
                return str(a["source"])
    if any(c.internal for c in final.candidates) and final.model is not None:
        ins = [s.name for s in final.model.inputs]
        return ins[0] if ins else None
    return None
