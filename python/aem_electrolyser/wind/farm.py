#!/usr/bin/env python3
"""Seeded 1 s power time series of a 64 MW offshore wind farm (8 turbines of 8 MW).

    python -m aem_electrolyser.wind.farm [--hours 1] [--seed 1] [--out out]

Importable: `farm_power(duration, seed=...)` returns (time [s], farm power [W], turbine wind
speeds [m/s]); `extreme_operating_gust(...)` gives the IEC gust used by aem_electrolyser.examples.grid_cosim.

Model (simple and documented; every number below is a default that can be changed):

* Site. Hub-height mean wind 10 m/s and turbulence intensity 8 %: the long-term mean wind
  speed at about 100 m in the German Bight (FINO1 research platform) is close to 10 m/s, and
  the ambient offshore turbulence intensity there is about 5-8 % at 10 m/s (Türk & Emeis,
  J. Wind Eng. Ind. Aerodyn. 98 (2010) 466-471); wake-added turbulence inside a farm moves
  it towards 10 %, so 8 % is a middle value.
* Turbulence. Longitudinal component with the Kaimal spectrum in the form of IEC 61400-1
  ed. 3, Annex C: S(f) = 4 σ² (L/V) / (1 + 6 f L/V)^(5/3), integral scale L = 8.1 Λ1 with
  Λ1 = 42 m above 60 m hub height (L = 340.2 m), σ = TI·V. Synthesised by inverse FFT with
  Gaussian Fourier coefficients (a stationary Gaussian process), then each realised series is
  scaled to σ exactly (as TurbSim's ScaleIEC option does), because a finite record's sampling
  scatter of the variance is not what an example should show.
* Farm smoothing. Each turbine sees a common part and an own part of the turbulence; at
  frequency f the common fraction is Davenport's coherence γ(f) = exp(-a f d / V) for a
  representative spacing d = 1 km (about 6 rotor diameters) and decay a = 4 (our assumption;
  measured decays range from a few to about 20 depending on direction and spacing). Slow
  variations are shared by all turbines, fast ones average out. No wake deficits, no frozen
  turbulence delays, no rotor averaging (the last makes the series slightly more variable
  than a real rotor's).
* Turbine. Generic 8 MW: rotor diameter 164 m (the class of the MHI Vestas V164-8.0 MW),
  air density 1.225 kg/m³, power coefficient 0.44 below rated, P = min(8 MW, ½ρAC_p v³)
  between cut-in 4 m/s and cut-out 25 m/s (the V164's published cut-in and cut-out speeds),
  zero outside; rated power is reached at 11.2 m/s. Electrical losses are neglected.
"""

import csv
from dataclasses import dataclass

import numpy as np
from aem_electrolyser import cli


@dataclass(frozen=True)
class Site:
    mean_speed: float = 10.0  # hub-height mean wind [m/s]
    turbulence_intensity: float = 0.08  # σ/V [1]
    length_scale: float = 8.1 * 42.0  # Kaimal integral scale L [m] (IEC 61400-1, hub > 60 m)
    spacing: float = 1000.0  # representative turbine spacing d [m]
    coherence_decay: float = 4.0  # Davenport decay a [1]; inf = independent turbines

    @property
    def sigma(self):
        return self.turbulence_intensity * self.mean_speed


@dataclass(frozen=True)
class Turbine:
    rated_power: float = 8e6  # [W]
    rotor_diameter: float = 164.0  # [m]
    power_coefficient: float = 0.44  # C_p below rated [1]
    air_density: float = 1.225  # [kg/m³]
    cut_in: float = 4.0  # [m/s]
    cut_out: float = 25.0  # [m/s]

    @property
    def rated_speed(self):
        area = np.pi * self.rotor_diameter**2 / 4.0
        return (self.rated_power / (0.5 * self.air_density * area * self.power_coefficient)) ** (1.0 / 3.0)


N_TURBINES = 8  # 8 x 8 MW = 64 MW, the paper's wind farm rating


def kaimal_spectrum(f, mean_speed, sigma, length_scale):
    """One-sided Kaimal spectrum S(f) [(m/s)²/Hz] of IEC 61400-1 ed. 3, Annex C."""
    f = np.asarray(f, dtype=float)
    lv = length_scale / mean_speed
    return 4.0 * sigma**2 * lv / (1.0 + 6.0 * f * lv) ** (5.0 / 3.0)


