"""Figures of a diagnosis report (matplotlib, no display needed).

Plotting lives here, outside the numerical modules, which never import it.
:func:`report_figures` draws, for a :class:`~.report.DiagnosisReport`:

1. measured vs nominal vs augmented for the outputs that carry the error, on
   a training and a held-out recording;
2. the residual against the regime variable that located it (before and
   after), with the bin means;
3. the residual tests: autocorrelation and cross-correlation with the main
   input, with their bounds, before and after (as MATLAB's ``resid``);
4. the ranked hypotheses: held-out mean fit (%) of each against the nominal.
"""

from __future__ import annotations

import io
import math
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from thermogym.identification.metrics import fit_text
from thermogym.plotting import time_axis

__all__ = ["report_figures"]

_C_MEAS, _C_NOM, _C_AUG = "0.25", "#d62728", "#1f77b4"


def _png(fig: plt.Figure) -> bytes:
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format="png", dpi=100)
    finally:
        plt.close(fig)
    return buf.getvalue()


def _top_outputs(rep: Any, n: int = 2) -> list[str]:
    sig = [d["signal"] for d in rep.located.get("signals", [])]
    return sig[:n] or rep.outputs[:n]


def _pick_series(rep: Any, j: int) -> list[dict[str, Any]]:
    tr = [s for s in rep.series if s["role"] == "train"]
    va = [s for s in rep.series if s["role"] == "validation"]

    def err(s: dict[str, Any]) -> float:
        e = s["measured"][:, j] - s["nominal"][:, j]
        return float(np.nanmean(e**2))

    out = []
    if tr:
        out.append(max(tr, key=err))
    if va:
        out.append(max(va, key=err))
    return out


def fig_traces(rep: Any) -> bytes:
    """Measured vs nominal vs augmented, top outputs × a training and a held-out recording."""
    outs = _top_outputs(rep)
    j0 = rep.outputs.index(outs[0])
    series = _pick_series(rep, j0)
    fig, axes = plt.subplots(
        2 * len(outs),
        len(series),
        figsize=(5.2 * len(series), 2.6 * len(outs) + 1.0),
        squeeze=False,
        sharex="col",
        gridspec_kw={"height_ratios": [3, 1.3] * len(outs)},
    )
    for c, s in enumerate(series):
        t, xl = time_axis(s["time"], relative=True)
        for r, o in enumerate(outs):
            j = rep.outputs.index(o)
            ax, axr = axes[2 * r, c], axes[2 * r + 1, c]
            unit = rep.units.get(o, "")
            y = s["measured"][:, j]
            ax.plot(t, y, ".", ms=2.5, color=_C_MEAS, label="measured")
            ax.plot(t, s["nominal"][:, j], "--", lw=1.3, color=_C_NOM, label="nominal")
            axr.plot(t, y - s["nominal"][:, j], lw=0.9, color=_C_NOM)
            if "augmented" in s:
                ax.plot(t, s["augmented"][:, j], lw=1.3, color=_C_AUG, label="augmented")
                axr.plot(t, y - s["augmented"][:, j], lw=0.9, color=_C_AUG)
            axr.axhline(0.0, color="0.6", lw=0.6)
            ax.set_title(f"{s['name']} ({s['role']})", fontsize=9)
            ax.set_ylabel(f"{o} [{unit}]", fontsize=8)
            axr.set_ylabel("residual", fontsize=8)
            ax.grid(alpha=0.3)
            axr.grid(alpha=0.3)
        axes[-1, c].set_xlabel(xl)
    axes[0, 0].legend(fontsize=7, loc="best")
    fig.suptitle("measured vs nominal vs augmented model", fontsize=11)
    fig.tight_layout()
    return _png(fig)


