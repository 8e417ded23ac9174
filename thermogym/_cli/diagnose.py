"""``thermogym diagnose``: locate a model mismatch and name the missing physics.

::

    thermogym diagnose --model MODEL [--params fit.json] --train DATA... --validate DATA...
                       --out report.json [--html report.html] [--md report.md]
                       [--augmented-fit fit.json] [--inputs COL,...] [--outputs COL,...]

``MODEL`` is a thermogym plant (``axt211``, ``strut``, ``spindle``, ...), ``foptd``
or ``ss:ORDER`` (with ``--inputs`` and ``--outputs`` naming the recording's
columns). ``DATA`` is a recording file (CSV/Parquet), a folder of them, or
``dataset:NAME`` for a shipped data set (``thermogym.datasets``).
"""

from __future__ import annotations

import argparse

from thermogym._cli.common import choice_list, names, positive, probability
from thermogym._cli.data import add_data_options
from thermogym.vocabulary import EFFECT_NAMES

#: ``--x0`` choices: :data:`thermogym.identification.diagnosis.run.X0_POLICIES`, written out
#: so that the options load without the diagnosis (tests/test_diagnose_x0.py checks they match).
X0_POLICIES: tuple[str, ...] = ("auto", "estimate", "rest", "measured")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument(
        "--model",
        required=True,
        help="nominal model: a thermogym plant, 'foptd' or 'ss:ORDER'",
    )
    p.add_argument(
        "--params",
        help="FitResult JSON of the nominal model: its parameters are the given ones (the "
        "identifiable ones are re-calibrated); for ss:N or foptd a FitResult of that model "
        "(its operating point and columns are used)",
    )
    p.add_argument(
        "--train",
        nargs="+",
        required=True,
        metavar="DATA",
        help="training recordings: files, folders or dataset:NAME",
    )
    p.add_argument(
        "--validate",
        nargs="+",
        required=True,
        metavar="DATA",
        help="held-out recordings: files, folders or dataset:NAME",
    )
    p.add_argument("--out", required=True, help="report JSON to write")
    p.add_argument("--html", help="also write a self-contained HTML report with figures")
    p.add_argument("--md", help="also write a Markdown report (figures next to it)")
    p.add_argument(
        "--augmented-fit", help="also write the winning augmented model's FitResult JSON"
    )
    p.add_argument(
        "--inputs", type=names(), help="generic models: exogenous columns, comma-separated"
    )
    p.add_argument("--outputs", type=names(), help="output columns to compare, comma-separated")
    p.add_argument(
        "--candidates",
        type=choice_list([e for e in EFFECT_NAMES if e != "none"], "effect"),
        help="effects to consider, comma-separated (default: all)",
    )
    p.add_argument(
        "--dt",
        type=positive("s", "a sample period"),
        help="average the recordings onto this period [s] first (default: their own, or for "
        "more than 20,000 samples a grid of 1/20 of the model's fastest half-response; give "
        "the recordings' period to keep it)",
    )
    p.add_argument(
        "--alpha",
        type=probability(),
        default=0.01,
        help="test level in (0, 1) (default 0.01)",
    )
    p.add_argument(
        "--scheme",
        choices=("auto", "split", "crossfit"),
        default="auto",
        help="how hypotheses are scored on held-out data (default auto)",
    )
    p.add_argument(
        "--time-limit",
        type=positive("s", "a time limit"),
        help="start no hypothesis after this many seconds",
    )
    p.add_argument(
        "--max-effects",
        type=int,
        default=3,
        help="most effects a combination holds (default 3)",
    )
    p.add_argument(
        "--x0",
        choices=X0_POLICIES,
        default="auto",
        help="initial state of every recording in the fits: estimate (least squares on the "
        "recording's outputs, as MATLAB's compare), rest (the model's own start: a plant at "
        "rest; an identified ss/foptd settled at the first input, or at rest at its operating "
        "point), measured (measured temperature states from their first samples); auto "
        "(default): estimate, or rest for a generic model whose inputs are constant in every "
        "training recording. The command prints which it used",
    )
    p.add_argument("--no-sparse", action="store_true", help="skip the sparse-regression fallback")
    p.add_argument("--quiet", action="store_true", help="print only the verdict")
    add_data_options(p)