def turbulent_speeds(duration, dt=1.0, site=Site(), n_turbines=N_TURBINES, seed=1):
    """Wind speed [m/s] at each turbine, shape (n_turbines, samples), samples = duration/dt."""
    n = int(round(duration / dt))
    if n < 2:
        raise ValueError("duration must cover at least two samples")
    rng = np.random.default_rng(seed)
    f = np.fft.rfftfreq(n, dt)
    s = kaimal_spectrum(f, site.mean_speed, site.sigma, site.length_scale)
    s[0] = 0.0  # zero-mean turbulence
    amp = np.sqrt(s * (f[1] - f[0]) / 2.0) * n  # numpy irfft scaling: var = Σ S Δf
    gamma = np.exp(-site.coherence_decay * f * site.spacing / site.mean_speed)

    def gaussian():
        return (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) / np.sqrt(2.0)

    common = gaussian()
    speeds = np.empty((n_turbines, n))
    for i in range(n_turbines):
        coeff = amp * (np.sqrt(gamma) * common + np.sqrt(1.0 - gamma) * gaussian())
        u = np.fft.irfft(coeff, n)
        u -= u.mean()
        speeds[i] = site.mean_speed + u * (site.sigma / u.std())
    return speeds


def rotor_effective(speeds, dt, mean_speed, rotor_diameter):
    """First-order low-pass, τ = D/(2V), of each row of speeds [m/s] (circular, via FFT)."""
    speeds = np.atleast_2d(speeds)
    n = speeds.shape[-1]
    f = np.fft.rfftfreq(n, dt)
    tau = rotor_diameter / (2.0 * mean_speed)
    return np.fft.irfft(np.fft.rfft(speeds, axis=-1) / (1.0 + 2j * np.pi * f * tau), n, axis=-1)


def power_curve(speed, turbine=Turbine()):
    """Electric power [W] of one turbine at hub-height wind speed [m/s]."""
    v = np.asarray(speed, dtype=float)
    area = np.pi * turbine.rotor_diameter**2 / 4.0
    p = 0.5 * turbine.air_density * area * turbine.power_coefficient * v**3
    p = np.minimum(p, turbine.rated_power)
    return np.where((v >= turbine.cut_in) & (v < turbine.cut_out), p, 0.0)


def farm_power(duration, dt=1.0, site=Site(), turbine=Turbine(), n_turbines=N_TURBINES, seed=1, rotor_filter=True):
    """(time [s], farm power [W], turbine wind speeds [m/s]) for a seeded record; the speeds
    are the rotor-effective ones that drive the power curve."""
    speeds = turbulent_speeds(duration, dt, site, n_turbines, seed)
    if rotor_filter:
        speeds = rotor_effective(speeds, dt, site.mean_speed, turbine.rotor_diameter)
    t = np.arange(speeds.shape[1]) * dt
    return t, power_curve(speeds, turbine).sum(axis=0), speeds


def extreme_operating_gust(t, start, site=Site(), turbine=Turbine(), period=10.5):
    """Wind speed increment [m/s] of the IEC 61400-1 ed. 3 extreme operating gust (6.3.2.2).

    V(t) = V - 0.37 V_gust sin(3πτ/T)(1 - cos(2πτ/T)) for 0 ≤ τ = t - start ≤ T, with
    V_gust = 3.3 σ / (1 + 0.1 D / Λ1) (the 1-year extreme-wind bound is not binding here).
    A dip, a rise of +0.74 V_gust at T/2, a dip, over T = 10.5 s; all turbines at once.
    """
    tau = np.asarray(t, dtype=float) - start
    v_gust = 3.3 * site.sigma / (1.0 + 0.1 * turbine.rotor_diameter / (site.length_scale / 8.1))
    x = np.clip(tau / period, 0.0, 1.0)
    return -0.37 * v_gust * np.sin(3 * np.pi * x) * (1 - np.cos(2 * np.pi * x))


def main(argv=None):
    parser = cli.CommandLine(description=__doc__)
    parser.add_argument("--hours", type=cli.positive(float), default=1.0, help="hours of 1 s samples [default: 1]")
    parser.add_argument("--seed", type=int, default=1, help="seed of the series [default: 1]")
    cli.add_out_option(parser, "out", "wind_farm.csv")
    args = parser.parse_args(argv)
    if args.hours * 3600.0 < 2.0:
        parser.error(f"--hours: {args.hours:g} h is shorter than two 1 s samples")
    path = cli.writable_folder(args.out) / "wind_farm.csv"
    t, p, speeds = farm_power(args.hours * 3600.0, seed=args.seed)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time [s]", "farm power [W]", "mean turbine wind [m/s]"])
        for row in zip(t, p, speeds.mean(axis=0)):
            w.writerow([f"{x:.10g}" for x in row])
    if args.quiet:
        return
    rated = N_TURBINES * Turbine().rated_power
    print(
        f"wind farm {rated / 1e6:.0f} MW, {t.size} s: mean {p.mean() / 1e6:.2f} MW "
        f"(capacity factor {p.mean() / rated:.2f}), min {p.min() / 1e6:.2f} MW, max {p.max() / 1e6:.2f} MW, "
        f"std {p.std() / 1e6:.2f} MW, largest 1 s change {np.abs(np.diff(p)).max() / 1e6:.2f} MW"
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    cli.run_command(main)