def fig_regime(rep: Any) -> bytes | None:
    """Residual against the regime variable that located the mismatch."""
    regs = [r for r in rep.located.get("regimes", []) if r["kind"] != "experiment"]
    regs = regs or rep.located.get("regimes", [])
    if not regs or not rep.regime_values:
        return None
    top = regs[0]
    var = next((v for v in rep.regime_values if v.name == top["variable"]), None)
    if var is None:
        return None
    j = rep.outputs.index(top["signal"])
    x = np.concatenate(var.values)
    lab = np.concatenate(var.labels)
    e0 = np.concatenate([s["measured"][:, j] - s["nominal"][:, j] for s in rep.series])
    has_aug = all("augmented" in s for s in rep.series)
    e1 = (
        np.concatenate([s["measured"][:, j] - s["augmented"][:, j] for s in rep.series])
        if has_aug
        else None
    )
    fig, ax = plt.subplots(1, 2, figsize=(11, 4), gridspec_kw={"width_ratios": [2, 1]})
    step = max(1, x.size // 6000)
    ax[0].plot(x[::step], e0[::step], ".", ms=2, color=_C_NOM, alpha=0.4, label="nominal")
    if e1 is not None:
        ax[0].plot(x[::step], e1[::step], ".", ms=2, color=_C_AUG, alpha=0.4, label="augmented")
    ax[0].axhline(0.0, color="0.5", lw=0.7)
    xl = var.name + (f" [{rep.units.get(var.signal, '')}]" if var.signal else "")
    if var.kind in ("heating_cooling", "opening_closing"):
        xl = f"slope of {var.signal} [{rep.units.get(var.signal, '')}/min]"
    if var.kind == "time_in_run":
        xl = "time since start [h]"
    ax[0].set_xlabel(xl)
    ax[0].set_ylabel(f"residual of {top['signal']} [{rep.units.get(top['signal'], '')}]")
    ax[0].legend(fontsize=8, markerscale=4)
    ax[0].grid(alpha=0.3)
    nb = len(var.bins)
    pos = np.arange(nb)
    m0 = [np.nanmean(e0[lab == b]) if np.any(lab == b) else np.nan for b in range(nb)]
    ax[1].bar(pos - 0.2, m0, 0.4, color=_C_NOM, label="nominal")
    if e1 is not None:
        m1 = [np.nanmean(e1[lab == b]) if np.any(lab == b) else np.nan for b in range(nb)]
        ax[1].bar(pos + 0.2, m1, 0.4, color=_C_AUG, label="augmented")
    ax[1].set_xticks(pos)
    ax[1].set_xticklabels(var.bins, rotation=40, ha="right", fontsize=7)
    ax[1].axhline(0.0, color="0.5", lw=0.7)
    ax[1].set_title("mean residual per regime", fontsize=9)
    ax[1].legend(fontsize=7)
    fig.suptitle(
        f"residual of {top['signal']} vs {top['variable']} (η² = {top['eta2']:.2f})", fontsize=11
    )
    fig.tight_layout()
    return _png(fig)


def fig_tests(rep: Any) -> bytes | None:
    """Autocorrelation and input cross-correlation of the residual, before and after."""
    o = _top_outputs(rep, 1)[0]
    role = "validation"
    t0 = rep.tests_before.get(role, {}).get(o)
    if t0 is None:
        return None
    t1 = rep.tests_after.get(role, {}).get(o) if rep.tests_after else None
    inp = rep.exogenous[0]
    fig, ax = plt.subplots(1, 2, figsize=(11, 3.6))
    lags = np.arange(t0.autocorr.size)
    ax[0].stem(lags, t0.autocorr, linefmt=_C_NOM, markerfmt="o", basefmt=" ", label="nominal")
    if t1 is not None:
        ax[0].plot(lags + 0.15, t1.autocorr, "s", color=_C_AUG, ms=4, label="augmented")
    ax[0].axhspan(-t0.bound, t0.bound, color="0.85")
    ax[0].set_xlabel("lag [samples]")
    ax[0].set_title(f"autocorrelation of the residual of {o} ({role})", fontsize=9)
    ax[0].legend(fontsize=7)
    M = t0.max_lag
    tau = np.arange(-M, M + 1)
    if inp in t0.xcorr:
        ax[1].plot(tau, t0.xcorr[inp], color=_C_NOM, label="nominal")
        b = t0.xbound[inp]
        ax[1].axhspan(-b, b, color="0.85")
        if t1 is not None and inp in t1.xcorr:
            ax[1].plot(tau, t1.xcorr[inp], color=_C_AUG, label="augmented")
    ax[1].set_xlabel("lag [samples] (positive: input earlier)")
    ax[1].set_title(f"cross-correlation of {inp} and the residual", fontsize=9)
    ax[1].legend(fontsize=7)
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    return _png(fig)


def fig_hypotheses(rep: Any) -> bytes | None:
    """Held-out mean fit (NRMSE fit, %) of each hypothesis against the nominal model."""
    hs = [h for h in rep.hypotheses if "validation_after" in h]
    if not hs:
        return None
    hs = hs[:12]
    names = [f"{h['effect']} ({h.get('target', '')})"[:48] for h in hs]
    after = [h["validation_after"].get("mean", math.nan) for h in hs]
    before = hs[0]["validation_before"].get("mean", math.nan)
    fig, ax = plt.subplots(figsize=(8, 0.42 * len(hs) + 1.4))
    y = np.arange(len(hs))[::-1]
    colors = [
        _C_AUG if i == 0 and rep.best.get("effect") == hs[0]["effect"] else "0.6"
        for i in range(len(hs))
    ]
    ax.barh(y, [100.0 * a for a in after], color=colors)
    ax.axvline(100.0 * before, color=_C_NOM, ls="--", label=f"nominal {fit_text(before)}")
    ax.set_yticks(y)
    ax.set_yticklabels(names, fontsize=8)
    lo = min([before, *[a for a in after if math.isfinite(a)]])
    ax.set_xlim(100.0 * max(lo - 0.05 * (1 - lo) - 0.01, -1.0), 100.0)
    ax.set_xlabel("held-out mean fit [%] (NRMSE fit, 100 = perfect)")
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3, axis="x")
    ax.set_title("hypotheses, ranked by held-out improvement with a BIC penalty", fontsize=10)
    fig.tight_layout()
    return _png(fig)


def report_figures(rep: Any) -> dict[str, bytes]:
    """Every figure of a report as PNG bytes, by caption."""
    out: dict[str, bytes] = {}
    if rep.series:
        cap = (
            "Measured (dots), nominal (red, dashed) and augmented (blue) outputs that carry the "
            "error, with residuals"
        )
        out[cap] = fig_traces(rep)
    for cap, fn in (
        ("Residual against the operating regime that located the mismatch", fig_regime),
        ("Residual tests (as MATLAB resid): grey bands are the 99 % bounds", fig_tests),
        ("Hypotheses ranked on held-out data", fig_hypotheses),
    ):
        try:
            png = fn(rep)
        except (ValueError, IndexError, KeyError):  # a figure that cannot be drawn is left out
            png = None
        if png:
            out[cap] = png
    return out
