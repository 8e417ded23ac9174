"""Residual analysis: whether a model mismatch is significant beyond noise.

Ljung's residual analysis (as MATLAB's ``resid``) asks two questions of the
simulation residual ``e = y − ŷ`` of a model:

* **whiteness** — is ``e`` uncorrelated with its own past? The Ljung-Box
  portmanteau statistic over lags 1..M::

      Q = N (N + 2) Σ_{k=1}^{M} r_e(k)² / (N − k)  ~  χ²(M)   under "e is white"

* **independence** — is ``e`` uncorrelated with the past of each input? For
  lags τ = 0..M the normalised cross-correlation ``r_eu(τ)`` has, when ``e``
  and ``u`` are independent, ``√N r_eu(τ) ~ N(0, P)`` with
  ``P = Σ_k r_e(k) r_u(k)`` (Ljung, *System Identification*, 2nd ed., sec.
  16.6), so colored residuals and inputs widen the bound instead of
  producing false alarms. The test uses the largest ``|r_eu(τ)|`` over the
  lags with a Bonferroni correction.

The thermal grey-box practice of IEA EBC Annex 58 reads the outcome: residuals
that are autocorrelated but independent of the inputs call for more states
(missing dynamics, an unmeasured disturbance); residuals correlated with an
explanatory variable call for including it (its effect is mis-modelled).

All correlations are computed by FFT (``O(N log N)``), so a day at 1 Hz
(86,400 samples) takes milliseconds. NaN samples (missing measurements) are
set to zero after removing the mean, which shrinks correlations slightly but
never invents them.

Statistical significance alone is not enough at 86,400 samples: a residual a
few percent of the noise level is "significant". A mismatch also has to be
*material*: the systematic part of the residual (its RMS with the noise
variance removed) must exceed a fraction of the noise level and of the
signal's spread. The noise level is estimated from the residual itself, from
its second differences (robust, insensitive to slow systematic errors)::

    σ̂ = 1.4826 · median(|Δ²e − median(Δ²e)|) / √6
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import fft as sfft
from scipy import stats

from thermogym.errors import ShapeError

__all__ = [
    "ResidualTest",
    "autocorrelation",
    "cross_correlation",
    "noise_sigma",
    "residual_tests",
]


def _prep(x: ArrayLike) -> tuple[NDArray[np.float64], int]:
    a = np.asarray(x, dtype=float)
    if a.ndim != 1:
        raise ShapeError(f"expected a 1-D series, got shape {a.shape}")
    ok = np.isfinite(a)
    n = int(ok.sum())
    if n == 0:
        return np.zeros_like(a), 0
    out = np.where(ok, a - a[ok].mean(), 0.0)
    return out, n


def cross_correlation(a: ArrayLike, b: ArrayLike, max_lag: int) -> NDArray[np.float64]:
    """Normalised cross-correlation ``r_ab(τ)`` for τ = −M..M, by FFT.

    ``r_ab(τ) = Σ_k a[k + τ] b[k] / √(Σ a² Σ b²)`` of the demeaned series, so a
    positive ``τ`` correlates ``a`` with the *past* of ``b`` (for ``a`` the
    residual and ``b`` an input: the input acting ``τ`` samples before).

    Parameters
    ----------
    a, b : array_like, shape (N,)
        Series of equal length; NaN samples count as zero deviation.
    max_lag : int
        Largest lag M, 0 <= M < N.

    Returns
    -------
    ndarray, shape (2M + 1,)
        Index ``M + τ`` holds ``r_ab(τ)``; zeros when a series is constant.

    Examples
    --------
    >>> import numpy as np
    >>> u = np.random.default_rng(0).standard_normal(1000)
    >>> e = np.roll(u, 3)          # e[k] = u[k - 3]
    >>> r = cross_correlation(e, u, 5)
    >>> int(np.argmax(r)) - 5
    3
    """
    x, _ = _prep(a)
    y, _ = _prep(b)
    N = x.size
    if y.size != N:
        raise ShapeError(f"series have {N} and {y.size} samples; expected equal lengths")
    M = int(max_lag)
    if not 0 <= M < N:
        raise ShapeError(f"max_lag is {max_lag!r}; expected 0 <= max_lag < {N}")
    den = math.sqrt(float(np.dot(x, x)) * float(np.dot(y, y)))
    if den == 0.0:
        return np.zeros(2 * M + 1)
    n = sfft.next_fast_len(2 * N - 1, real=True)
    c = sfft.irfft(sfft.rfft(x, n) * np.conj(sfft.rfft(y, n)), n)
    # c[τ] = Σ_k x[k+τ] y[k]; negative lags wrap to the end
    out = np.concatenate([c[n - M :], c[: M + 1]]) if M else c[:1]
    return out / den


def autocorrelation(e: ArrayLike, max_lag: int) -> NDArray[np.float64]:
    """Normalised autocorrelation ``r_e(k)``, k = 0..M, by FFT (``r_e(0) = 1``).

    Examples
    --------
    >>> import numpy as np
    >>> r = autocorrelation(np.random.default_rng(1).standard_normal(86400), 25)
    >>> bool(r[0] == 1.0 and np.all(np.abs(r[1:]) < 4 / np.sqrt(86400)))
    True
    """
    r = cross_correlation(e, e, max_lag)
    M = int(max_lag)
    out = r[M:]
    return out / out[0] if out[0] != 0 else out


def noise_sigma(e: ArrayLike) -> float:
    """Robust white-noise level of a series from its second differences.

    ``Δ²`` removes slow (systematic) variation; the MAD is insensitive to the
    few large jumps at input edges. For white noise of level σ, ``Δ²e`` has
    variance ``6σ²``.

    Returns
    -------
    float
        σ̂ (NaN for fewer than 5 valid samples).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(2)
    >>> t = np.arange(5000.0)
    >>> round(noise_sigma(np.sin(t / 500) + 0.1 * rng.standard_normal(t.size)), 2)
    0.1
    """
    a = np.asarray(e, dtype=float)
    d2 = a[2:] - 2.0 * a[1:-1] + a[:-2]
    d2 = d2[np.isfinite(d2)]
    if d2.size < 3:
        return math.nan
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return 1.4826 * mad / math.sqrt(6.0)


@dataclass
class ResidualTest:
    """Residual tests of one output over one or several recordings (pooled).

    Attributes
    ----------
    signal : str
    n_samples : int
        Valid residual samples, all recordings together.
    max_lag : int
    autocorr : ndarray, shape (M + 1,)
        Sample-weighted mean autocorrelation over the recordings.
    bound : float
        ``z_{1−α/2} / √N``: the band white residuals stay in (plots).
    q_stat, q_dof, p_white : float
        Pooled Ljung-Box statistic, its degrees of freedom and p-value.
    xcorr : dict of str to ndarray
        Per input, the weighted mean cross-correlation for τ = −M..M.
    xbound : dict of str to float
        Per input, ``z_{1−α/2} √P / √N``.
    p_independent : dict of str to float
        Per input, Bonferroni p-value of the largest ``|r_eu(τ)|``, τ = 0..M.
    rms : float
        Residual RMS.
    sigma : float
        Noise level estimated from the residual (:func:`noise_sigma`).
    systematic_rms : float
        ``√max(0, rms² − σ̂²)``: the part of the residual that is not noise.
    scale : float
        Spread (standard deviation) of the measured signal.
    """

    signal: str
    n_samples: int
    max_lag: int
    autocorr: NDArray[np.float64]
    bound: float
    q_stat: float
    q_dof: int
    p_white: float
    xcorr: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    xbound: dict[str, float] = field(default_factory=dict)
    p_independent: dict[str, float] = field(default_factory=dict)
    rms: float = math.nan
    sigma: float = math.nan
    systematic_rms: float = math.nan
    scale: float = math.nan

    def white(self, alpha: float) -> bool:
        """Whether whiteness is accepted at level ``alpha``."""
        return bool(self.p_white >= alpha)

    def independent(self, alpha: float) -> dict[str, bool]:
        """Per input, whether independence is accepted at level ``alpha``."""
        return {k: bool(p >= alpha) for k, p in self.p_independent.items()}

    def material(self, min_snr: float, min_rel: float) -> bool:
        """Whether the systematic residual is large enough to matter.

        Parameters
        ----------
        min_snr : float
            Least ``systematic_rms / σ̂``.
        min_rel : float
            Least ``systematic_rms / scale`` (fraction of the signal's spread).
        """
        if not math.isfinite(self.systematic_rms):
            return False
        noise_ok = (not math.isfinite(self.sigma)) or self.systematic_rms >= min_snr * self.sigma
        rel_ok = (not math.isfinite(self.scale)) or self.systematic_rms >= min_rel * self.scale
        return bool(noise_ok and rel_ok)

    def to_dict(self, alpha: float) -> dict[str, Any]:
        """JSON-ready summary (correlations rounded for size)."""
        return {
            "signal": self.signal,
            "n_samples": self.n_samples,
            "max_lag": self.max_lag,
            "whiteness": {
                "q_stat": self.q_stat,
                "dof": self.q_dof,
                "p_value": self.p_white,
                "white": self.white(alpha),
                "autocorr_lag1": float(self.autocorr[1]) if self.autocorr.size > 1 else math.nan,
                "bound": self.bound,
            },
            "independence": {
                k: {
                    "p_value": p,
                    "independent": bool(p >= alpha),
                    "max_abs_xcorr": float(np.max(np.abs(self.xcorr[k][self.max_lag :]))),
                    "peak_lag": int(np.argmax(np.abs(self.xcorr[k][self.max_lag :]))),
                    "bound": self.xbound[k],
                }
                for k, p in self.p_independent.items()
            },
            "rms": self.rms,
            "noise_sigma": self.sigma,
            "systematic_rms": self.systematic_rms,
            "signal_scale": self.scale,
        }


def residual_tests(
    residuals: Sequence[ArrayLike],
    inputs: Sequence[Mapping[str, ArrayLike]],
    *,
    signal: str = "e",
    measured: Sequence[ArrayLike] | None = None,
    max_lag: int = 25,
    alpha: float = 0.01,
) -> ResidualTest:
    """Whiteness and input-independence tests of one output over recordings.

    Parameters
    ----------
    residuals : sequence of array_like, each shape (N_r,)
        ``y − ŷ`` of one output in each recording.
    inputs : sequence of mapping
        Per recording, input name → series (N_r,).
    signal : str
        Name of the output (for the report).
    measured : sequence of array_like, optional
        The measured output per recording (for its spread).
    max_lag : int
        Largest lag M [samples] (MATLAB ``resid`` default 25); reduced for
        short recordings to N/4.
    alpha : float
        Level of the plotted bounds (the p-values do not depend on it).

    Returns
    -------
    ResidualTest

    Raises
    ------
    ShapeError
        No recording, mismatched lengths.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(3)
    >>> u = (np.arange(20000) % 400 < 200).astype(float)
    >>> white = residual_tests([rng.standard_normal(20000)], [{"u": u}])
    >>> bool(white.p_white > 0.01 and white.p_independent["u"] > 0.01)
    True
    >>> lagged = 0.2 * np.convolve(u, np.ones(50) / 50)[:20000]
    >>> bad = residual_tests([rng.standard_normal(20000) + lagged], [{"u": u}])
    >>> bool(bad.p_white < 1e-6 and bad.p_independent["u"] < 1e-6)
    True
    """
    if len(residuals) == 0:
        raise ShapeError("residual_tests needs at least one residual series")
    if len(inputs) != len(residuals):
        raise ShapeError(f"{len(residuals)} residual series but {len(inputs)} input mappings")
    z = float(stats.norm.ppf(1.0 - alpha / 2.0))
    n_total = 0
    q_total, dof_total = 0.0, 0
    acc_sum: NDArray[np.float64] | None = None
    names = list(inputs[0]) if inputs else []
    x_sum: dict[str, NDArray[np.float64]] = {}
    p_sum: dict[str, float] = {k: 0.0 for k in names}
    zmax: dict[str, float] = {k: 0.0 for k in names}
    n_lags_total: dict[str, int] = {k: 0 for k in names}
    sq, sig_num, sig_den = 0.0, 0.0, 0
    meas_vals: list[NDArray[np.float64]] = []
    M_used = int(max_lag)
    for r, (e, us) in enumerate(zip(residuals, inputs, strict=True)):
        ea = np.asarray(e, dtype=float)
        ok = np.isfinite(ea)
        N = int(ok.sum())
        if N < 8:
            continue
        M = max(1, min(int(max_lag), N // 4))
        M_used = min(M_used, M)
        rho = autocorrelation(ea, M)
        # Ljung-Box: Q = N (N + 2) Σ r_k² / (N − k)
        k = np.arange(1, M + 1)
        q = N * (N + 2) * float(np.sum(rho[1:] ** 2 / (N - k)))
        q_total += q
        dof_total += M
        acc = np.zeros(int(max_lag) + 1)
        acc[: M + 1] = rho
        acc_sum = acc * N if acc_sum is None else acc_sum + acc * N
        for name in names:
            ua = np.asarray(us[name], dtype=float)
            if ua.shape != ea.shape:
                raise ShapeError(
                    f"input {name!r} of recording {r} has shape {ua.shape}, residual {ea.shape}"
                )
            rx = cross_correlation(ea, ua, M)
            ru = autocorrelation(ua, M)
            # P = Σ_{k=−M..M} r_e(k) r_u(k): variance factor of √N r_eu(τ) under independence
            P = max(float(rho[0] * ru[0] + 2.0 * np.sum(rho[1:] * ru[1:])), 1e-12)
            stat = float(np.max(np.abs(rx[M:]))) * math.sqrt(N / P)
            if stat > zmax[name] or n_lags_total[name] == 0:
                zmax[name] = max(zmax[name], stat)
            n_lags_total[name] += M + 1
            full = np.zeros(2 * int(max_lag) + 1)
            full[int(max_lag) - M : int(max_lag) + M + 1] = rx
            x_sum[name] = full * N if name not in x_sum else x_sum[name] + full * N
            p_sum[name] += P * N
        sq += float(np.sum(ea[ok] ** 2))
        s = noise_sigma(ea)
        if math.isfinite(s):
            sig_num += s * s * N
            sig_den += N
        n_total += N
        if measured is not None:
            m = np.asarray(measured[r], dtype=float)
            meas_vals.append(m[np.isfinite(m)])
    if n_total == 0:
        raise ShapeError(
            f"residual of {signal!r} has fewer than 8 valid samples in every recording"
        )
    p_white = float(stats.chi2.sf(q_total, dof_total)) if dof_total else math.nan
    autocorr = (acc_sum / n_total) if acc_sum is not None else np.zeros(int(max_lag) + 1)
    xcorr = {k: v / n_total for k, v in x_sum.items()}
    xbound = {k: z * math.sqrt(p_sum[k] / n_total) / math.sqrt(n_total) for k in names}
    p_ind = {}
    for name in names:
        # two-sided normal tail of the largest statistic, Bonferroni over all lags tested
        p1 = 2.0 * float(stats.norm.sf(zmax[name]))
        p_ind[name] = float(min(1.0, p1 * max(n_lags_total[name], 1)))
    rms = math.sqrt(sq / n_total)
    sigma = math.sqrt(sig_num / sig_den) if sig_den else math.nan
    sys_rms = math.sqrt(max(0.0, rms * rms - sigma * sigma)) if math.isfinite(sigma) else rms
    scale = float(np.std(np.concatenate(meas_vals))) if meas_vals else math.nan
    return ResidualTest(
        signal=signal,
        n_samples=n_total,
        max_lag=int(max_lag),
        autocorr=autocorr,
        bound=z / math.sqrt(n_total),
        q_stat=q_total,
        q_dof=dof_total,
        p_white=p_white,
        xcorr=xcorr,
        xbound=xbound,
        p_independent=p_ind,
        rms=rms,
        sigma=sigma,
        systematic_rms=sys_rms,
        scale=scale,
    )
