"""Batched AXT211 simulation against a loop of scipy.integrate.solve_ivp.

1024 AXT211 parameter sets (±10 % around nominal) over one hour at 1 s steps,
heater on for 30 min then off. thermogym simulates the whole batch in one call
(compiled fixed-step RK4). The peer integrates each parameter set with
``scipy.integrate.solve_ivp`` (RK45) segment by segment between input
switches, with tolerances chosen so that its error against a tight reference is
no larger than thermogym's — equal (or better) accuracy for the peer.

Backlash is switched off for the comparison (it is a discrete memory, not
part of the ODE the peer integrates), so the states compared are T_P, T_G, x_P.

Usage::

    python benchmarks/simulate.py [--n 1024] [--n-peer 1024] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from thermogym.models import AXT211

T_END, T_OFF, DT = 3600.0, 1800.0, 1.0


def python_rhs(p: dict[str, float]):
    """Eqs (14)-(21) of 002_dae2310635fe074e.txt in plain Python (the peer's model)."""
    R = [p[f"R_{i}"] for i in range(6)]

    def rhs(t, x, u, kU, TU):
        TP, TG, xP = x
        Tc = min(max(TP, 30.0), 101.0)
        tau = (Tc - 65.0) / 35.0
        Rp = R[0] + tau * (R[1] + tau * (R[2] + tau * (R[3] + tau * (R[4] + tau * R[5]))))
        if TP > 101.0:
            dR = R[1] + tau * (2 * R[2] + tau * (3 * R[3] + tau * (4 * R[4] + 5 * tau * R[5])))
            Rp += dR / 35.0 * (TP - 101.0)
        P = (kU * u) ** 2 / Rp
        q = p["lambda_PG"] * (TP - TG)
        xp = max(xP, 0.0)
        k = (p["kP_a"] * xp + p["kP_b"]) * xp + p["kP_c"]
        dx = (k * (TP - p["T_P0"]) - xP) / p["tau_P"]
        if (xP <= 0.0 and dx < 0.0) or (xP >= p["x_max"] and dx > 0.0):
            dx = 0.0
        return [(P - q) / p["C_P"], (q - p["lambda_GU"] * (TG - TU)) / p["C_G"], dx]

    return rhs


def peer_simulate(p: dict[str, float], rtol: float, atol: float) -> np.ndarray:
    """Integrate one parameter set with solve_ivp, piecewise between input switches."""
    rhs = python_rhs(p)
    t_eval = np.arange(0.0, T_END, DT)
    out = np.empty((t_eval.size, 3))
    x = [25.0, 25.0, 0.0]
    for (a, b), u in (((0.0, T_OFF), 1.0), ((T_OFF, T_END - DT), 0.0)):
        sel = (t_eval >= a) & (t_eval <= b)
        sol = solve_ivp(
            rhs,
            (a, b),
            x,
            method="RK45",
            rtol=rtol,
            atol=atol,
            t_eval=t_eval[sel],
            args=(u, 24.0, 25.0),
        )
        out[sel] = sol.y.T
        x = sol.y[:, -1]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1024, help="parameter sets")
    ap.add_argument(
        "--n-peer",
        type=int,
        default=None,
        help="parameter sets the peer loop runs (default: all; fewer are "
        "timed and scaled linearly, and the report says so)",
    )
    ap.add_argument(
        "--peer-rtol",
        type=float,
        default=1e-8,
        help="peer tolerance; 1e-8 gives an error no larger than thermogym's",
    )
    ap.add_argument("--json", type=Path, help="write the figures to this file")
    args = ap.parse_args()

    model = AXT211()
    rng = np.random.default_rng(0)
    n = args.n
    theta = model.theta(batch=n)
    scale = rng.uniform(0.9, 1.1, theta.shape)
    for name in ("C_P", "lambda_PG", "C_G", "lambda_GU", "tau_P", "kP_b", "kP_c"):
        j = model.param_index(name)
        theta[:, j] *= scale[:, j]
    theta[:, model.param_index("c_backlash")] = 0.0
    T = int(T_END / DT)
    u = np.zeros((T, 3))
    u[: int(T_OFF / DT), 0] = 1.0
    u[:, 1], u[:, 2] = 24.0, 25.0
    x0 = np.array([25.0, 25.0, 0.0, 0.0])

    model.simulate(u[:10], DT, theta[:64], x0)  # compile (cached on disk after the first run)
    t_ours = np.inf
    for _ in range(3):  # best of three: the machine may be busy with something else
        t0 = time.perf_counter()
        sim = model.simulate(u, DT, theta, x0)
        t_ours = min(t_ours, time.perf_counter() - t0)
    iT = [model.output_names.index(k) for k in ("T_P", "T_G", "x_P")]

    # accuracy against a tight reference on a few parameter sets
    names = model.param_names
    check = range(0, n, max(1, n // 8))
    err_ours, err_peer = 0.0, 0.0
    for b in check:
        p = dict(zip(names, theta[b], strict=True))
        ref = peer_simulate(p, 1e-11, 1e-11)
        ours = sim.outputs[b][:, iT]
        peer = peer_simulate(p, args.peer_rtol, args.peer_rtol * 1e-2)
        err_ours = max(err_ours, float(np.abs(ours[:, :2] - ref[:, :2]).max()))
        err_peer = max(err_peer, float(np.abs(peer[:, :2] - ref[:, :2]).max()))

    n_peer = min(args.n_peer or n, n)
    t0 = time.perf_counter()
    for b in range(n_peer):
        peer_simulate(
            dict(zip(names, theta[b], strict=True)), args.peer_rtol, args.peer_rtol * 1e-2
        )
    t_peer = (time.perf_counter() - t0) * n / n_peer
    ratio = t_peer / t_ours

    print(f"AXT211, {n} parameter sets x {T} steps of {DT:g} s")
    print(f"  thermogym batched RK4 : {t_ours:8.3f} s   max |error| T_P,T_G {err_ours:.2e} °C")
    extrapolated = f" (timed on {n_peer}, scaled)" if n_peer < n else ""
    print(
        f"  solve_ivp loop (RK45) : {t_peer:8.3f} s   max |error| T_P,T_G {err_peer:.2e} °C"
        f"{extrapolated}"
    )
    print(
        f"  ratio                 : {ratio:8.1f}x  (target >= 100x; peer error "
        f"{'<=' if err_peer <= err_ours else '>'} ours)"
    )
    if args.json:
        doc = {
            "figures": {
                "batched_s": t_ours,
                "peer_loop_s": t_peer,
                "n_parameter_sets": n,
                "n_steps": T,
                "peer_sets_timed": n_peer,
                "max_abs_err_ours_degC": err_ours,
                "max_abs_err_peer_degC": err_peer,
            },
            "peer": "scipy.integrate.solve_ivp (RK45) loop per parameter set",
            "ratio": ratio,
            "target": 100,
        }
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(doc, indent=2) + "\n")


if __name__ == "__main__":
    main()
