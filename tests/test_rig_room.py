"""The room rig's true plant: energy balance, its table of extra physics, the thermostat day."""

from __future__ import annotations

import numpy as np
import pytest

from thermogym.rigs import _room_physics as rp
from thermogym.rigs import get_rig
from thermogym.rigs.room import ROOM_EXTRAS, RoomPlant


def _run(plant, u_row, n, dt=10.0, x0=None, spec=None):
    u = np.tile(np.asarray(u_row, dtype=float), (n, 1))
    return plant.simulate(u, dt, spec if spec is not None else plant.nominal(), x0=x0)


@pytest.fixture(scope="module")
def open_valve():
    # actuator powered in a room at 18 °C on a cold day: the valve opens, the radiator heats
    plant = RoomPlant()
    x0 = plant.warm_state(plant.nominal(), 18.0, -5.0)
    return _run(plant, [1.0, 24.0, -5.0, 0.0, 0.0], 3 * 360, x0=x0)


def test_radiator_heats_once_the_actuator_opened(open_valve):
    run = open_valve
    xv, Q = run.output("x_V")[0], run.output("Q_heat")[0]
    k_open = int(np.argmax(xv > 4.4))
    assert 20 <= k_open <= 60  # the AXT211 takes minutes in a cool room (10 s samples)
    assert Q[: max(k_open - 30, 1)].max() < 50.0  # nothing before the valve opens
    assert 700.0 < Q[-1] < 1500.0  # near the design output at a 55/45 °C heating curve


def test_energy_balance_of_the_zone(open_valve):
    # heat into the zone = heat stored + heat lost, over 3 h (a hand budget of the nodes)
    plant = RoomPlant()
    run = open_valve
    q = plant.nominal()
    xs = run.states[0]
    C = np.array([q[n][0] for n in ("C_air", "C_int", "C_wi", "C_wo")])
    T = xs[:, rp.I_AIR : rp.I_AIR + 4]
    stored = C @ (T[-1] - T[0])
    Q_in = xs[-1, rp.I_Q] - xs[0, rp.I_Q]
    dt = 10.0
    Ta, Two = T[:, 0], T[:, 3]
    H_air = q["H_win"][0] + q["H_inf"][0]  # no occupancy gains: no extra ventilation
    loss_air = H_air * (Ta - (-5.0))
    loss_wall = q["H_we"][0] * (Two - (-5.0))
    loss = np.sum(0.5 * (loss_air[1:] + loss_air[:-1]) + 0.5 * (loss_wall[1:] + loss_wall[:-1]))
    loss *= dt
    # the pipe's loss and the actuator's power also enter the air
    P = run.output("P_PTC")[0]
    Tp = xs[:, rp.I_PIPE : rp.I_PIPE + rp.N_PIPE]
    pipe = (q["G_pipe"][0] / rp.N_PIPE) * (Tp.sum(axis=1) - rp.N_PIPE * Ta)
    extra = dt * np.sum(0.5 * (P[1:] + P[:-1]) + 0.5 * (pipe[1:] + pipe[:-1]))
    assert stored == pytest.approx(Q_in + extra - loss, rel=0.01)


@pytest.mark.parametrize("switch", [e.name for e in ROOM_EXTRAS])
def test_every_room_row_switches(switch):
    plant = RoomPlant(off=[switch])
    assert not plant.switches[switch] and plant.switches["latent_heat"]
    assert switch in __import__("thermogym.rigs.room", fromlist=["x"]).__doc__


def _flow(h, off=(), kind=0):
    plant = RoomPlant(off=off)
    q = plant.nominal().array([p.name for p in plant.parameters])[0, -rp.N_ROOM_PARAMS :]
    return rp.valve_flow(h, q, plant._swr, kind)


