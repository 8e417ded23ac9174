"""Toy model for the external-adapter tests: first-order thermal lag as a batch job.

Usage: python lag_batch.py INPUTS.csv PARAMS.json OUTPUTS.csv

Reads time and u from INPUTS.csv, K, tau (and y0) from PARAMS.json, writes
time and y to OUTPUTS.csv: y[k+1] = a y[k] + (1 - a) K u[k], a = exp(-dt_k / tau).
"""

import json
import sys

import numpy as np


def main(inputs: str, params: str, outputs: str) -> None:
    data = np.loadtxt(inputs, delimiter=",", skiprows=1, ndmin=2)
    with open(inputs) as f:
        header = f.readline().strip().split(",")
    time = data[:, header.index("time")]
    u = data[:, header.index("u")]
    p = json.load(open(params))
    a = np.exp(-np.diff(time) / p["tau"])
    y = np.empty_like(time)
    y[0] = p.get("y0", 0.0)
    for k in range(len(time) - 1):
        y[k + 1] = a[k] * y[k] + (1.0 - a[k]) * p["K"] * u[k]
    np.savetxt(
        outputs,
        np.column_stack([time, y]),
        delimiter=",",
        header="time,y",
        comments="",
        fmt="%.17g",
    )


if __name__ == "__main__":
    main(*sys.argv[1:4])
