"""External models as :class:`~thermogym.identification.simmodel.SimModel`: one interface.

Paper 000 (``000_24627a5308ee07db.txt``, sections 1-3) identifies models
built in other tools "without the need to convert these models", with one
workflow for every model type, and combines them (co-simulation). Each
adapter here makes one kind of external model look like a ``SimModel``, so
the identification coordinator fits any of them the same way:

=====================  ===================================================
adapter                the model is
=====================  ===================================================
:class:`CallableModel` a Python function ``func(time, inputs, params)``
:class:`ScriptModel`   a Python script; uncertain parameters are variables
                       in it (paper 000 workflow steps 1-2)
:class:`BatchJobModel` a command-line program that reads inputs and
                       parameters from files and writes its outputs to a
                       file (paper 000's third way of coupling)
:class:`FMUModel`      a Functional Mock-up Unit (Modelica, Simulink, ...)
                       through FMPy
:class:`OctaveModel`   a GNU Octave / Matlab ``.m`` script through oct2py
:class:`CoSimModel`    two or more of the above (or thermogym models) whose
                       parameters are identified together, one model's
                       output optionally feeding another's input
=====================  ===================================================

Non-batched adapters evaluate the parameter sets of one call in parallel
local processes (or Ray actors, ``backend="ray"``), with a time limit per
evaluation; a failing evaluation (exception, non-zero exit, NaN output,
timeout, crash) is reported in ``SimBatch.errors`` and the batch goes on
(:mod:`.parallel`).

:func:`load_external` builds any of them from a TOML/YAML/JSON file
(:mod:`.config`). :func:`time_evaluations` shows what one evaluation and a
batch cost.

Example
-------
A script ``lag_model.py`` (a heater's temperature rise under a constant power) and its
configuration ``lag.toml`` next to it, written to a temporary folder here:

>>> import tempfile
>>> from pathlib import Path
>>> import numpy as np
>>> from thermogym.identification.external import load_external
>>> from thermogym.recording import Recording
>>> folder = Path(tempfile.mkdtemp())
>>> _ = (folder / "lag_model.py").write_text('''
... import numpy as np
... K = 1.0  # the adapter sets K, tau, time (the recording's) and P
... tau = 100.0
... time = np.arange(0.0, 600.0, 10.0)
... P = np.ones_like(time)
... y = K * P * (1.0 - np.exp(-time / tau))
... ''')
>>> _ = (folder / "lag.toml").write_text('''
... type = "script"
... path = "lag_model.py"
... timeout = 20
... [parameters]
... K = {start = 1.0, lower = 0.1, upper = 10.0}
... tau = {start = 100.0, lower = 10.0, upper = 1000.0}
... [inputs]
... P = "P_heater"
... [outputs]
... y = "T_rise"
... [evaluation]
... backend = "serial"
... ''')
>>> rec = Recording(np.arange(0.0, 300.0, 60.0), {"P_heater": np.ones(5)})
>>> with load_external(folder / "lag.toml") as model:
...     batch = model.simulate(np.array([[2.0, 100.0], [1.0, 50.0]]), rec)
>>> batch.outputs.shape, batch.errors                # (B, T, outputs) and errors per set
((2, 5, 1), [None, None])
>>> batch.outputs[0, :, 0].round(3).tolist()         # 2 (1 - exp(-t / 100 s))
[0.0, 0.902, 1.398, 1.669, 1.819]
>>> import shutil
>>> shutil.rmtree(folder)
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from thermogym.identification.external.batchjob import BatchJobModel
    from thermogym.identification.external.callable import CallableModel
    from thermogym.identification.external.config import ExternalConfig, read_config
    from thermogym.identification.external.cosim import CoSimModel
    from thermogym.identification.external.fmu import FMUModel
    from thermogym.identification.external.octave import OctaveModel
    from thermogym.identification.external.script import ScriptModel
    from thermogym.identification.external.timing import EvaluationTiming, time_evaluations
    from thermogym.identification.simmodel import SimModel

__all__ = [
    "BatchJobModel",
    "CallableModel",
    "CoSimModel",
    "EvaluationTiming",
    "ExternalConfig",
    "FMUModel",
    "OctaveModel",
    "ScriptModel",
    "build_model",
    "load_external",
    "read_config",
    "time_evaluations",
]

# Submodules are imported on first use (PEP 562): worker processes import the
# adapter modules, and should not pay for the others (FMPy, oct2py, Ray).
_LAZY = {
    "BatchJobModel": "batchjob",
    "CallableModel": "callable",
    "CoSimModel": "cosim",
    "EvaluationTiming": "timing",
    "ExternalConfig": "config",
    "FMUModel": "fmu",
    "OctaveModel": "octave",
    "ScriptModel": "script",
    "read_config": "config",
    "time_evaluations": "timing",
}

_ADAPTERS = {
    "callable": ("callable", "CallableModel"),
    "script": ("script", "ScriptModel"),
    "batchjob": ("batchjob", "BatchJobModel"),
    "fmu": ("fmu", "FMUModel"),
    "octave": ("octave", "OctaveModel"),
    "cosim": ("cosim", "CoSimModel"),
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        module = importlib.import_module(f"{__name__}.{_LAZY[name]}")
        return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def build_model(cfg: ExternalConfig) -> SimModel:
    """Build the adapter a checked configuration names.

    Parameters
    ----------
    cfg : ExternalConfig
        From :func:`read_config`.

    Returns
    -------
    SimModel
    """
    module, cls = _ADAPTERS[cfg.type]
    adapter = getattr(importlib.import_module(f"{__name__}.{module}"), cls)
    return adapter.from_config(cfg)


def load_external(
    config: str | os.PathLike[str] | Mapping[str, Any],
    *,
    base_dir: str | os.PathLike[str] | None = None,
    **overrides: Any,
) -> SimModel:
    """Build an external model from a configuration file or dict.

    Parameters
    ----------
    config : path or mapping
        TOML, YAML or JSON file (or the same keys as a dict); see
        :mod:`thermogym.identification.external.config`.
    base_dir : path, optional
        Folder relative paths of a dict are resolved against (default: the
        current folder; a file's own folder for a file).
    **overrides
        Keys that replace the configuration's, e.g. ``backend="ray"``,
        ``workers=4``, ``timeout=30``.

    Returns
    -------
    SimModel
        Call ``close()`` (or use it as a context manager) to stop its worker
        processes.

    Raises
    ------
    ConfigError
        The configuration is invalid; the message names the offending key.

    Examples
    --------
    >>> import numpy as np
    >>> from thermogym.recording import Recording
    >>> cfg = {"type": "callable",
    ...        "callable": "thermogym.identification.external.examples:first_order_lag",
    ...        "parameters": {"K": {"start": 1.0, "lower": 0.1, "upper": 10.0},
    ...                       "tau": {"start": 60.0, "lower": 5.0, "upper": 600.0}},
    ...        "inputs": {"u": "P_heater"}, "outputs": {"y": "T_rise"}}
    >>> model = load_external(cfg, backend="serial")
    >>> model.param_names, model.input_names, model.output_names, model.batched
    (('K', 'tau'), ('P_heater',), ('T_rise',), False)
    >>> rec = Recording(np.arange(0.0, 50.0, 10.0), {"P_heater": np.full(5, 10.0)})
    >>> batch = model.simulate(np.array([[2.0, 10.0], [2.0, 1e-3]]), rec)
    >>> batch.outputs[:, -1, 0].round(3), batch.errors
    (array([19.634, 20.   ]), [None, None])
    >>> model.close()
    """
    # on first use, like the adapters (PEP 562 above)
    from thermogym.identification.external.config import read_config

    return build_model(read_config(config, base_dir=base_dir, **overrides))