def test_valve_authority_lifts_the_part_stroke_flow():
    # installed characteristic 1 / sqrt(a / f² + 1 − a), a = 0.5, at 30 % of a linear stroke
    assert _flow(0.3) == pytest.approx(1.0 / np.sqrt(0.5 / 0.09 + 0.5), rel=1e-9)
    assert _flow(0.3, off=["valve_authority"]) == pytest.approx(0.3)
    assert _flow(1.0) == pytest.approx(1.0) and _flow(0.0) < 1e-3  # shut: seat leakage only
    # an equal-percentage valve passes much less at part stroke
    assert _flow(0.3, kind=1) < 0.5 * _flow(0.3)


def test_pipe_transport_delays_a_supply_step_by_volume_over_flow():
    # valve open (actuator held powered), then the outdoor temperature drops 15 → −10 °C:
    # the heating curve raises the supply at once; the radiator inlet follows after V/ṁ
    def inlet(off):
        plant = RoomPlant(off=off)
        spec = plant.nominal()
        warm = _run(plant, [1.0, 24.0, 15.0, 0.0, 0.0], 180, 10.0, spec=spec)
        x0 = warm.states[:, -1]
        run = _run(plant, [1.0, 24.0, -10.0, 0.0, 0.0], 240, 1.0, x0=x0, spec=spec)
        Tw = run.hidden["T_valve_water"][0]
        half = Tw[0] + 0.5 * (Tw[-1] - Tw[0])
        return int(np.argmax(Tw > half))

    t_on, t_off = inlet(["boiler_cycling"]), inlet(["boiler_cycling", "pipe_transport"])
    # 3.4 kJ/K over ṁ c_w ≈ 0.9 × 120 W/K (the valve fully open, authority 0.5): ~30 s
    assert 18 <= t_on - t_off <= 45


def test_hot_valve_body_and_plume_warm_the_actuator():
    def warm(off):
        run = _run(RoomPlant(off=["boiler_cycling", *off]), [1.0, 24.0, -5.0, 0.0, 0.0], 720)
        return run

    on = warm([])
    off = warm(["hot_valve_body", "actuator_plume"])
    # the actuator's air: the room plus 15 % of the radiator's excess; without: the room
    dT_plume = on.output("T_U")[0, -1] - on.output("T_zone")[0, -1]
    excess = on.output("T_rad")[0, -1] - on.output("T_zone")[0, -1]
    assert dT_plume == pytest.approx(0.15 * excess, rel=1e-6)
    np.testing.assert_allclose(off.output("T_U")[0], off.output("T_zone")[0])
    # the valve neck on hot water runs the cartridge hotter at the same supply
    assert on.output("T_P")[0, -1] > off.output("T_P")[0, -1] + 1.0


def test_curved_heating_curve_and_boiler_cycling():
    q = (
        RoomPlant()
        .nominal()
        .array([p.name for p in RoomPlant().parameters])[0, -rp.N_ROOM_PARAMS :]
    )
    curved = RoomPlant(off=["boiler_cycling"])
    linear = RoomPlant(off=["boiler_cycling", "curved_heating_curve"])
    Tc = rp.supply_temperature(5.0, 0.0, q, curved._swr)
    Tl = rp.supply_temperature(5.0, 0.0, q, linear._swr)
    assert Tl == pytest.approx(20.0 + 35.0 * 0.5)
    assert Tc == pytest.approx(20.0 + 35.0 * 0.5 ** (1 / 1.3))
    cyc = [rp.supply_temperature(5.0, t, q, RoomPlant()._swr) for t in np.arange(0, 1200, 60)]
    assert np.ptp(cyc) == pytest.approx(4.0, rel=0.05)  # ±2 K over a 20-min cycle
    assert rp.supply_temperature(-10.0, 0.0, q, linear._swr) == pytest.approx(55.0)


def test_solar_gains_warm_the_mass_before_the_air():
    # 4 h of 400 W of sun in an unheated room: with the distribution most of it goes
    # into the floor and furniture, so the air warms less
    def air_rise(off):
        plant = RoomPlant(off=off)
        spec = plant.nominal()
        x0 = plant.warm_state(spec, 18.0, 0.0)
        run = _run(plant, [0.0, 24.0, 0.0, 400.0, 0.0], 4 * 360, x0=x0, spec=spec)
        return run.output("T_zone")[0, -1] - run.output("T_zone")[0, 0]

    assert air_rise([]) < air_rise(["solar_gains"]) - 0.2


