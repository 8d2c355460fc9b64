"""aem_electrolyser.wind.year: a seeded year of 1 s wind-farm power (hourly Weibull/AR(1) weather,
chunked Kaimal turbulence of aem_electrolyser.wind.farm). Expectations come from the model's
definitions (the Weibull law, the AR(1) process, c(t), the Kaimal spectrum and the rotor
filter), with tolerances of a few standard errors of the estimate."""

import time
from dataclasses import replace

import numpy as np
import pytest
from scipy import stats
from scipy.special import gamma, ndtri

from aem_electrolyser.wind.year import (
    DAY,
    FARM_RATING,
    HOUR,
    WindClimate,
    farm_power_year,
    hourly_mean_wind,
    wind_speeds,
)
from aem_electrolyser.wind.farm import N_TURBINES, Site, Turbine, kaimal_spectrum, power_curve

CLIMATE = WindClimate()
FLAT = replace(CLIMATE, seasonal_amplitude=0.0, diurnal_amplitude=0.0)  # stationary hours
CENTURY = 100 * 8766  # hours: a long record whose mean has a standard error of ~0.05 m/s


def weibull_scale(climate):
    """c0 = V̄/Γ(1 + 1/k) [m/s]: the mean of a Weibull(k, c0) law is V̄."""
    return climate.mean_speed / gamma(1.0 + 1.0 / climate.weibull_shape)


