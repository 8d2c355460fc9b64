"""aem-identify's temperature stage on measured data that nobody here wrote: de Groot, Kraakman
and Garcia Barros (Int J Hydrogen Energy 2022), an advanced alkaline single cell at 30 bar and
50, 60 and 70 degC, as the aec-modelling package (MIT) ships it.

The cell's polarisation curves are written as a log (current density in mA/cm2 as the current
column, the cell voltage, the temperature) and fitted by the installed command with the
nominal temperature at 60 degC and a window of +-10.5 K (all three curves), above 100 mA/cm2
(past the activation knee, where the linear-in-I model can hold). Expectations from the
physics, not from this code: within that window the linear-in-T model fits the measured curves
to about a hundredth of a volt; the voltage falls as the cell warms (kV < 0), by a few mV/K
per cell; and the resistance falls too (kR < 0), by less than 2 %/K of R.
"""

import json
import subprocess

import pytest

from aem_electrolyser import locate

datasets = pytest.importorskip("aec_modelling.datasets", reason="aec-modelling (requirements.txt) is not installed")


def fit_measured(tmp_path, name, nominal, window, running):
    frame = datasets.load(name).sort_values(["T", "j"])
    log = tmp_path / f"{name}.csv"
    rows = ["time,current,voltage,temperature"]
    rows += [f"{k},{j!r},{v!r},{t - 273.15!r}" for k, (j, t, v) in enumerate(zip(frame["j"], frame["T"], frame["V"]))]
    log.write_text("\n".join(rows) + "\n")
    out = tmp_path / f"{name}.json"
    done = subprocess.run(
        [
            str(locate.binary("aem-identify")),
            "fit",
            str(log),
            "-o",
            str(out),
            "--nominal-temperature",
            str(nominal),
            "--temperature-window",
            str(window),
            "--running-current",
            str(running),
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    statistics = json.loads(out.read_text())["modules"][0]["statistics"]
    return statistics["temperature"], done.stdout


def test_de_groots_temperature_series_fits_a_linear_in_t_curve(tmp_path):
    fit, report = fit_measured(tmp_path, "degroot_temperature", nominal=60.0, window=10.5, running=100.0)
    assert fit["points"] >= 15 and fit["temperatureRangeDegC"] == [50.0, 70.0]
    assert fit["rmseV"] < 0.02, fit
    kv, kr, r = fit["voltageTemperatureCoefficient"], fit["resistanceTemperatureCoefficient"], fit["ohmicResistance"]
    assert -0.01 < kv["value"] < -0.0005, kv  # a few mV/K per cell, negative
    assert kv["interval95"][1] < 0.0, kv  # negative with 95 % confidence
    assert -0.02 * r["value"] < kr["value"] < 0.0, (kr, r)
    assert "Temperature" in report and "kV" in report


def test_a_single_temperature_is_reported_as_not_identifiable(tmp_path):
    fit, report = fit_measured(tmp_path, "degroot_temperature", nominal=50.0, window=5.0, running=10.0)
    assert "not identifiable" in fit["skipped"] and "varies by" in fit["skipped"], fit
    assert "not identifiable" in report
