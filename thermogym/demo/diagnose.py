"""Stage 3: diagnose the strut's concealed effect, model it, show the fit improve.

:func:`thermogym.identification.diagnosis.diagnose` runs blind: it gets the
nominal model name (``strut``), the training recording (20 m/min) and the
held-out ones (25 and 30 m/min), nothing about the rig. It tests the
residuals, locates the mismatch, ranks the effects of the vocabulary on
held-out data and returns the augmented model as a FitResult.
"""

from __future__ import annotations

import math
from typing import Any

from thermogym._fileio import atomic_write
from thermogym.demo.core import DemoContext, StageResult
from thermogym.demo.identify import save_fit
from thermogym.demo.rigs import CONCEALED
from thermogym.fitresult import load_fit
from thermogym.identification.diagnosis import diagnose
from thermogym.identification.metrics import fit_text

__all__ = ["load_diagnose", "stage_diagnose"]


def _f(d: dict[str, Any], k: str) -> float:
    v = d.get(k, math.nan)
    return float(v) if isinstance(v, int | float) else math.nan


def stage_diagnose(ctx: DemoContext, res: StageResult) -> None:
    """Diagnose the strut recordings, write the diagnosis report and the augmented fit."""
    ctx.need("recordings")
    strut = ctx.products["recordings"]["strut/steps"]
    lines: list[str] = []
    rep = diagnose(
        "strut",
        strut[:1],
        strut[1:],
        max_candidates=6 if ctx.quick else 12,
        progress=lines.append,
    )
    rep.save(ctx.path("diagnosis", "strut_diagnosis.json"))
    rep.save_html(ctx.path("diagnosis", "strut_diagnosis.html"))
    figs = rep.figures()
    names = ["traces", "regime", "tests", "hypotheses"]
    for i, (cap, png) in enumerate(figs.items()):
        tag = names[i] if i < len(names) else f"figure{i + 1}"
        p = ctx.path("figures", f"diagnose_strut_{tag}.png")
        atomic_write(p, lambda tmp, data=png: tmp.write_bytes(data))  # type: ignore[misc]
        res.figure(ctx.rel(p), cap)
    b = rep.best
    if rep.augmented_fit is not None:
        rel = save_fit(ctx, rep.augmented_fit, "strut_augmented")
        ctx.products["fit_strut_augmented"] = rep.augmented_fit
    else:
        rel = "(none)"
    ctx.products["diagnosis"] = rep
    fb, va_after, tr_after = rep.fit_before, b.get("validation_after", {}), b.get("fit_after", {})
    va_before = b.get("validation_before", fb["validation"])
    res.table(
        ["output", "train before", "train after", "held-out before", "held-out after"],
        [
            [o, *(fit_text(_f(d, o)) for d in (fb["train"], tr_after, va_before, va_after))]
            for o in [*rep.outputs, "mean"]
        ],
        "Fit (NRMSE fit, %; 100 % = perfect) of the nominal and the augmented strut model; "
        "held-out: 25 and 30 m/min",
    )
    hyp_rows = []
    for i, h in enumerate(rep.hypotheses[:6]):
        params = ", ".join(
            f"{k} = {v['value']:.3g} {v.get('unit', '')}".strip()
            for k, v in (h.get("params") or {}).items()
        )
        hyp_rows.append(
            [
                i + 1,
                h["effect"],
                h.get("target", ""),
                params[:80],
                fit_text(_f(h.get("validation_after", {}), "mean")),
                f"{100 * h.get('explained', 0.0):.0f} %",
            ]
        )
    res.table(
        ["rank", "effect", "target", "fitted extra parameters", "held-out mean fit", "explained"],
        hyp_rows,
        "Hypotheses from the effect vocabulary, ranked on held-out data (BIC penalty)",
    )
    found = b.get("effect", "none")
    ok = found == CONCEALED or b.get("maps_to") == CONCEALED
    where = ", ".join(d["signal"] for d in rep.located.get("signals", [])[:3])
    res.shows = (
        "The loop's mismatch step: the identified strut model fails at feed rates it was not "
        "trained on; the diagnosis locates where, names the missing physics from the effect "
        "vocabulary, fits it and shows the fit improve on training AND held-out data."
    )
    res.text = (
        f"Verdict: {rep.verdict}\n\n"
        f"The rig's concealed effect was `{CONCEALED}`; the top-ranked hypothesis is "
        f"`{found}`{' (' + b['target'] + ')' if b.get('target') else ''}: "
        f"**{'correct' if ok else 'not the concealed effect'}**. The mismatch is mostly in "
        f"{where or 'no output'}. The augmented model (`{rel}`) is a FitResult of the strut "
        "model with the effect switched on; stage 4 builds an environment from it. The full "
        "diagnosis report is in `diagnosis/strut_diagnosis.html` (JSON next to it).\n\n"
        + "\n".join(f"* {ln}" for ln in lines[:8])
    )
    res.highlights["diagnosis (strut)"] = (
        f"found `{found}` (concealed: `{CONCEALED}`, {'correct' if ok else 'WRONG'}); held-out "
        f"mean fit {fit_text(_f(va_before, 'mean'))} → {fit_text(_f(va_after, 'mean'))} in "
        f"{rep.seconds:.1f} s"
    )


def load_diagnose(ctx: DemoContext) -> None:
    """Products of an earlier diagnosis in ``ctx.out``: the augmented model's FitResult."""
    p = ctx.out / "fits" / "strut_augmented.json"
    if p.is_file():
        ctx.products["fit_strut_augmented"] = load_fit(p)
        ctx.products.setdefault("fit_paths", {})["strut_augmented"] = p
