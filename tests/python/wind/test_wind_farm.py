"""aem_electrolyser.wind.farm: Kaimal turbulence, farm coherence, power curve, IEC gust."""

import numpy as np
import pytest
from scipy import signal

from aem_electrolyser.wind import farm as wf


@pytest.fixture(scope="module")
def long_record():
    """Six hours of two turbines, 1 s."""
    return wf.turbulent_speeds(6 * 3600.0, site=wf.Site(), n_turbines=2, seed=7)


def test_mean_and_turbulence_intensity_are_the_targets(long_record):
    site = wf.Site()
    for u in long_record:
        assert u.mean() == pytest.approx(site.mean_speed, abs=1e-9)
        assert u.std() / u.mean() == pytest.approx(site.turbulence_intensity, rel=1e-9)


def test_spectrum_has_the_kaimal_shape(long_record):
    site = wf.Site()
    f, psd = signal.welch(long_record, fs=1.0, nperseg=4096, axis=-1)
    psd = psd.mean(axis=0)
    target = wf.kaimal_spectrum(f, site.mean_speed, site.sigma, site.length_scale)
    # Band-averaged ratio from 2 mHz (a 34 s integral time scale) to 0.3 Hz, one band per decade
    # third. The record is scaled to σ over 0 < f ≤ 0.5 Hz, so the level sits a few % above
    # the one-sided Kaimal spectrum, which spreads σ² to infinity.
    edges = np.geomspace(2e-3, 0.3, 8)
    ratios = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        band = (f >= lo) & (f < hi)
        ratios.append(psd[band].mean() / target[band].mean())
    ratios = np.array(ratios)
    assert np.all((ratios > 0.8) & (ratios < 1.3)), ratios
    # and the inertial-range slope: -5/3 asymptotically, -5/3·x/(1+x) locally (x = 6fL/V)
    band = (f > 0.1) & (f < 0.4)
    slope = np.polyfit(np.log(f[band]), np.log(psd[band]), 1)[0]
    x = 6 * np.sqrt(0.1 * 0.4) * site.length_scale / site.mean_speed
    assert slope == pytest.approx(-5 / 3 * x / (1 + x), abs=0.15)


def test_turbines_share_slow_and_not_fast_turbulence(long_record):
    site = wf.Site()
    f, coh = signal.coherence(long_record[0], long_record[1], fs=1.0, nperseg=2048)
    gamma = np.exp(-site.coherence_decay * f * site.spacing / site.mean_speed)
    slow = (f > 1e-3) & (f < 3e-3)
    fast = (f > 0.05) & (f < 0.2)
    assert coh[slow].mean() == pytest.approx((gamma[slow] ** 2).mean(), abs=0.15)  # γ is root coherence
    assert coh[fast].mean() < 0.15  # the estimator bias of ~20 averaged segments


def test_farm_smoothing_reduces_relative_fluctuation():
    t, p_farm, speeds = wf.farm_power(3600.0, seed=3)
    single = wf.power_curve(speeds[0])
    assert np.std(np.diff(p_farm)) / p_farm.mean() < 0.6 * np.std(np.diff(single)) / single.mean()


def test_seed_reproducibility():
    a = wf.farm_power(600.0, seed=11)[1]
    b = wf.farm_power(600.0, seed=11)[1]
    c = wf.farm_power(600.0, seed=12)[1]
    assert np.array_equal(a, b)
    assert not np.allclose(a, c)


def test_power_curve_limits():
    tb = wf.Turbine()
    v = np.linspace(0, 30, 3001)
    p = wf.power_curve(v, tb)
    assert np.all(p[v < tb.cut_in] == 0)
    assert np.all(p[v >= tb.cut_out] == 0)
    assert np.all(p <= tb.rated_power)
    on = (v >= tb.cut_in) & (v < tb.cut_out)
    assert np.all(np.diff(p[on]) >= 0)
    assert np.all(p[(v >= tb.rated_speed) & on] == tb.rated_power)
    assert 10.5 < tb.rated_speed < 12.0
    assert wf.N_TURBINES * tb.rated_power == 64e6


def test_extreme_operating_gust_shape():
    site, tb = wf.Site(), wf.Turbine()
    t = np.arange(0.0, 40.0, 0.05)
    g = wf.extreme_operating_gust(t, start=10.0, site=site, turbine=tb)
    assert np.all(g[(t <= 10.0) | (t >= 20.5)] == pytest.approx(0.0, abs=1e-12))
    v_gust = 3.3 * site.sigma / (1 + 0.1 * tb.rotor_diameter / 42.0)
    assert g.max() == pytest.approx(0.74 * v_gust, rel=1e-3)
    assert t[np.argmax(g)] == pytest.approx(15.25, abs=0.05)


def test_rotor_filter_keeps_the_mean_and_removes_fast_turbulence(long_record):
    site, tb = wf.Site(), wf.Turbine()
    rotor = wf.rotor_effective(long_record, 1.0, site.mean_speed, tb.rotor_diameter)
    assert rotor.mean(axis=1) == pytest.approx(long_record.mean(axis=1), abs=1e-9)
    # |H|² = 1/(1 + (2πfτ)²) with τ = D/(2V): a tenth of the power at 0.06 Hz is left
    f, p_point = signal.welch(long_record[0], fs=1.0, nperseg=1024)
    _, p_rotor = signal.welch(rotor[0], fs=1.0, nperseg=1024)
    tau = tb.rotor_diameter / (2 * site.mean_speed)
    band = (f > 0.05) & (f < 0.07)
    expected = 1 / (1 + (2 * np.pi * f[band] * tau) ** 2)
    assert (p_rotor[band] / p_point[band]).mean() == pytest.approx(expected.mean(), rel=0.05)
