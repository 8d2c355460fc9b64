"""aem_electrolyser.examples.generator_trip with a short horizon (trip at 1 s, 10 s in all), checked against
what must hold whatever the implementation: equilibrium before the trip, the size of the unit
that trips and the governors' droop after it, the power balance of the network, the FCR-D up
request as the closed form of the frequency the hub was given, the hub's power as the closed-form
response of its modules to that request (plain: both poles; compensated: the fast pole alone;
the optimised control: both poles with the zero moved), and the order of the runs (reserve
lifts the frequency; compensation reduces faster, the optimised control slower)."""

import csv
import math
import subprocess
import sys
import time

import numpy as np
import pytest

from conftest import PAPER, modal_weights, module_power, setpoint_for

from aem_electrolyser.examples import generator_trip

# TOPS co-simulations
pytestmark = [
    pytest.mark.cosim,
    pytest.mark.filterwarnings("ignore:numpy.core is deprecated:DeprecationWarning"),
]  # inside tops

DURATION, TRIP, EXCHANGE, DT = 10.0, 1.0, 0.1, 5e-3
CAPACITY, LOAD, N = 12e6, 0.8, generator_trip.N_MODULES
K, V0, R = PAPER["gain"], PAPER["voltageIntercept"], PAPER["ohmicResistance"]
DROOP = 1 / 0.05 + 0.02  # k2a's TGOV1: 1/R + D_t [pu power / pu speed] on each unit's rating
MVA_LEFT = 3 * 900 + 450  # G2, G3, G4 and the G1 unit that stays
STIFFNESS = DROOP * MVA_LEFT / 50.0  # MW/Hz


@pytest.fixture(scope="module")
def trip(fmu_path, tmp_path_factory):
    out = tmp_path_factory.mktemp("out") / "generator_trip"
    start = time.perf_counter()
    cases, table = generator_trip.run(
        fmu_path,
        duration=DURATION,
        trip_time=TRIP,
        capacity=CAPACITY,
        load=LOAD,
        exchange=EXCHANGE,
        out=out.parent,
        verbose=False,
    )
    print(f"\ngenerator_trip.run, {len(generator_trip.RUNS)} x {DURATION:g} s: {time.perf_counter() - start:.1f} s")
    return out, cases, table


def exchanges(o):
    """Every exchange instant's values: the sample right after it holds what was set there."""
    stride = int(round(EXCHANGE / DT))
    return {k: o[k][::stride] for k in ("time", "f_hub", "request", "hub")}


def test_equilibrium_before_the_trip(trip):
    _, cases, _ = trip
    p_ref = LOAD * N * module_power(PAPER["maxSetpoint"])
    for name, o in cases.items():
        before = o["time"] < TRIP
        assert np.abs(o["f"][before] - 50.0).max() < 1e-9, name  # Hz
        assert np.abs(o["f_coi"][before] - 50.0).max() < 1e-9, name
        assert np.abs(o["f_hub"][before] - 50.0).max() < 1e-9, name
        assert np.all(o["request"][before] == 0.0), name
        assert o["hub"][before] == pytest.approx(p_ref, rel=1e-9), name  # the hub draws its reference
        assert o["vsc_hub"][before] == pytest.approx(p_ref, rel=1e-9), name  # and the VSC draws the hub's power
        assert np.ptp(o["gen"][before]) < 1.0, name  # W


def test_one_350_mw_unit_trips_and_the_droop_of_the_others_takes_over(trip):
    _, cases, _ = trip
    for name, o in cases.items():
        assert o["tripped"] == pytest.approx(350e6, rel=1e-9), name  # k2a's G1 (700 MW) as two units
        # quasi-steady state at the end: the governors left (5 % droop on 3150 MVA, plus D_t) carry
        # the lost unit's power and the change of demand in proportion to the frequency drop, and the
        # machines turn their mechanical power P_m at speed 1 + w into the electric power P_m/(1 + w)
        w = o["f_coi"][-1] / 50.0 - 1.0
        p_m = (o["gen"][0] - o["tripped"]) / 1e6 - STIFFNESS * 50.0 * w
        assert o["gen"][-1] / 1e6 == pytest.approx(p_m / (1.0 + w), rel=1e-3), name


def test_generators_supply_loads_hub_and_losses_at_every_step(trip):
    _, cases, _ = trip
    for name, o in cases.items():
        balance = o["gen"] - o["loads"] - o["vsc_hub"] - o["losses"]
        assert np.abs(balance).max() < 1e-9 * o["gen"].max(), name
        # the hub's VSC (its power into the network) follows the hub FMU's power
        assert o["vsc_hub"][-1] == pytest.approx(o["hub"][-1], rel=1e-3), name


def test_reserve_request_is_the_fcr_d_up_closed_form_of_the_frequency_given(trip):
    _, cases, _ = trip
    for name, o in cases.items():
        e = exchanges(o)
        # the hub is given the PLL's frequency at B12 at each exchange instant (the sample before)
        stride = int(round(EXCHANGE / DT))
        assert np.array_equal(e["f_hub"][1:], o["f"][stride - 1 : -1 : stride]), name
        capacity = o["capacity"]
        expected = -capacity * np.clip((49.9 - e["f_hub"]) / 0.4, 0.0, 1.0)
        assert e["request"] == pytest.approx(expected, abs=1e-6), name  # W
    assert cases["no reserve"]["capacity"] == 0.0
    assert cases["FCR-D up"]["capacity"] == cases["FCR-D up, compensated"]["capacity"] == CAPACITY
    assert cases["FCR-D up"]["request"].min() < -0.3 * CAPACITY  # the trip reaches well into the band


