"""The diagnosis report: JSON for machines, Markdown and self-contained HTML for people.

:class:`DiagnosisReport` is what :func:`~thermogym.identification.diagnosis.diagnose`
returns. Its JSON (:meth:`DiagnosisReport.to_dict`) has at least::

    {"format": "thermogym.diagnosis", "schema_version": 2,
     "named_effects": ["nonlinear_heat_transfer", "sensor_lag"],   # or ["none"] ...
     "combination": [{"effect", "form", "target", "share_of_explained_error", "params",
                      "baseline": {"generic_fix", "delta_ic", "physics_favoured"}}, ...],
     "nominal_adequate": true, "baseline": {ARX(2, 2) on the same data},
     "parameters": {"significant", "moved", "parameters": {name: {given, calibrated,
                    low, high, identifiable, note}}},
     "mismatch_detected": true,
     "located": {"signals": [...], "windows": [...], "regimes": [...]},
     "hypotheses": [{"rank": 1, "effect": ..., "target": ..., "explanation": ...,
                     "params": {name: {"value", "stderr", "unit"}},
                     "fit_before": {output: NRMSE, "mean": ...}, "fit_after": {...},
                     "validation_before": {...}, "validation_after": {...},
                     "score": ..., "delta_bic": ..., "explained": ...}, ...],
     "best": {"effect": ..., ...},
     "augmented_fit": {FitResult} | null,
     "nominal_fit": {FitResult}, "detection": {...}, "detection_after": {...}}

The HTML page embeds its figures as PNG data (one file to mail or archive);
the figures are drawn by :mod:`.plots`, imported only when a page is written.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import thermogym
from thermogym._checks import with_unit
from thermogym._fileio import atomic_write, atomic_write_text, to_jsonable
from thermogym.errors import ConfigError
from thermogym.fitresult import FitResult
from thermogym.identification.metrics import fit_text

__all__ = ["DiagnosisReport"]

FORMAT = "thermogym.diagnosis"
SCHEMA_VERSION = 2


def _public(d: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in d.items() if not k.startswith("_")}


def _fit(v: Any) -> str:
    """An NRMSE fit (a fraction) as every command shows it: ``fit_text``, "–" when missing."""
    if isinstance(v, int | float) and math.isfinite(v):
        return fit_text(float(v))
    return "–"


def _f(v: Any, digits: int = 4) -> str:
    if isinstance(v, float):
        if not math.isfinite(v):
            return "–"
        return f"{v:.{digits}g}"
    return str(v)


@dataclass
class DiagnosisReport:
    """Outcome of a diagnosis (see the module docstring for the JSON layout).

    Attributes
    ----------
    model : str
        Nominal model name.
    model_config : dict
    outputs : list of str
        Compared outputs.
    exogenous : list of str
    units : dict
    mismatch_detected : bool
    alpha : float
    detection : dict
        Residual tests of the nominal model on training and validation data.
    located : dict
        Signals, windows, regimes.
    nominal_fit : FitResult
    fit_before : dict
        NRMSE per output of the nominal model, training and validation.
    hypotheses : list of dict
        Ranked hypotheses.
    best : dict
        The winner (``effect`` is ``none`` or ``unexplained`` when there is none).
    augmented_fit : FitResult or None
    detection_after : dict
        Residual tests of the winner.
    scheme : str
        ``split`` or ``crossfit``.
    named_effects : list of str
        What the diagnosis names, in order: the physics effects kept by the
        forward selection (then ``parameter_error`` when re-calibrating the
        given parameters was needed too), or ``["parameter_error"]``,
        ``["none"]``, ``["unexplained"]``.
    combination : list of dict
        Each kept effect with its form, its share of the explained held-out
        error, its parameters and the generic fix beside it.
    parameters : dict
        The parameter-or-physics test: given against re-calibrated parameters.
    baseline : dict
        The plain ARX baseline on the same data.
    alternatives : list of dict
        Other effects the held-out data fit about as well as the first effect kept
        (``instead_of``; ΔIC within 6), with the experiment that would tell them apart.
    complete : bool
        False when the time limit cut the search short (``incomplete`` says
        what was left out; the ranking covers only what was tried).
    incomplete : list of str
    nominal_adequate : bool
        Whether the nominal model predicts the held-out data at least as well
        as the plain ARX.
    """

    model: str
    model_config: dict[str, Any]
    outputs: list[str]
    exogenous: list[str]
    units: dict[str, str]
    mismatch_detected: bool
    alpha: float
    detection: dict[str, Any]
    located: dict[str, Any]
    nominal_fit: FitResult
    fit_before: dict[str, Any]
    hypotheses: list[dict[str, Any]] = field(default_factory=list)
    best: dict[str, Any] = field(default_factory=dict)
    augmented_fit: FitResult | None = None
    detection_after: dict[str, Any] = field(default_factory=dict)
    scheme: str = ""
    signatures: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0
    named_effects: list[str] = field(default_factory=list)
    combination: list[dict[str, Any]] = field(default_factory=list)
    parameters: dict[str, Any] = field(default_factory=dict)
    baseline: dict[str, Any] = field(default_factory=dict)
    nominal_adequate: bool = True
    complete: bool = True
    incomplete: list[str] = field(default_factory=list)
    alternatives: list[dict[str, Any]] = field(default_factory=list)
    stages: dict[str, float] = field(default_factory=dict)
    selection: list[dict[str, Any]] = field(default_factory=list)
    # arrays kept for figures (not in the JSON)
    series: list[dict[str, Any]] = field(default_factory=list, repr=False)
    regime_values: list[Any] = field(default_factory=list, repr=False)
    tests_before: dict[str, Any] = field(default_factory=dict, repr=False)
    tests_after: dict[str, Any] = field(default_factory=dict, repr=False)

    # ------------------------------------------------------------------ JSON
    @property
    def verdict(self) -> str:
        """One sentence (or two): what was found."""
        named = self.named_effects or [self.best.get("effect", "none")]
        lead = ""
        if not self.complete:
            why = (self.incomplete[0].split(": ")[0]) if self.incomplete else "time limit reached"
            lead = (
                f"Incomplete search ({why}; what was left out is listed under 'incomplete', "
                "and a longer time limit gives the whole search). "
            )
        if not self.nominal_adequate:
            b = self.baseline.get("validation", {}).get("mean", math.nan)
            n = self.baseline.get("nominal_validation", {}).get("mean", math.nan)
            lead += (
                f"Nominal model inadequate: a plain ARX predicts the held-out data better "
                f"(mean fit {fit_text(b)} against {fit_text(n)}). "
            )
        where = ", ".join(d["signal"] for d in self.located.get("signals", [])[:2])
        if named == ["none"]:
            flagged = [
                o
                for part in ("validation", "train")
                for o, t in self.detection.get(part, {}).items()
                if isinstance(t, dict) and t.get("significant")
            ]
            if not flagged:
                return lead + (
                    "No significant mismatch: the model reproduces the recordings to within "
                    "their noise."
                )
            b = self.baseline.get("validation", {}).get("mean", math.nan)
            n = self.baseline.get("nominal_validation", {}).get("mean", math.nan)
            return lead + (
                f"No missing physics named: the residual of {', '.join(dict.fromkeys(flagged))} "
                "is not white, but no hypothesis explains it on held-out data and the nominal "
                "model predicts them at least as well as a plain ARX (held-out mean fit "
                f"{fit_text(n)} against {fit_text(b)}): what is left is coloured noise or an "
                "effect outside the catalogue."
            )
        if named == ["unexplained"]:
            return lead + (
                f"Significant mismatch (mostly {where}); no hypothesis explains it on held-out "
                "data."
            )
        if named == ["parameter_error"]:
            moved = self.parameters.get("moved", [])
            if self.detection.get("residual_structure"):
                # the detection ran on the re-calibrated model: its residual is still
                # significant and material, so re-calibration is not the whole answer
                return lead + (
                    "Parameter error: re-calibrating the model's own parameters "
                    f"({', '.join(moved) or 'within their intervals'}) explains part of the "
                    f"mismatch, but the re-calibrated model still misses the recordings "
                    f"significantly (mostly {where or 'on every output'}) and no hypothesis "
                    "explains the rest on held-out data: coloured noise or physics outside the "
                    "catalogue."
                )
            return lead + (
                "Parameter error: re-calibrating the model's own parameters "
                f"({', '.join(moved) or 'within their intervals'}) explains the mismatch; no "
                "physics is missing."
            )
        parts = []
        for c in self.combination:
            share = c.get("share_of_explained_error", math.nan)
            parts.append(
                f"'{c['effect']}' ({c['form']}, {c['target']}"
                + (f", {100 * share:.0f} % of the explained error" if math.isfinite(share) else "")
                + ")"
            )
        before = self.best.get("validation_before", {}).get("mean", math.nan)
        after = self.best.get("validation_after", {}).get("mean", math.nan)
        extra = " Parameters re-calibrated too." if "parameter_error" in named else ""
        doubt = ""
        if any(not c.get("baseline", {}).get("physics_favoured", True) for c in self.combination):
            doubt = (
                " The evidence does not favour a physical explanation over a generic extra "
                "state for every effect (see the baselines)."
            )
        alt = ""
        if self.alternatives:
            alt = (
                " The data fit "
                + ", ".join(
                    f"'{a['effect']}' ({a['form']}, {a['target']})" for a in self.alternatives
                )
                + f" about as well as '{self.alternatives[0].get('instead_of', named[0])}' "
                "(see alternatives: the experiment that tells "
                "them apart)."
            )
        return lead + (
            f"Significant mismatch (mostly {where}): missing physics {' + '.join(parts)}; "
            f"held-out mean fit {fit_text(before)} → {fit_text(after)}.{extra}{doubt}{alt}"
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (NaN and infinities as null)."""
        hyps = []
        for i, h in enumerate(self.hypotheses):
            hyps.append({"rank": i + 1, **_public(h)})
        located = {k: v for k, v in self.located.items() if k != "all_regimes"}
        best = _public(self.best)
        doc = {
            "format": FORMAT,
            "schema_version": SCHEMA_VERSION,
            "model": self.model,
            "model_config": self.model_config,
            "outputs": self.outputs,
            "verdict": self.verdict,
            "named_effects": list(self.named_effects),
            "combination": self.combination,
            "nominal_adequate": self.nominal_adequate,
            "complete": self.complete,
            "incomplete": list(self.incomplete),
            "alternatives": self.alternatives,
            "baseline": self.baseline,
            "parameters": self.parameters,
            "selection": self.selection,
            "mismatch_detected": self.mismatch_detected,
            "located": located,
            "hypotheses": hyps,
            "best": best,
            "fit_before": self.fit_before,
            "fit_after": {
                "train": best.get("fit_after", {}),
                "validation": best.get("validation_after", {}),
            },
            "scheme": self.scheme,
            "detection": self.detection,
            "detection_after": self.detection_after,
            "augmented_fit": self.augmented_fit.to_dict() if self.augmented_fit else None,
            "nominal_fit": self.nominal_fit.to_dict(),
            "signatures": self.signatures,
            "notes": self.notes,
            "seconds": self.seconds,
            "stage_seconds": self.stages,
            "package_version": thermogym.__version__,
        }
        return to_jsonable(doc, "diagnosis report")

    def to_json(self) -> str:
        """The report as JSON text."""
        return json.dumps(self.to_dict(), indent=2, ensure_ascii=False, allow_nan=False) + "\n"

    def save(self, path: str | os.PathLike[str], *, overwrite: bool = True) -> Path:
        """Write the JSON report atomically (an existing file survives a failure)."""
        try:
            return atomic_write_text(path, self.to_json(), overwrite=overwrite)
        except FileExistsError as e:
            raise ConfigError(f"not writing the report: {e}") from e

    # ------------------------------------------------------------------ Markdown
    def _fit_rows(self) -> list[list[str]]:
        rows = []
        b = self.best
        for o in [*self.outputs, "mean"]:
            rows.append(
                [
                    o,
                    _fit(self.fit_before["train"].get(o, math.nan)),
                    _fit(b.get("fit_after", {}).get(o, math.nan)),
                    _fit(
                        b.get("validation_before", self.fit_before["validation"]).get(o, math.nan)
                    ),
                    _fit(b.get("validation_after", {}).get(o, math.nan)),
                ]
            )
        return rows

    def _hyp_rows(self) -> list[list[str]]:
        rows = []
        for i, h in enumerate(self.hypotheses):
            params = ", ".join(
                f"{k} = {with_unit(_f(v['value'], 3), v['unit'])}"
                for k, v in (h.get("params") or {}).items()
                if not k.startswith(("dist_cos",))
            )
            rows.append(
                [
                    str(i + 1),
                    h["effect"],
                    h.get("target", ""),
                    params if "error" not in h else h["error"][:60],
                    _fit(h.get("validation_before", {}).get("mean", math.nan)),
                    _fit(h.get("validation_after", {}).get("mean", math.nan)),
                    f"{100 * h.get('explained', 0.0):.0f} %",
                    _f(h.get("score", math.nan), 5),
                ]
            )
        return rows

    def _test_rows(self) -> list[list[str]]:
        rows = []
        for role in ("train", "validation"):
            for o in self.outputs:
                d0 = self.detection.get(role, {}).get(o)
                d1 = self.detection_after.get(role, {}).get(o) if self.detection_after else None
                if d0 is None:
                    continue

                def ind(d: dict[str, Any] | None) -> str | float:
                    if not d:
                        return "–"
                    return min((v["p_value"] for v in d["independence"].values()), default=math.nan)

                rows.append(
                    [
                        role,
                        o,
                        _f(d0["whiteness"]["p_value"], 2),
                        _f(ind(d0), 2),
                        _f(d0["rms"], 3),
                        _f(d1["whiteness"]["p_value"], 2) if d1 else "–",
                        _f(ind(d1), 2) if d1 else "–",
                        _f(d1["rms"], 3) if d1 else "–",
                        _f(d0["noise_sigma"], 3),
                    ]
                )
        return rows

    def to_markdown(self, figures: dict[str, str] | None = None) -> str:
        """A readable report; ``figures`` maps captions to image paths or data URIs."""

        def table(header: list[str], rows: list[list[str]]) -> str:
            lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
            lines += ["| " + " | ".join(r) + " |" for r in rows]
            return "\n".join(lines)

        b = self.best
        alpha_test = self.detection.get("alpha_per_test", math.nan)
        mat = self.detection.get("materiality", {})
        parts = [
            f"# Mismatch diagnosis: model `{self.model}`",
            "",
            f"**{self.verdict}**",
            "",
        ]

        def params_table(params: dict[str, Any]) -> str:
            return table(
                ["parameter", "value", "95 % interval", "unit", "meaning"],
                [
                    [
                        k,
                        _f(v.get("value", math.nan), 4),
                        (
                            f"{_f(v.get('low', math.nan), 3)} … {_f(v.get('high', math.nan), 3)}"
                            if v.get("identifiable", True)
                            else v.get("note", "not identifiable from these data")
                        ),
                        v.get("unit", ""),
                        v.get("description", ""),
                    ]
                    for k, v in params.items()
                ],
            )

        if not self.nominal_adequate and self.baseline:
            parts += [
                "## Nominal model inadequate",
                "",
                f"A plain {self.baseline.get('model', 'ARX')} fitted on the same training data "
                f"({self.baseline.get('n_params', '?')} parameters) predicts the held-out data "
                f"better: mean fit {_fit(self.baseline.get('validation', {}).get('mean'))} "
                f"against the nominal model's "
                f"{_fit(self.baseline.get('nominal_validation', {}).get('mean'))}. What follows "
                "stands on a model that misses more than one effect can explain.",
                "",
            ]
        if not self.complete:
            parts += [
                "## Incomplete search",
                "",
                "The time limit cut the search short; the ranking below covers only what was "
                "tried:",
                "",
                *[f"* {x}" for x in self.incomplete],
                "",
            ]
        if self.alternatives:
            parts += [
                "## Alternatives the data do not tell apart",
                "",
                *[
                    f"* `{a['effect']}` ({a['form']}, {a['target']}) instead of "
                    f"`{a.get('instead_of', '')}`: held-out ΔIC "
                    f"{a['delta_ic']:.1f}, {100 * a['explained']:.0f} % of the systematic error "
                    f"removed. To tell them apart: {a['tell_apart']}."
                    for a in self.alternatives
                ],
                "",
            ]
        if self.combination:
            parts += ["## What is missing", ""]
            for c in self.combination:
                eff = c["effect"]
                share = c.get("share_of_explained_error", math.nan)
                parts += [
                    f"### `{eff}`: {c['form']} ({c['target']}), "
                    f"{100 * share:.0f} % of the explained error"
                    if isinstance(share, float) and math.isfinite(share)
                    else f"### `{eff}`: {c['form']} ({c['target']})",
                    "",
                ]
                if c.get("evidence"):
                    parts += [f"*Residual signature:* {c['evidence']}.", ""]
                if c.get("params"):
                    parts += [params_table(c["params"]), ""]
                base = c.get("baseline") or {}
                if base:
                    parts += [
                        f"Beside it, a generic fix ({base.get('generic_fix', '')}): held-out "
                        f"ΔIC {_f(base.get('delta_ic'), 4)} against this effect's "
                        f"{_f(c.get('delta_ic'), 4)}"
                        + (
                            "."
                            if base.get("physics_favoured", True)
                            else ": **the evidence does not favour a physical explanation**."
                        ),
                        "",
                    ]
            if b.get("explanation"):
                parts += [b["explanation"], ""]
        elif b.get("effect") == "parameter_error":
            parts += ["## Parameter error", "", b.get("explanation", ""), ""]
            if self.parameters.get("parameters"):
                parts += [params_table(self.parameters["parameters"]), ""]
        elif b.get("effect") not in (None, "none"):
            parts += [f"## `{b['effect']}`", "", b.get("explanation", ""), ""]
        parts += [
            "## Fit before and after (NRMSE fit, %; 100 % = perfect)",
            "",
            table(
                ["output", "train before", "train after", "held-out before", "held-out after"],
                self._fit_rows(),
            ),
            "",
        ]
        if self.scheme == "crossfit":
            parts += [
                "Held-out numbers are cross-fitted: each validation recording is predicted by "
                "models fitted on the training recordings and the other validation recordings "
                "(the training data alone hold no sign of the mismatch).",
                "",
            ]
        sig = self.located.get("signals", [])
        parts += [
            "## Where",
            "",
            table(
                ["output", "share of error", "RMS", "noise σ", "RMS / σ"],
                [
                    [
                        d["signal"],
                        f"{100 * d['share_of_error']:.1f} %",
                        _f(d["rms"], 3),
                        _f(d["noise_sigma"], 3),
                        _f(d["rms_over_noise"], 3),
                    ]
                    for d in sig
                ],
            ),
            "",
        ]
        regs = self.located.get("regimes", [])
        if regs:
            parts += [
                table(
                    ["regime", "output", "η²", "worst", "mean residual per bin"],
                    [
                        [
                            r["variable"],
                            r["signal"],
                            f"{r['eta2']:.2f}",
                            r["worst_bin"],
                            "; ".join(f"{x['bin']}: {_f(x['mean'], 3)}" for x in r["bins"][:6]),
                        ]
                        for r in regs
                    ],
                ),
                "",
            ]
        win = self.located.get("windows", [])
        if win:
            parts += [
                table(
                    ["recording", "output", "from [s]", "to [s]", "mean residual"],
                    [
                        [
                            w["recording"],
                            w["signal"],
                            _f(w["t_start_s"], 6),
                            _f(w["t_end_s"], 6),
                            _f(w["mean_residual"], 3),
                        ]
                        for w in win
                    ],
                ),
                "",
            ]
        if self.hypotheses:
            parts += [
                "## Hypotheses (ranked on held-out data)",
                "",
                table(
                    [
                        "#",
                        "effect",
                        "target",
                        "fitted extra parameters",
                        "held-out before",
                        "held-out after",
                        "explained",
                        "score (−ΔBIC)",
                    ],
                    self._hyp_rows(),
                ),
                "",
            ]
        parts += [
            "## Residual tests (Ljung-Box whiteness, input independence; p-values)",
            "",
            table(
                [
                    "data",
                    "output",
                    "white p before",
                    "indep. p before",
                    "RMS before",
                    "white p after",
                    "indep. p after",
                    "RMS after",
                    "noise σ",
                ],
                self._test_rows(),
            ),
            "",
            f"Significance level per test: {_f(alpha_test, 3)} (α = {self.alpha:g}, Bonferroni); "
            f"a mismatch must also be material (systematic RMS ≥ {mat.get('min_snr', '?')} σ and "
            f"≥ {100 * mat.get('min_rel', 0):.1f} % of the spread).",
            "",
        ]
        if figures:
            parts += ["## Figures", ""]
            for cap, src in figures.items():
                parts += [f"![{cap}]({src})", "", f"*{cap}*", ""]
        if self.notes:
            parts += ["## Notes", "", *[f"* {n}" for n in self.notes], ""]
        parts += [f"*thermogym {thermogym.__version__}, {self.seconds:.1f} s*", ""]
        return "\n".join(parts)

    # ------------------------------------------------------------------ HTML
    def figures(self) -> dict[str, bytes]:
        """The report's figures as PNG bytes, by caption (draws with matplotlib)."""
        # lazy: the figures module loads matplotlib (~0.3 s), only needed when figures are drawn
        from thermogym.identification.diagnosis import plots

        return plots.report_figures(self)

    def to_html(self) -> str:
        """A self-contained HTML page (figures embedded as PNG data)."""
        figs = self.figures()
        uris = {
            cap: "data:image/png;base64," + base64.b64encode(png).decode("ascii")
            for cap, png in figs.items()
        }
        md = self.to_markdown()
        body = _markdown_to_html(md)
        imgs = "".join(
            f'<figure><img src="{src}" alt="{html.escape(cap)}"><figcaption>{html.escape(cap)}'
            "</figcaption></figure>"
            for cap, src in uris.items()
        )
        style = (
            "body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;"
            "color:#222}table{border-collapse:collapse;margin:1em 0;font-size:0.9em}"
            "td,th{border:1px solid #ccc;padding:3px 8px}th{background:#f3f3f3}"
            "img{max-width:100%}figure{margin:1.5em 0}figcaption{color:#555;font-style:italic}"
            "code{background:#f4f4f4;padding:0 3px}"
        )
        return (
            "<!DOCTYPE html><html><head><meta charset='utf-8'>"
            f"<title>thermogym diagnosis: {html.escape(self.model)}</title><style>{style}</style>"
            f"</head><body>{body}<h2>Figures</h2>{imgs}</body></html>\n"
        )

    def save_html(self, path: str | os.PathLike[str], *, overwrite: bool = True) -> Path:
        """Write the HTML page atomically."""
        try:
            return atomic_write_text(path, self.to_html(), overwrite=overwrite)
        except FileExistsError as e:
            raise ConfigError(f"not writing the HTML report: {e}") from e

    def save_markdown(
        self,
        path: str | os.PathLike[str],
        *,
        overwrite: bool = True,
        figures_dir: str | None = None,
    ) -> Path:
        """Write the Markdown report; figures go next to it as PNG files when asked."""
        p = Path(path)
        figs: dict[str, str] = {}
        if figures_dir is not None:
            folder = p.parent / figures_dir
            folder.mkdir(parents=True, exist_ok=True)
            for i, (cap, png) in enumerate(self.figures().items()):
                f = folder / f"figure{i + 1}.png"

                # a def rather than a lambda: mypy cannot infer a lambda with a default
                # argument (the default binds this loop's figure)
                def _write(tmp: Path, data: bytes = png) -> None:
                    tmp.write_bytes(data)

                atomic_write(f, _write)
                figs[cap] = f"{figures_dir}/{f.name}"
        try:
            return atomic_write_text(p, self.to_markdown(figs), overwrite=overwrite)
        except FileExistsError as e:
            raise ConfigError(f"not writing the Markdown report: {e}") from e


