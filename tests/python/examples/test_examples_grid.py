"""Smoke runs of examples 3 (aem_electrolyser.examples.wind_hub) and 4 (aem_electrolyser.examples.grid_cosim) through the
packaged hub FMU, with short horizons, and the numbers they must get right."""

import csv

import numpy as np
import pytest

from aem_electrolyser.examples import grid_cosim, wind_hub
from aem_electrolyser.hub import HubFMU

HUB = HubFMU
# TOPS co-simulations
pytestmark = [
    pytest.mark.cosim,
    pytest.mark.filterwarnings("ignore:numpy.core is deprecated:DeprecationWarning"),
]  # inside tops


@pytest.fixture(scope="module")
def wind_hub_run(fmu_path, tmp_path_factory):
    out = tmp_path_factory.mktemp("wind_hub")
    return out / "wind_hub", wind_hub.run(fmu_path, duration=900.0, seed=2, out=out, hub_factory=HUB, verbose=False)


def test_wind_hub_energy_balance(wind_hub_run):
    out, (t, wind, runs, summaries) = wind_hub_run
    assert set(runs) == {"equal", "sequential"}
    for d, s in summaries.items():
        # wind = hub + grid exchange, to rounding
        assert s["wind"] == pytest.approx(s["hub"] + s["grid"], rel=1e-12)
        assert s["grid"] == pytest.approx(s["exported"] - s["imported"], rel=1e-9, abs=1e-3)
        # the FMU's energy integral agrees with its sampled power (trapezoid over 1 s samples)
        o = runs[d]
        assert s["hub"] == pytest.approx(np.trapezoid(o["hubPower"], t), rel=2e-3)
        assert np.isfinite(s["rms"])
        # hydrogen by mass: the normal litres made times M(H2)/V_m(0 °C, 1 atm), 2.01588 g/mol
        # over 22.413969 l/mol (the FMU's hubH2MassFlow uses the same density)
        made = o["hubH2Produced"][-1] - o["hubH2Produced"][0]
        assert s["h2_kg"] == pytest.approx(made * 2.01588e-3 / 22.413969, rel=1e-6) and made > 0
        assert 0 < s["rms"] < 0.2 * s["nominal"]
    # the CSV carries the same balance sample by sample
    with open(out.with_suffix(".csv")) as f:
        rows = list(csv.reader(f))
    header, data = rows[0], np.array(rows[1:], dtype=float)
    col = {name: i for i, name in enumerate(header)}
    for d in runs:
        assert np.allclose(
            data[:, col["wind power [W]"]],
            data[:, col[f"{d} hub power [W]"]] + data[:, col[f"{d} grid exchange [W]"]],
            rtol=1e-9,
        )
    assert len(data) == len(t) == 901
    assert out.with_suffix(".png").stat().st_size > 10_000


@pytest.mark.parametrize("dispatch", ["equal", "sequential"])
def test_hub_steady_power_for_a_constant_reference(fmu_path, dispatch):
    reference = np.full(600, 45e6)
    out, rating = wind_hub.simulate(fmu_path, reference, 1.0, dispatch, hub_factory=HUB)
    assert np.all(np.abs(out["hubPower"] / 45e6 - 1) < 1e-3)
    assert out["hubEnergy"][-1] == pytest.approx(45e6 * 600, rel=1e-3)
    assert wind_hub.N_MODULES * rating[1] == pytest.approx(58.6e6, rel=2e-3)


@pytest.fixture(scope="module")
def cosim(fmu_path):
    return grid_cosim.run(fmu_path, duration=20.0, gust_start=2.0, exchange=0.1, hub_factory=HUB, verbose=False)


def test_tops_starts_in_equilibrium(cosim):
    steady = cosim["steady wind"]
    assert np.abs(steady["df"]).max() < 1e-6  # Hz: no start transient
    assert np.abs(steady["v"] - steady["v0"]).max() < 1e-7  # pu
    assert np.allclose(steady["vsc_hub"], steady["hub"], rtol=1e-6)  # VSC draws the hub's power
    assert np.allclose(steady["vsc_wind"], steady["wind"], rtol=1e-6)


def test_gust_moves_frequency_and_the_vsc_follows_the_hub(cosim):
    gust = cosim["gust"]
    exchange = gust["vsc_wind"] - gust["vsc_hub"]
    assert exchange.max() > 10e6  # the hub lags the gust: export to the grid
    assert np.abs(gust["df"]).max() > 1e-3  # Hz, visible in a 3.6 GW system
    assert np.abs(gust["df"]).max() < 0.05
    # after the gust the hub VSC draws the FMU's power again
    late = gust["time"] > 15.0
    assert np.allclose(gust["vsc_hub"][late], gust["hub"][late], rtol=2e-3)
