"""The work of ``thermogym models``.

The command's description and its options: :mod:`thermogym._cli.models`.
"""

from __future__ import annotations

import argparse
import json

from thermogym.models.registry import get_model, model_names


def _generic_note(name: str) -> str:
    return {
        "ss": "generic discrete state space; signals named from the data (--inputs/--outputs)",
        "foptd": "generic FOPTD set; signals named from the data (--inputs/--outputs)",
    }.get(name, "")


def run(args: argparse.Namespace) -> int:
    """List the models."""
    names = [args.name] if args.name else model_names()
    descs = []
    for n in names:
        try:
            descs.append(get_model(n).describe())
        except Exception:  # generic models need their dimensions
            if args.name and n not in model_names():
                get_model(n)  # raises the clear unknown-model error
            descs.append(
                {"name": n, "description": _generic_note(n), "signals": [], "parameters": []}
            )
    if args.json:
        print(json.dumps(descs, indent=2, ensure_ascii=False))
        return 0
    for d in descs:
        print(f"{d['name']}  (v{d.get('version', '-')}) — {d['description']}")
        for s in d["signals"]:
            print(f"    {s['role']:<12} {s['name']:<24} [{s['unit']}]  {s['description']}")
        if d["parameters"]:
            print(f"    {len(d['parameters'])} parameters:")
        for p in d["parameters"]:
            print(
                f"      {p['name']:<16} {p['nominal']:>12.6g} [{p['unit']}]  "
                f"[{p['lower']:.4g}, {p['upper']:.4g}]  {p['description']}"
            )
        print()
    return 0
