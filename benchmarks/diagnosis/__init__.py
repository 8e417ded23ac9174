"""Public generalisation suite of the mismatch diagnosis (issue 15).

Plants, effects and cases are written here from textbook heat transfer and the
papers, independently of the diagnosis and of ``thermogym.models.augmented``
(``tests/test_generalisation_suite.py`` checks the imports). Only the runner,
``generalisation.py``, calls the public :func:`thermogym.identification.diagnosis.diagnose`
(inside :func:`~benchmarks.diagnosis.generalisation.run_case`); ``detection_limits.py``
makes its cases with ``cases.py`` like every other case and scores them through
``run_case``: it imports neither the diagnosis nor the augmentations.

Modules
-------
signals
    Coloured sensor noise, quantisation, excitation signals, time profiles.
effects
    The hidden effects' forms: input maps, heat-transfer laws, sensor errors, delays.
plants
    The new plant families' true plants (lamp-heated plate, stirred tank,
    two-zone building) and the nominal models a user would bring.
rigcases
    The papers' rigs (``thermogym.rigs``) with effects added by this suite's code.
cases
    The case list, the recordings of a case and its ground truth.
generalisation
    The runner (``--json PATH``).
detection_limits
    Effect ladders and controls on the plate, scored by ``run_case`` (item 7).
_onecore
    One thread per case, set before numpy loads (both runners).
"""