def hourly_averages(x, dt):
    """Means over whole hours of a series sampled every dt [s]."""
    per = int(round(HOUR / dt))
    return x[: x.size // per * per].reshape(-1, per).mean(axis=1)


# --- reproducibility, length, range ---------------------------------------------------------


def test_same_seed_is_bit_identical_and_another_seed_differs():
    a = farm_power_year(DAY, seed=5)
    assert np.array_equal(a, farm_power_year(DAY, seed=5))
    assert np.array_equal(a, farm_power_year(DAY, seed=5, threads=1))  # threads change nothing
    assert not np.allclose(a, farm_power_year(DAY, seed=6))
    assert np.array_equal(hourly_mean_wind(500, 5), hourly_mean_wind(500, 5))
    assert not np.allclose(hourly_mean_wind(500, 5), hourly_mean_wind(500, 6))


def test_a_shorter_run_is_the_start_of_a_longer_one():
    long = farm_power_year(2 * DAY, seed=2)
    assert np.array_equal(farm_power_year(DAY + 1234.0, seed=2), long[: 86400 + 1234])
    assert np.array_equal(hourly_mean_wind(100, 2), hourly_mean_wind(1000, 2)[:100])


@pytest.mark.parametrize("dt", [1.0, 10.0])
def test_length_for_a_duration_that_is_not_whole_records(dt):
    duration = 13 * HOUR + 1234.0  # 4 records of 3 h and a part of the fifth
    p = farm_power_year(duration, dt=dt, seed=3)
    assert p.dtype == np.float64 and p.size == round(duration / dt)
    assert np.all((p >= 0) & (p <= FARM_RATING))


def test_dt_changes_the_sampling_not_the_weather():
    """The hourly weather depends on the seed only; turbulence averages out over an hour."""
    fine = hourly_averages(farm_power_year(4 * DAY, dt=1.0, seed=4), 1.0)
    coarse = hourly_averages(farm_power_year(4 * DAY, dt=10.0, seed=4), 10.0)
    assert np.corrcoef(fine, coarse)[0, 1] > 0.95
    assert abs(fine.mean() - coarse.mean()) < 0.03 * FARM_RATING


def test_rating_is_eight_turbines_of_8_mw():
    assert FARM_RATING == N_TURBINES * Turbine().rated_power == 64e6


def test_invalid_layouts_are_refused():
    with pytest.raises(ValueError):
        farm_power_year(0.4, dt=1.0)  # no sample
    with pytest.raises(ValueError):
        farm_power_year(DAY, climate=replace(CLIMATE, overlap=4 * HOUR))  # overlap > chunk


# --- hourly means: Weibull marginal, AR(1) persistence, seasonal and diurnal cycles -----------


def test_hourly_marginal_is_the_weibull_law():
    v = hourly_mean_wind(CENTURY, seed=11, climate=FLAT)
    k, c = FLAT.weibull_shape, weibull_scale(FLAT)
    assert v.min() > 0
    assert v.mean() == pytest.approx(FLAT.mean_speed, abs=0.2)  # ~4 standard errors
    # KS distance; ~11 000 effective samples (AR(1) with φ = 0.975) give ~0.013 at 5 %;
    # k = 2.0 instead of 2.2 would already be 0.023 away.
    assert stats.kstest(v, stats.weibull_min(k, scale=c).cdf).statistic < 0.02
    k_fit, _, c_fit = stats.weibull_min.fit(v, floc=0)
    assert k_fit == pytest.approx(k, abs=0.05)
    assert c_fit == pytest.approx(c, rel=0.02)


def test_underlying_gaussian_process_has_the_ar1_persistence():
    """z_h = Φ⁻¹(F_Weibull(V_h)) recovers the AR(1) process: corr(z_h, z_h+l) = φ^l."""
    v = hourly_mean_wind(CENTURY, seed=12, climate=FLAT)
    z = ndtri(-np.expm1(-((v / weibull_scale(FLAT)) ** FLAT.weibull_shape)))
    phi = FLAT.persistence
    assert z.mean() == pytest.approx(0.0, abs=0.05) and z.std() == pytest.approx(1.0, abs=0.05)
    for lag, tol in [(1, 0.003), (24, 0.03)]:  # standard errors ~0.0003 and ~0.01
        assert np.corrcoef(z[:-lag], z[lag:])[0, 1] == pytest.approx(phi**lag, abs=tol)


def test_seasonal_and_diurnal_cycles_have_their_amplitudes_and_peaks():
    """E[V | t] = c(t) Γ(1+1/k), so V/V̄ regressed on the first harmonics of the year and the
    day returns (a_s, day_peak) and (a_d, hour_peak)."""
    v = hourly_mean_wind(CENTURY, seed=13, climate=CLIMATE)
    day = (np.arange(v.size) + 0.5) / 24.0
    ws, wd = 2 * np.pi * day / 365.25, 2 * np.pi * day
    x = np.column_stack([np.ones_like(day), np.cos(ws), np.sin(ws), np.cos(wd), np.sin(wd)])
    b = np.linalg.lstsq(x, v / CLIMATE.mean_speed, rcond=None)[0]
    assert np.hypot(b[1], b[2]) == pytest.approx(CLIMATE.seasonal_amplitude, abs=0.03)  # SE ~0.009
    assert np.arctan2(b[2], b[1]) % (2 * np.pi) * 365.25 / (2 * np.pi) == pytest.approx(CLIMATE.peak_day, abs=10)
    assert np.hypot(b[3], b[4]) == pytest.approx(CLIMATE.diurnal_amplitude, abs=0.004)  # SE ~0.001
    assert np.arctan2(b[4], b[3]) % (2 * np.pi) * 24 / (2 * np.pi) == pytest.approx(CLIMATE.peak_hour, abs=1.0)
    # and in plain words: winter (Dec-Feb) is windier than summer (Jun-Aug) by the ratio of
    # their mean seasonal factors, about (1 + 0.9 a_s)/(1 - 0.9 a_s) = 1.39
    doy = day % 365.25
    winter, summer = (doy < 59) | (doy >= 334), (doy >= 151) & (doy < 243)
    season = 1 + CLIMATE.seasonal_amplitude * np.cos(2 * np.pi * (doy - CLIMATE.peak_day) / 365.25)
    expected = season[winter].mean() / season[summer].mean()
    assert v[winter].mean() / v[summer].mean() == pytest.approx(expected, abs=0.06)  # SE ~0.02


# --- 1 s speeds: turbulence level and record boundaries --------------------------------------


def within_hour_ratio(speeds, hourly, climate):
    """Mean over hours and turbines of std(detrended 1 s speed)/(TI V_h) [1]."""
    n_hours = speeds.shape[1] // 3600
    u = speeds[:, : n_hours * 3600].reshape(speeds.shape[0], n_hours, 3600)
    s = np.arange(3600.0) - 1799.5
    slope = (u * s).sum(axis=-1, keepdims=True) / (s * s).sum()
    resid = u - u.mean(axis=-1, keepdims=True) - slope * s
    return (resid.std(axis=-1) / (climate.turbulence_intensity * hourly[:n_hours])).mean()


def rotor_share(mean_speed):
    """√(∫S|H|² df / ∫S df) over 1/3600 … 0.5 Hz [1]: the rotor filter |H|² = 1/(1 + (2πfτ)²),
    τ = D/(2V), on the Kaimal spectrum cut at the Nyquist frequency of 1 s samples."""
    site, f = Site(mean_speed=mean_speed), np.linspace(1 / 3600, 0.5, 20000)
    s = kaimal_spectrum(f, site.mean_speed, site.sigma, site.length_scale)
    tau = Turbine().rotor_diameter / (2 * mean_speed)
    return np.sqrt((s / (1 + (2 * np.pi * f * tau) ** 2)).sum() / s.sum())


def test_turbulence_within_an_hour_is_ti_times_the_mean_wind():
    days, seed = 4, 21
    hourly = hourly_mean_wind(days * 24, seed)
    point = within_hour_ratio(wind_speeds(days * DAY, seed=seed, rotor_filter=False), hourly, CLIMATE)
    # σ = TI·V; periods beyond an hour (a few % of the variance of a 3 h record) and the
    # interpolated mean's trend (removed) are not within-hour variance. Seeds scatter by ±0.005.
    assert 0.95 < point < 1.02
    rotor = within_hour_ratio(wind_speeds(days * DAY, seed=seed), hourly, CLIMATE)
    expected = np.mean([rotor_share(v) for v in hourly])  # 0.79 at 5 m/s … 0.82 at 20 m/s
    assert rotor / point == pytest.approx(expected, rel=0.02)


def boundary_jump_ratio(climate, days=10, seed=31, half=30):
    """Mean over windows of the largest normalised 1 s change |Δv|/(TI V) of all turbines in
    ±half s around record starts and blend ends, over that in windows mid-record [1]."""
    speeds = wind_speeds(days * DAY, seed=seed, climate=climate)
    mean = np.interp(
        np.arange(speeds.shape[1]) + 0.5,
        (np.arange(days * 24 + 1) + 0.5) * HOUR,
        hourly_mean_wind(days * 24 + 1, seed, climate),
    )
    jump = np.abs(np.diff(speeds, axis=1)) / (climate.turbulence_intensity * mean[1:])
    m, o = int(climate.chunk), int(climate.overlap)
    starts = np.arange(m, speeds.shape[1] - m, m)

    def largest(centres):
        return np.mean([jump[:, c - half : c + half].max() for c in centres])

    at_edges = largest(np.concatenate([starts, starts + o]) if o else starts)
    return at_edges / largest(np.concatenate([starts + m // 3, starts + 2 * m // 3]))


def test_no_jump_at_record_boundaries():
    assert boundary_jump_ratio(CLIMATE) < 1.15  # ~80 windows of 480 changes each: SE ~3 %
    # the same statistic sees the jump of unblended records (and so can fail)
    assert boundary_jump_ratio(replace(CLIMATE, overlap=0.0)) > 2.0


# --- whole runs ------------------------------------------------------------------------------


def test_power_follows_the_hourly_wind_through_the_power_curve():
    """Turbulence averages out in hourly means: farm power ≈ N·P(V_h) hour by hour."""
    seed = 41
    p = hourly_averages(farm_power_year(30 * DAY, seed=seed), 1.0)
    quasi_steady = N_TURBINES * power_curve(hourly_mean_wind(30 * 24, seed))
    assert np.corrcoef(p, quasi_steady)[0, 1] > 0.95
    assert p.mean() == pytest.approx(quasi_steady.mean(), rel=0.05)


@pytest.mark.slow
def test_a_year_at_1_s_runs_in_range():
    start = time.perf_counter()
    p = farm_power_year(365 * DAY, seed=1)
    elapsed = time.perf_counter() - start
    assert p.size == 31_536_000
    assert 0.0 == p.min() and p.max() == FARM_RATING  # calm and full-load hours both occur
    # capacity factor from the Weibull law through the power curve (no turbulence), with a
    # year's sampling scatter of ~±0.05
    v = np.linspace(0.01, 40, 40001)
    pdf = stats.weibull_min(CLIMATE.weibull_shape, scale=weibull_scale(CLIMATE)).pdf(v)
    cf = (power_curve(v) * pdf).sum() * (v[1] - v[0]) / Turbine().rated_power
    assert p.mean() / FARM_RATING == pytest.approx(cf, abs=0.1)
    assert elapsed < 60  # about 12 s on two free cores; generous for a shared machine
