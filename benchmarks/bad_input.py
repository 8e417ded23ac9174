"""Bad inputs over the whole command line: clear errors, tracebacks, silent accepts, damage.

Runs generated cases (``tests/cli_badinput.py``: option values of every
command, output paths, malformed CSV recordings, ``.meta.json`` sidecars,
FitResults, external-model TOML/YAML configurations, Ctrl-C at points of
valid runs) through :func:`thermogym.cli.main` in this process, each in a fresh
work folder of valid files with exactly one thing wrong, and counts:

``tried``
    cases run.
``clear_error``
    exit 2 (130 for an interruption), one line on stderr starting
    ``thermogym ...: error:`` (``interrupted``) that names the offending
    option, value, column, key or file; no traceback, no ``np.float64(...)``.
``unclear``
    exit 2 (130) but the line is missing, doubled or does not name the offender.
``traceback``
    an exception escaped, a traceback was printed, an internal error (exit 1)
    was reported, or the case ran past its time limit.
``silent_wrong``
    a known-bad input that exits 0.
``file_damage``
    a case after which a file of the work folder changed or vanished, or a
    failed run left a new file (a best-so-far ``*.interrupted*`` file named by
    the message is allowed; the outputs of a run wrongly exiting 0 count under
    ``silent_wrong``).

Peer: the hand survey of issue 17 before this work (153 bad inputs, 116 with a
clear error, 76 %); it is not re-measured here, the old CLI being gone.

Usage::

    python benchmarks/bad_input.py [--cases 600] [--seed 0] [--json PATH] [--show]
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import cli_badinput as cb  # noqa: E402

from thermogym._fileio import atomic_write_text  # noqa: E402

#: Issue 17's hand survey before this work: tried, clear.
PEER = (153, 116)


def main() -> int:
    """Run the cases and report."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=600, help="number of cases (default 600)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the case generator")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per case")
    ap.add_argument("--json", type=Path, help="write the figures here")
    ap.add_argument("--show", action="store_true", help="print every case that is not clear")
    args = ap.parse_args()
    os.environ.setdefault("MPLBACKEND", "Agg")

    rng = np.random.default_rng(args.seed)
    picker = cb.RandomPicker(rng)
    names = list(cb.FAMILIES)
    weights = np.array([cb.FAMILIES[n][1] for n in names], float)
    weights /= weights.sum()
    t0 = time.perf_counter()
    cb.build_fixtures()
    counts: collections.Counter[str] = collections.Counter()
    by_family: dict[str, collections.Counter[str]] = {n: collections.Counter() for n in names}
    failures: list[dict[str, object]] = []
    seconds: list[float] = []
    kinds: set[tuple[str, str]] = set()  # (family, what was wrong): the variety tried
    for k in range(args.cases):
        family = names[int(rng.choice(len(names), p=weights))]
        case = cb.FAMILIES[family][0](picker)
        out = cb.run_case(case, timeout=args.timeout)
        seconds.append(out.seconds)
        kinds.add((family, case.note or case.argv[0]))
        counts["tried"] += 1
        counts[out.verdict] += 1
        by_family[family]["tried"] += 1
        by_family[family][out.verdict] += 1
        if out.damage:
            counts["file_damage"] += 1
            by_family[family]["file_damage"] += 1
        if out.verdict != "clear_error" or out.damage:
            entry = {
                "case": case.describe(),
                "verdict": out.verdict,
                "code": out.code,
                "stderr": out.err.strip()[-400:],
                "damage": out.damage,
            }
            failures.append(entry)
            if args.show:
                print(f"{k:4d} {out.verdict:12s} {case.describe()}\n     {entry['stderr']}")
    total = time.perf_counter() - t0
    keys = ("tried", "clear_error", "unclear", "traceback", "silent_wrong", "file_damage")
    figures = {k: int(counts.get(k, 0)) for k in keys}
    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    share = figures["clear_error"] / max(figures["tried"], 1)
    print(
        f"{figures['tried']} bad inputs in {total:.0f} s (median {np.median(seconds):.3f} s a "
        f"case; load {load[0]:.2f})"
        if load
        else f"{figures['tried']} bad inputs in {total:.0f} s"
    )
    for k in keys[1:]:
        print(f"  {k:13s} {figures[k]:5d}")
    print(f"  {len(kinds)} kinds of defect (family and what was wrong)")
    peer = PEER[1] / PEER[0]
    print(
        f"clear errors {100 * share:.1f} % vs {100 * peer:.0f} % in the hand survey of issue 17 "
        f"before this work ({PEER[1]}/{PEER[0]}; ratio {share / peer:.2f}x)"
    )
    for n in names:
        c = by_family[n]
        print(
            f"  {n:10s} tried {c['tried']:4d}  clear {c['clear_error']:4d}  unclear "
            f"{c['unclear']:3d}  traceback {c['traceback']:3d}  silent {c['silent_wrong']:3d}  "
            f"damage {c['file_damage']:3d}"
        )
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        doc = {
            "figures": figures,
            "by_family": {n: dict(c) for n, c in by_family.items()},
            "peer": {"name": "issue 17 hand survey (before)", "tried": PEER[0], "clear": PEER[1]},
            "kinds": len(kinds),
            "seed": args.seed,
            "seconds": total,
            "load": list(load) if load else None,
            "failures": failures[:100],
        }
        atomic_write_text(args.json, json.dumps(doc, indent=2) + "\n")
        print(f"wrote {args.json}")
    bad = figures["traceback"] + figures["silent_wrong"] + figures["file_damage"]
    return 0 if bad == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
