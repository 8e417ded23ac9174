"""``thermogym models``: list models, their signals and parameters."""

from __future__ import annotations

import argparse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument("name", nargs="?", help="show one model only")
    p.add_argument("--json", action="store_true", help="machine-readable output")