def test_occupancy_ventilation_cools_an_occupied_room():
    def air(off):
        plant = RoomPlant(off=off)
        spec = plant.nominal()
        x0 = plant.warm_state(spec, 20.0, 0.0)
        run = _run(plant, [0.0, 24.0, 0.0, 0.0, 250.0], 6 * 360, x0=x0, spec=spec)
        return run.output("T_zone")[0, -1]

    # full occupancy: the whole extra 0.5 1/h against half of it always
    assert air([]) < air(["occupancy_ventilation"]) - 0.1


def test_radiator_segments_and_radiant_share():
    def steady(off):
        run = _run(RoomPlant(off=["boiler_cycling", *off]), [1.0, 24.0, -5.0, 0.0, 0.0], 720)
        return run

    seg, mixed = steady([]), steady(["radiator_segments"])
    # one mixed node emits at its outlet temperature: less than the distributed radiator
    assert seg.output("Q_heat")[0, -1] > mixed.output("Q_heat")[0, -1]
    rad, conv = seg, steady(["radiant_emission"])
    d_rad = rad.hidden["T_internal"][0, -1] - rad.output("T_zone")[0, -1]
    d_conv = conv.hidden["T_internal"][0, -1] - conv.output("T_zone")[0, -1]
    assert d_rad > d_conv  # radiant heat lands on the mass first


def test_zone_nodes_keep_the_steady_loss_change_the_transient():
    def run(off):
        plant = RoomPlant(off=["boiler_cycling", *off])
        spec = plant.nominal()
        x0 = plant.warm_state(spec, 20.0, 0.0)
        return _run(plant, [0.0, 24.0, 0.0, 0.0, 300.0], 24 * 360, x0=x0, spec=spec)

    four, lumped = run([]), run(["zone_nodes"])
    # 300 W of gains, no heating: the steady state is that of the same envelope
    assert abs(four.output("T_zone")[0, -1] - lumped.output("T_zone")[0, -1]) < 1.5
    assert np.abs(four.output("T_zone")[0] - lumped.output("T_zone")[0]).max() > 0.2


def test_thermostat_day_on_the_rig():
    run = get_rig("room").run("thermostat", seed=1)[0]
    t = run.time
    hour = (t / 3600.0) % 24.0
    occ = (hour >= 9.0) & (hour < 18.0)  # two hours after the set-point rise
    Tz = run.truth["T_zone"]
    assert abs(np.mean(Tz[occ]) - 21.0) < 1.0
    assert run.columns["u"].min() == 0.0 and run.columns["u"].max() == 1.0
    assert set(run.meta) >= {"days", "valve"} and "effect" not in str(run.meta)
    rig = get_rig("room", valve="equal_percentage")
    assert rig.plant().valve == "equal_percentage"
    assert rig.with_specimen({"C_air": 2e5}).valve == "equal_percentage"


@pytest.mark.parametrize("effect", ["phase_change", "supply_variation"])
def test_concealed_actuator_effects_change_the_room_and_leave_no_trace(effect, tmp_path):
    import json

    from thermogym.rigs import run_experiment

    clean = run_experiment("room", "thermostat", seed=2, days=0.25)[0]
    got = run_experiment("room", "thermostat", tmp_path, seed=2, days=0.25, effects=[effect])[0]
    # the actuator's own physics changes when the valve opens: stroke and heat differ
    assert np.nanmax(np.abs(got["x_V"] - clean["x_V"])) > 0.05, effect
    text = " ".join(p.read_text() for p in tmp_path.iterdir() if p.suffix == ".json")
    text += json.dumps(got.meta)
    assert "effect" not in text
    for word in (effect, *get_rig("room").effect_defaults[effect]):
        assert word not in text, (effect, word)
