"""``thermogym experiment RIG PROTOCOL --out DIR``: run a virtual test rig.

Protocol options (``--option KEY=VALUE``) are checked against the protocol's
own defaults before the rig runs: a list of numbers where the default is a
list (``speeds=[4000,6000]``, a single number is taken as a one-item list), a
number where it is a number, positive for durations, periods, speeds and
counts. The recordings and ``manifest.json`` are written into a staged folder
and moved into ``--out`` only when every recording was written (an
interrupted run leaves ``--out`` as it was).
"""

from __future__ import annotations

import argparse

from thermogym._cli.common import whole


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Declare the options."""
    p.add_argument("rig", help="axt211, room, spindle or strut")
    p.add_argument(
        "protocol", help="protocol of the rig, e.g. strut steps (an unknown one lists the rig's)"
    )
    p.add_argument("--out", required=True, help="folder for the recordings (created)")
    p.add_argument(
        "--seed",
        type=whole(0, 2**32 - 1, what="a seed"),
        default=0,
        help="seed of every random draw (default 0)",
    )
    p.add_argument(
        "--format",
        choices=("csv", "parquet"),
        default="csv",
        dest="fmt",
        help="file format (default csv, with a .meta.json sidecar)",
    )
    p.add_argument(
        "--effect",
        action="append",
        default=[],
        metavar="NAME[:k=v,...]",
        help="include physics the nominal model lacks (concealed: not recorded)",
    )
    p.add_argument(
        "--option",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="protocol option, e.g. speeds=[4000,6000]",
    )