def _markdown_to_html(md: str) -> str:
    """The small Markdown subset of :meth:`DiagnosisReport.to_markdown` as HTML."""
    out: list[str] = []
    lines = md.splitlines()
    i = 0

    def inline(s: str) -> str:
        s = html.escape(s)
        s = re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", s)
        s = re.sub(r"`(.+?)`", r"<code>\1</code>", s)
        s = re.sub(r"\*(.+?)\*", r"<i>\1</i>", s)
        return s

    while i < len(lines):
        line = lines[i]
        if line.startswith("|"):
            rows = []
            while i < len(lines) and lines[i].startswith("|"):
                rows.append([c.strip() for c in lines[i].strip("|").split("|")])
                i += 1
            head, body = rows[0], [r for r in rows[1:] if not set("".join(r)) <= set("-")]
            out.append(
                "<table><tr>"
                + "".join(f"<th>{inline(c)}</th>" for c in head)
                + "</tr>"
                + "".join(
                    "<tr>" + "".join(f"<td>{inline(c)}</td>" for c in r) + "</tr>" for r in body
                )
                + "</table>"
            )
            continue
        if line.startswith("# "):
            out.append(f"<h1>{inline(line[2:])}</h1>")
        elif line.startswith("## "):
            out.append(f"<h2>{inline(line[3:])}</h2>")
        elif line.startswith("* "):
            out.append(f"<ul><li>{inline(line[2:])}</li></ul>")
        elif line.startswith("!["):
            pass
        elif line.strip():
            out.append(f"<p>{inline(line)}</p>")
        i += 1
    return "\n".join(out)