@pytest.mark.parametrize("name", [n for n, (offers, *_) in generator_trip.RUNS.items() if offers])
def test_hub_power_is_the_closed_form_response_to_the_request(trip, name):
    """Every running module gets the setpoint of (reference + request)/n, held over the exchange
    (equal dispatch: n = N; target dispatch at t: n = reference/P(t) modules, counted for the
    reference, the others idle); its current follows G(s) = K(a/(tau1 s+1) + b/(tau2 s+1)), or
    K/(tau1 s+1) with compensation, or with the zero at tn the same with a = (tn - tau1)/(tau2 -
    tau1), b = 1 - a, exactly for a held input (the request only lowers the draw: no ramp limit)."""
    _, cases, _ = trip
    o = cases[name]
    e = exchanges(o)
    a, b = modal_weights()
    if o["compensation"]:
        a, b = 1.0, 0.0
    if o["filter_zero"] > 0:
        a = (o["filter_zero"] - PAPER["tauPole1"]) / (PAPER["tauPole2"] - PAPER["tauPole1"])
        b = 1.0 - a
    n = N if o["dispatch_target"] is None else round(o["p_ref"] / module_power(o["dispatch_target"]))
    u = [setpoint_for((o["p_ref"] + r) / n) for r in e["request"]]
    z1, z2 = a * K * u[0], b * K * u[0]
    e1, e2 = math.exp(-EXCHANGE / PAPER["tauPole1"]), math.exp(-EXCHANGE / PAPER["tauPole2"])
    expected = []
    for uk in u:
        i = z1 + z2
        expected.append(n * (V0 + R * i) * i)
        z1 = a * K * uk + (z1 - a * K * uk) * e1
        z2 = b * K * uk + (z2 - b * K * uk) * e2
    assert e["hub"] == pytest.approx(np.array(expected), rel=1e-9)


def test_reserve_lifts_the_frequency_and_compensation_reduces_faster(trip):
    _, cases, table = trip
    none, plain, comp, slow, both = (cases[n] for n in generator_trip.RUNS)
    # identical until the hub is asked for something (f < 49.9 Hz)
    quiet = none["time"] < TRIP + 0.1
    for o in (plain, comp, slow, both):
        assert np.abs(o["f"][quiet] - none["f"][quiet]).max() < 1e-12
    for o in (plain, comp, slow, both):
        assert o["f"].min() >= none["f"].min() - 1e-6  # nadir not lower (Hz)
        assert o["f"][-1] > none["f"][-1]
    at = np.searchsorted(none["time"], TRIP + 7.5 + DT / 2)  # the sample holding the power at the trip + 7.5 s
    assert none["time"][at] == pytest.approx(TRIP + 7.5 + DT)
    assert comp["hub"][at] < plain["hub"][at] < none["hub"][at] - 0.25 * CAPACITY
    assert plain["hub"][at] < slow["hub"][at] < none["hub"][at]  # the optimised control is slower
    assert plain["hub"][at] < both["hub"][at] < none["hub"][at]  # so is the one with fewer modules
    # what the hub gives up lifts the frequency, by less than the governors' droop alone would
    # (1261 MW/Hz): part of it goes to the impedance loads, whose voltage rises with it
    for o in (plain, comp):
        lift = o["f_coi"][-1] - none["f_coi"][-1]
        relief = (none["hub"][-1] - o["hub"][-1]) / 1e6
        assert 0.3 * relief / STIFFNESS < lift < relief / STIFFNESS
    # the table reports the same
    assert table["FCR-D up, compensated"]["hub power at trip + 7.5 s [MW]"] == pytest.approx(comp["hub"][at] / 1e6)
    assert table["no reserve"]["nadir [Hz]"] == pytest.approx(none["f"].min())
    for m in table.values():
        assert -1.0 < m["max RoCoF [Hz/s]"] < -0.1
        assert 49.5 < m["nadir [Hz]"] <= m["first dip [Hz]"] < 49.9


def test_files_carry_units_and_every_step(trip):
    out, cases, table = trip
    with open(out.with_suffix(".csv"), newline="") as f:
        rows = list(csv.reader(f))
    header, data = rows[0], np.array(rows[1:], dtype=float)
    assert all(h.endswith("]") for h in header)
    assert len(data) == len(cases["no reserve"]["time"]) == round(DURATION / DT)
    col = {h: i for i, h in enumerate(header)}
    assert np.allclose(data[:, col["FCR-D up reserveRequest [W]"]], cases["FCR-D up"]["request"], rtol=1e-9)
    with open(out.parent / f"{out.name}_table.csv", newline="") as f:
        table_rows = list(csv.DictReader(f))
    assert [r["run"] for r in table_rows] == list(generator_trip.RUNS)
    assert all("[" in h for h in table_rows[0] if h != "run")
    assert out.with_suffix(".png").stat().st_size > 10_000


def test_command_line_help_and_a_horizon_too_short():
    script = ["-m", "aem_electrolyser.examples.generator_trip"]
    result = subprocess.run([sys.executable, *script, "--help"], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0 and "--capacity" in result.stdout and "FCR-D" in result.stdout
    result = subprocess.run([sys.executable, *script, "--duration", "4"], capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and "--duration" in result.stderr
