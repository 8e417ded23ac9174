"""Exception hierarchy of thermogym.

Every error raised on purpose by thermogym derives from :class:`ThermogymError`
and from the builtin exception that matches its meaning, so callers can catch
either ``ThermogymError`` (everything thermogym refuses) or the builtin
(``ValueError``, ``LookupError``, ...) as they would for any library.

Messages name the offending signal, shape or value and say what was expected.
"""

from __future__ import annotations

__all__ = [
    "ConfigError",
    "ExternalModelError",
    "IdentificationError",
    "ParameterError",
    "RecordingError",
    "ShapeError",
    "SimulationError",
    "ThermogymError",
    "UnitError",
    "UnknownNameError",
]


class ThermogymError(Exception):
    """Root of every exception thermogym raises on purpose."""


class RecordingError(ThermogymError, ValueError):
    """A recording is malformed: columns, values, time axis or metadata."""


class UnitError(RecordingError):
    """A signal carries a unit other than the one the model declares."""


class ShapeError(ThermogymError, ValueError):
    """An array has a shape other than the one expected."""


class ParameterError(ThermogymError, ValueError):
    """A parameter name, value or bound is invalid."""


class UnknownNameError(ThermogymError, LookupError):
    """A model, rig, protocol, effect or signal name is not known."""

    def __str__(self) -> str:  # LookupError would quote the message like a dict key
        return str(self.args[0]) if self.args else ""


class ConfigError(ThermogymError, ValueError):
    """A configuration file or option is invalid."""


class SimulationError(ThermogymError, RuntimeError):
    """A simulation failed (non-finite state, unstable step size, ...)."""


class IdentificationError(ThermogymError, RuntimeError):
    """An identification could not be carried out on the data given."""


class ExternalModelError(ThermogymError, RuntimeError):
    """An external model (script, batch job, FMU, Octave) failed."""
