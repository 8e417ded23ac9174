"""Prediction-error families (ARX, ARMAX, OE, BJ, SOPDT, ssest): known systems recovered.

Truth: data simulated from a known model (the polynomial form written out with
``scipy.signal.lfilter``, independent of thermogym's realisation) plus white
noise of known variance. Checks: the true parameters lie within their
estimated 99.9 % intervals, the residual variance is the noise variance (the
noise ceiling), orders and delays chosen by cross-validation are the true ones.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from thermogym.errors import ConfigError
from thermogym.identification.linear_fit import predict_fit
from thermogym.identification.metrics import nrmse
from thermogym.identification.n4sid import prepare_problem
from thermogym.identification.pem import pem, select_orders, sopdt
from thermogym.models.polynomial import PolynomialModel
from thermogym.recording import Recording

Z = 3.3  # 99.9 % two-sided normal quantile


def _prbs(rng, n, hold=8):
    return np.repeat(rng.choice([-1.0, 1.0], n // hold + 1), hold)[:n]


def _rec(u, y, names=("u",)):
    cols = {c: u[:, i] for i, c in enumerate(names)} | {"y": y}
    return Recording(np.arange(y.size, dtype=float), cols)


def _within(fit, truth):
    for k, v in truth.items():
        se = fit.stderr[k]
        assert np.isfinite(se) and se > 0, k
        assert abs(fit.parameters[k] - v) <= Z * se, (k, fit.parameters[k], v, se)


def test_polynomial_realisation_equals_the_difference_equations():
    rng = np.random.default_rng(0)
    u = rng.normal(size=(300, 2))
    e = rng.normal(size=300)
    m = PolynomialModel(
        ["u1", "u2"], ["y"], structure="bj", nb=2, nf=[[2, 1]], nc=1, nd=2, nk=[[1, 0]]
    )
    th = {
        "b0_y__u1": 0.5,
        "b1_y__u1": -0.2,
        "f1_y__u1": -1.2,
        "f2_y__u1": 0.4,
        "b0_y__u2": 1.0,
        "b1_y__u2": 0.3,
        "f1_y__u2": -0.5,
        "c1_y": 0.4,
        "d1_y": -0.9,
        "d2_y": 0.2,
    }
    # G_1 = q^-1 (0.5 − 0.2 q^-1) / (1 − 1.2 q^-1 + 0.4 q^-2), G_2 = (1 + 0.3 q^-1) / (1 − 0.5 q^-1)
    ysim = lfilter([0, 0.5, -0.2], [1, -1.2, 0.4], u[:, 0]) + lfilter([1, 0.3], [1, -0.5], u[:, 1])
    y = ysim + lfilter([1, 0.4], [1, -0.9, 0.2], e)
    np.testing.assert_allclose(m.simulate(u, 1.0, m.theta(th)).outputs[0, :, 0], ysim, atol=1e-12)
    # the one-step predictor of the realisation leaves exactly the innovations
    pred = m.state_space(m.theta(th)).predict(y[:, None], u)[0, :, 0]
    np.testing.assert_allclose(y - pred, e, atol=1e-10)
    # DC gains B(1)/F(1)
    np.testing.assert_allclose(m.dcgain(th)[0, 0], [0.3 / 0.2, 1.3 / 0.5])


def test_arx_recovers_parameters_and_the_noise_level():
    rng = np.random.default_rng(1)
    u = _prbs(rng, 2000)
    e = 0.05 * rng.normal(size=u.size)
    # A y = B u + e with A = 1 − 1.5 q^-1 + 0.7 q^-2, B = q^-2 (1 + 0.5 q^-1)
    y = lfilter([0, 0, 1.0, 0.5], [1, -1.5, 0.7], u) + lfilter([1.0], [1, -1.5, 0.7], e)
    res = pem(
        _rec(u[:, None], y), ["u"], ["y"], "arx", na=2, nb=2, nk=2, operating_point_mode="none"
    )
    _within(res.fit, {"a1_y": -1.5, "a2_y": 0.7, "b0_y": 1.0, "b1_y": 0.5})
    s2 = res.fit.settings["fit_info"]["outputs"]["y"]["sigma2"]
    assert s2 == pytest.approx(0.05**2, rel=0.1)


def test_armax_and_bj_recover_their_noise_models():
    rng = np.random.default_rng(2)
    u = _prbs(rng, 3000)
    e = 0.1 * rng.normal(size=u.size)
    # ARMAX: (1 − 0.8 q^-1) y = 0.5 q^-1 u + (1 + 0.6 q^-1) e
    y = lfilter([0, 0.5], [1, -0.8], u) + lfilter([1, 0.6], [1, -0.8], e)
    res = pem(
        _rec(u[:, None], y),
        ["u"],
        ["y"],
        "armax",
        na=1,
        nb=1,
        nc=1,
        nk=1,
        operating_point_mode="none",
    )
    _within(res.fit, {"a1_y": -0.8, "b0_y": 0.5, "c1_y": 0.6})
    # BJ: y = 0.3 q^-1 / (1 − 0.7 q^-1) u + (1 + 0.5 q^-1)/(1 − 0.9 q^-1) e
    y = lfilter([0, 0.3], [1, -0.7], u) + lfilter([1, 0.5], [1, -0.9], e)
    res = pem(
        _rec(u[:, None], y),
        ["u"],
        ["y"],
        "bj",
        nb=1,
        nf=1,
        nc=1,
        nd=1,
        nk=1,
        operating_point_mode="none",
    )
    _within(res.fit, {"b0_y": 0.3, "f1_y": -0.7, "c1_y": 0.5, "d1_y": -0.9})
    assert res.fit.settings["fit_info"]["outputs"]["y"]["sigma2"] == pytest.approx(0.01, rel=0.1)


def test_oe_recovers_a_two_input_system_and_simulates_at_the_noise_ceiling():
    rng = np.random.default_rng(3)
    u = np.column_stack([_prbs(rng, 2000, 10), _prbs(rng, 2000, 15)])
    clean = lfilter([0, 0.2], [1, -0.9], u[:, 0]) + lfilter([0, 0, 0.5, 0.2], [1, -0.6], u[:, 1])
    sigma = 0.1
    y = clean + sigma * rng.normal(size=clean.size)
    rec = _rec(u, y, ("u1", "u2"))
    res = pem(
        rec, ["u1", "u2"], ["y"], "oe", nb=[[1, 2]], nf=1, nk=[[1, 2]], operating_point_mode="none"
    )
    _within(
        res.fit,
        {"b0_y__u1": 0.2, "f1_y__u1": -0.9, "b0_y__u2": 0.5, "b1_y__u2": 0.2, "f1_y__u2": -0.6},
    )
    # simulated fit equals the fit of the noise-free truth to the noisy data (noise ceiling)
    yh = predict_fit(res.fit, rec)[:, 0]
    ceiling = nrmse(y, clean)
    assert nrmse(y, yh) == pytest.approx(ceiling, abs=0.005)
    assert nrmse(clean, yh) > 0.99


def test_cross_validation_finds_the_true_order_and_delay():
    rng = np.random.default_rng(4)
    u = _prbs(rng, 1600, 12)
    # second order, delay 3 samples, small equation noise
    y = lfilter([0, 0, 0, 0.4, 0.2], [1, -1.3, 0.45], u) + 0.01 * rng.normal(size=u.size)
    prob = prepare_problem(_rec(u[:, None], y), ["u"], ["y"], operating_point_mode="none")
    sel = select_orders(prob, "arx", {}, max_order=5, max_delay=6)
    assert sel["orders"]["nk"] == [[3]]
    assert sel["chosen_order"] == 2
    assert sel["orders"]["na"] == 2


def test_sopdt_recovers_its_parameters_within_their_intervals():
    from thermogym.models.process import SOPDTModel

    rng = np.random.default_rng(5)
    true = SOPDTModel(["P"], ["T"], K=0.8, T1=60.0, T2=12.0, tau=7.5)
    u = np.repeat(rng.uniform(0, 10, 25), 80)
    y = 25.0 + true.simulate(u[:, None], 1.0).outputs[0, :, 0] + 0.05 * rng.normal(size=u.size)
    rec = Recording(np.arange(u.size, dtype=float), {"P": u, "T": y})
    res = sopdt(rec, ["P"], ["T"], operating_point_mode="mean")
    _within(res.fit, {"K_T": 0.8, "T1_T": 60.0, "T2_T": 12.0, "tau_T": 7.5})


def test_ssest_chooses_a_feedthrough_when_the_output_answers_within_the_sample():
    from thermogym.identification.ssest import ssest
    from thermogym.models.linear import StateSpaceModel

    rng = np.random.default_rng(6)
    true = StateSpaceModel.from_matrices([[0.9]], [[0.1]], [[1.0]], [[-0.8]], dt=1.0)
    u = _prbs(rng, 800, 6)
    y = true.simulate(u[:, None], 1.0).outputs[0, :, 0] + 0.01 * rng.normal(size=u.size)
    res = ssest(
        _rec(u[:, None], y),
        ["u"],
        ["y"],
        orders=range(1, 3),
        max_delay=1,
        operating_point_mode="none",
    )
    st = res.fit.settings
    assert st["feedthrough"] is True and st["input_delay"] == 0
    assert res.fit.metrics["train"]["mnrmse"] > 0.98


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"family": "foo"}, "family"),
        ({"family": "oe", "na": 2}, "no A polynomial"),
        ({"family": "arx", "nk": -1}, "nk"),
        ({"family": "arx", "nb": 0}, "nb"),
        ({"family": "arx", "na": 1.5}, "na"),
        ({"family": "arx", "folds": 1}, "folds"),
        ({"family": "oe", "focus": "sideways"}, "focus"),
    ],
)
def test_bad_options_are_named(kwargs, match):
    rng = np.random.default_rng(7)
    u = _prbs(rng, 200)
    rec = _rec(u[:, None], lfilter([0, 0.5], [1, -0.5], u))
    family = kwargs.pop("family")
    with pytest.raises(ConfigError, match=match):
        pem(rec, ["u"], ["y"], family, **kwargs)


def test_a_constant_output_is_named_by_every_family():
    # a dead sensor or a wrong column: before, ARX/OE failed their cross-validation with no
    # reason given and SOPDT wrote a fit of gain 0 (exit 0 on the command line)
    from thermogym.errors import IdentificationError
    from thermogym.identification.n4sid import n4sid

    u = _prbs(np.random.default_rng(7), 200)
    rec = _rec(u[:, None], np.full(200, 21.5))
    for family in ("arx", "oe", "bj"):
        with pytest.raises(IdentificationError, match=rf"{family.upper()}: output 'y' .*21\.5"):
            pem(rec, ["u"], ["y"], family)
    with pytest.raises(IdentificationError, match=r"SOPDT: output 'y' is constant"):
        sopdt(rec, ["u"], ["y"])
    with pytest.raises(IdentificationError, match=r"N4SID: output 'y' is constant"):
        n4sid(rec, ["u"], ["y"], order=2)
    varying = _rec(u[:, None], lfilter([0, 0.5], [1, -0.5], u))
    assert prepare_problem([rec, varying], ["u"], ["y"]).outputs == ["y"]  # moves in one


def test_polynomial_model_options_are_checked():
    with pytest.raises(ConfigError, match="structure"):
        PolynomialModel(structure="arma")
    with pytest.raises(ConfigError, match="nf"):
        PolynomialModel(structure="arx", nf=1)
    with pytest.raises(ConfigError, match="nk"):
        PolynomialModel(structure="oe", nk=-2)


def test_cli_identify_oe_and_bad_values(tmp_path, capsys):
    from thermogym.cli import main
    from thermogym.fitresult import FitResult
    from thermogym.recording import write_recording

    rng = np.random.default_rng(8)
    u = _prbs(rng, 600)
    y = 3.0 + lfilter([0, 0, 0.3], [1, -0.7], u) + 0.01 * rng.normal(size=u.size)
    path = tmp_path / "run.csv"
    write_recording(_rec(u[:, None], y), path)
    out = tmp_path / "oe.json"
    rc = main(
        [
            "identify",
            "oe",
            str(path),
            "--inputs",
            "u",
            "--outputs",
            "y",
            "--nb",
            "1",
            "--nf",
            "1",
            "--nk",
            "2",
            "--operating-point",
            "mean",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    fit = FitResult.load(out)
    assert fit.model == "oe" and fit.parameters["f1_y"] == pytest.approx(-0.7, abs=0.01)
    assert fit.settings["signal_ranges"]["u"] == [-1.0, 1.0]
    rc = main(
        [
            "identify",
            "oe",
            str(path),
            "--inputs",
            "u",
            "--outputs",
            "y",
            "--nk",
            "x",
            "--out",
            str(tmp_path / "bad.json"),
        ]
    )
    assert rc == 2 and "--nk" in capsys.readouterr().err
    rc = main(
        [
            "identify",
            "ssest",
            str(path),
            "--inputs",
            "u",
            "--outputs",
            "y",
            "--orders",
            "3:1",
            "--out",
            str(tmp_path / "bad.json"),
        ]
    )
    assert rc == 2 and "--orders" in capsys.readouterr().err


def test_auto_prefers_output_error_for_a_plant_with_white_measurement_noise():
    from thermogym.identification.ssest import identify_auto

    rng = np.random.default_rng(9)
    u = _prbs(rng, 1200, 20)
    clean = lfilter([0, 0.1], [1, -0.9], u)
    y = clean + 0.3 * np.std(clean) * rng.normal(size=u.size)
    res = identify_auto(
        _rec(u[:, None], y),
        ["u"],
        ["y"],
        families=("arx", "oe"),
        max_order=3,
        max_delay=3,
        operating_point_mode="none",
    )
    scores = res.fit.settings["auto"]["families"]
    # least-squares ARX of a low order is biased by output noise; OE is not
    assert res.fit.settings["auto"]["chosen"] == "oe"
    assert scores["oe"]["cv_mnrmse"] > scores["arx"]["cv_mnrmse"]
    assert res.fit.parameters["f1_y"] == pytest.approx(-0.9, abs=0.02)


def _lag_fit(seed: int, noise: float = 0.05):  # type: ignore[no-untyped-def]
    """ssest of order 1 on y = 0.1 q⁻¹ / (1 − 0.9 q⁻¹) u + white noise (gain 1, pole 0.9)."""
    from thermogym.identification.ssest import ssest

    rng = np.random.default_rng(seed)
    u = _prbs(rng, 400, 10)
    y = lfilter([0.0, 0.1], [1.0, -0.9], u) + noise * rng.normal(size=u.size)
    return ssest(_rec(u[:, None], y), ["u"], ["y"], order=1, feedthrough=False,
                 input_delay=0, operating_point_mode="none").fit  # fmt: skip


def test_ssest_covariance_matches_the_spread_over_noise_realisations():
    # the pole and the DC gain of a refined state space vary over noise realisations as
    # its stored covariance says (delta method), and nothing moves along the similarity
    # direction (B, C) -> (t B, C / t), which the data cannot determine
    fits = [_lag_fit(seed) for seed in range(20)]

    def pole_gain(p):  # type: ignore[no-untyped-def]
        a, b, c = p["A_0_0"], p["B_0_0"], p["C_0_0"]
        return np.array([a, c * b / (1.0 - a)])

    seen = np.array([pole_gain(f.parameters) for f in fits])
    f = fits[0]
    assert f.method == "ssest" and f.covariance is not None
    names = list(f.covariance_names)
    cov = np.asarray(f.covariance)
    x = np.array([f.parameters[n] for n in names])
    # Jacobian of (pole, gain) by central differences
    G = np.zeros((2, x.size))
    for k in range(x.size):
        h = 1e-6 * max(abs(x[k]), 1.0)
        up, dn = x.copy(), x.copy()
        up[k] += h
        dn[k] -= h
        hi = pole_gain(dict(zip(names, up, strict=True)))
        lo = pole_gain(dict(zip(names, dn, strict=True)))
        G[:, k] = (hi - lo) / (2 * h)
    predicted = np.sqrt(np.diag(G @ cov @ G.T))
    empirical = seen.std(axis=0, ddof=1)
    assert np.all(predicted > empirical / 2) and np.all(predicted < empirical * 2), (
        predicted,
        empirical,
    )
    tangent = np.zeros(x.size)
    tangent[names.index("B_0_0")] = f.parameters["B_0_0"]
    tangent[names.index("C_0_0")] = -f.parameters["C_0_0"]
    assert tangent @ cov @ tangent <= 1e-12 * np.trace(cov) * (tangent @ tangent)


def test_identified_plant_randomises_an_ssest_fit_and_explains_an_n4sid_fit(tmp_path):
    import gymnasium as gym

    from thermogym.errors import ParameterError
    from thermogym.identification.n4sid import n4sid

    fit = _lag_fit(0)
    fit.save(tmp_path / "ssest.json")

    def poles(seed: int) -> float:
        env = gym.make("thermogym/IdentifiedPlant-v0", params=str(tmp_path / "ssest.json"),
                       randomize="covariance")  # fmt: skip
        env.reset(seed=seed)
        return float(env.unwrapped._e.A[0, 0, 0])

    assert poles(1) == poles(1) != poles(2)
    assert abs(poles(3) - fit.parameters["A_0_0"]) < 0.05
    rng = np.random.default_rng(0)
    u = _prbs(rng, 400, 10)
    rec = _rec(u[:, None], lfilter([0.0, 0.1], [1.0, -0.9], u) + 0.05 * rng.normal(size=400))
    plain = n4sid(rec, ["u"], ["y"], 1).fit
    assert plain.covariance is None
    with pytest.raises(ParameterError, match=r"this 'n4sid' fit has none .*identify ssest"):
        gym.make("thermogym/IdentifiedPlant-v0", params=plain, randomize="covariance")


def test_a_refinement_that_converges_gives_no_convergence_warning():
    fit = _lag_fit(0)
    assert fit.settings["evaluation_limit_reached"] is False
    assert "not_converged" not in {w["code"] for w in fit.warnings}
