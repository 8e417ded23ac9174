"""Sensor-module firmware: the virtual sensor as C99 code for the ATmega328P.

Paper ``001_6d13a2cd04f5de5e.txt`` writes the identified spindle model into
the firmware of its temperature-sensing module (ATmega328P, AD7794 ADC,
Pt1000 RTDs at 4.17 Hz) so that the module computes the internal
temperatures from the surface temperatures. This package generates that
firmware from a FitResult:

* :func:`export` — ``vs_model.h`` (matrices, dimensions, scaling, provenance)
  plus the C sources (one copy, shipped as package data in ``c/``), with
  optional C-versus-Python test vectors; refuses models that do not fit;
* :mod:`~thermogym.firmware.codegen` — firmware coordinates, footprint
  estimate, header text; :mod:`~thermogym.firmware.rtd` — the Python
  reference of the RTD conversion (eqs 1-2);
* :mod:`~thermogym.firmware.toolchain` — gcc host test, avr-gcc/avr-size,
  simavr; :mod:`~thermogym.firmware.selftest` — the cases
  ``make -C firmware test`` runs; :mod:`~thermogym.firmware.reference` —
  known spindle models for tests; :mod:`~thermogym.firmware.plots` — the
  measured / true / estimated figure.

The C API (``vs_observer.h``, ``rtd.h``): ``vs_init``, ``vs_reset``,
``vs_step`` on a ``vs_observer`` instance; ``rtd_code_to_temperature`` and
friends.
"""

from thermogym.firmware.codegen import TARGETS, Footprint, firmware_model, footprint
from thermogym.firmware.export import ExportReport, c_source_dir, export, sensor_from_fit

__all__ = [
    "TARGETS",
    "ExportReport",
    "Footprint",
    "c_source_dir",
    "export",
    "firmware_model",
    "footprint",
    "sensor_from_fit",
]
