"""Example external models shipped with thermogym.

* ``strut_script.py``: the strut's thermal network as a Python script with
  its five ratio parameters as variables (paper 000, section 4.2), for
  :class:`~thermogym.identification.external.ScriptModel`; used by
  ``benchmarks/global_fit.py`` to time a loop of script calls against the
  batched simulator.
* :func:`first_order_lag`: a function following the contract of
  :class:`~thermogym.identification.external.CallableModel`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "STRUT_OUTPUTS",
    "STRUT_RATIOS",
    "first_order_lag",
    "strut_config",
    "strut_script_path",
]

#: The five ratio parameters of paper 000 (appendix, Table 5) and their bounds.
STRUT_RATIOS: dict[str, tuple[float, float, float]] = {
    "r_motor": (1.0, 0.3, 3.0),
    "r_bearing": (1.0, 0.3, 3.0),
    "r_nut": (1.0, 0.3, 3.0),
    "r_spindle_air": (1.0, 0.8, 1.3),
    "r_tube_air": (1.0, 0.8, 1.3),
}
#: Outputs the script leaves (recording columns of the strut rig).
STRUT_OUTPUTS: tuple[str, ...] = (
    "T_drive",
    "T_belt_housing",
    "T_bearing",
    "T_nut",
    "T_spindle",
    "T_tube_front",
    "T_tube_rear",
    "dL_um",
)


def strut_script_path() -> Path:
    """Path of ``strut_script.py``."""
    return Path(__file__).with_name("strut_script.py")


def strut_config(
    outputs: tuple[str, ...] | list[str] | None = None, **overrides: Any
) -> dict[str, Any]:
    """Configuration of the strut script for :func:`.load_external`.

    Parameters
    ----------
    outputs : sequence of str, optional
        Outputs to compare (default: all of :data:`STRUT_OUTPUTS`).
    **overrides
        Further keys, e.g. ``timeout=60`` or ``evaluation={"backend": "serial"}``.

    Returns
    -------
    dict

    Examples
    --------
    >>> from thermogym.identification.external import load_external
    >>> model = load_external(strut_config(["T_nut"], evaluation={"backend": "serial"}))
    >>> model.param_names
    ('r_motor', 'r_bearing', 'r_nut', 'r_spindle_air', 'r_tube_air')
    >>> model.close()
    """
    cfg: dict[str, Any] = {
        "type": "script",
        "name": "strut_script",
        "path": str(strut_script_path()),
        "parameters": {
            k: {"start": s, "lower": lo, "upper": hi} for k, (s, lo, hi) in STRUT_RATIOS.items()
        },
        "fixed": {"T_ref": 20.0},
        "inputs": ["feed_rate", "T_air"],
        "outputs": list(outputs) if outputs is not None else list(STRUT_OUTPUTS),
        "timeout": 60.0,
    }
    cfg.update(overrides)
    return cfg


def first_order_lag(
    time: NDArray[np.float64], inputs: dict[str, NDArray[np.float64]], params: dict[str, float]
) -> dict[str, NDArray[np.float64]]:
    """First-order thermal lag ``tau dy/dt = -y + K u`` as a :class:`.CallableModel` function.

    The input is held between samples (zero-order hold), so the exact
    discrete solution is ``y[k+1] = a y[k] + (1 - a) K u[k]`` with
    ``a = exp(-(t[k+1] - t[k]) / tau)``; non-uniform grids are fine.

    Parameters
    ----------
    time : ndarray, shape (T,)
        Sample times [s].
    inputs : dict
        ``"u"``: heating power [W], shape (T,).
    params : dict
        ``"K"`` gain [K/W], ``"tau"`` time constant [s], optional ``"y0"``
        initial temperature rise [K].

    Returns
    -------
    dict
        ``"y"``: temperature rise [K], shape (T,).

    Examples
    --------
    >>> first_order_lag(np.array([0.0, 10.0]), {"u": np.array([1.0, 1.0])},
    ...                 {"K": 2.0, "tau": 10.0})["y"].round(4)
    array([0.    , 1.2642])
    """
    u = inputs["u"]
    a = np.exp(-np.diff(time) / params["tau"])
    y = np.empty_like(time, dtype=float)
    y[0] = params.get("y0", 0.0)
    for k in range(len(time) - 1):
        y[k + 1] = a[k] * y[k] + (1.0 - a[k]) * params["K"] * u[k]
    return {"y": y}
