"""Model names used on the command line and in FitResults.

``get_model("axt211")`` builds a model from its name and the constructor
arguments stored in a FitResult's ``model_config``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from thermogym.errors import ConfigError, UnknownNameError
from thermogym.models import axt211
from thermogym.models.base import Model

__all__ = ["get_model", "model_names", "register_model"]

_FACTORIES: dict[str, Callable[..., Model]] = {}


def register_model(name: str, factory: Callable[..., Model]) -> None:
    """Register a model factory under a command-line name."""
    _FACTORIES[name] = factory


def _load_builtin() -> None:
    if _FACTORIES:
        return
    # AXT211 loads with thermogym.models; the other built-in models load on first use, so
    # that the registry imports cheaply
    register_model("axt211", axt211.AXT211)
    for module, names in (
        ("thermogym.models.spindle", ("spindle",)),
        ("thermogym.models.strut", ("strut",)),
        ("thermogym.models.room", ("room",)),
        ("thermogym.models.linear", ("ss", "foptd")),
        ("thermogym.models.tclab", ("tclab",)),
        ("thermogym.models.polynomial", ("arx", "armax", "oe", "bj")),
        ("thermogym.models.process", ("sopdt",)),
        ("thermogym.models.augmented", ("augmented",)),
    ):
        try:
            mod = __import__(module, fromlist=["MODELS"])
        except ModuleNotFoundError as e:
            if e.name != module:
                raise
            continue
        for n in names:
            register_model(n, mod.MODELS[n])


def model_names() -> list[str]:
    """Names of every registered model."""
    _load_builtin()
    return list(_FACTORIES)


def get_model(name: str, **config: Any) -> Model:
    """Build the model called ``name`` with constructor arguments ``config``.

    Raises
    ------
    UnknownNameError
        ``name`` is not a registered model.
    ConfigError
        ``config`` does not fit the model's constructor.
    """
    _load_builtin()
    try:
        factory = _FACTORIES[name]
    except KeyError:
        raise UnknownNameError(f"unknown model {name!r}; models are {sorted(_FACTORIES)}") from None
    try:
        return factory(**config)
    except TypeError as e:
        raise ConfigError(f"model {name!r} cannot be built from {config}: {e}") from e
