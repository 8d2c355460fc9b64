#!/usr/bin/env python3
"""A seeded year (or any duration) of 1 s (or any dt) power of the 64 MW offshore wind farm of
aem_electrolyser.wind.farm, for year-long hub studies: each Dask worker regenerates it from
(duration, dt, seed, climate), bit for bit with the same numpy and scipy (on x86, the same
SIMD level too: numpy's AVX-512 kernels of pow/exp/cos may differ in the last bit; AVX2 and
the SSE baseline agree), using about a quarter of a GB beyond the interpreter for a year.

    python -m aem_electrolyser.wind.year [--days 365] [--seed 1] [--dt 1] [--out out]

Model (every number is a default field of `WindClimate`; time t = 0 is 1 January 00:00):

* Hourly mean hub-height wind V_h of hour h, [3600 h, 3600 (h+1)) s. A Gaussian AR(1) process
  z_h = φ z_(h-1) + √(1-φ²) ε_h (unit variance, z_0 ~ N(0,1)) gives persistence; it is mapped to
  a Weibull marginal, U = Φ(z_h), V_h = c(t_h) (-ln(1-U))^(1/k), evaluated as
  c (-ln Φ(-z))^(1/k) (scipy.special.log_ndtr, exact in the tails), at the hour's midpoint t_h
  with c(t) = c0 (1 + a_s cos 2π(day - day_peak)/365.25) (1 + a_d cos 2π(hour - hour_peak)/24).
  Hence E[V | t] = c(t) Γ(1+1/k) and c0 = V̄/Γ(1+1/k) = 11.29 m/s for the long-term mean
  V̄ = 10 m/s (FINO1 at about 100 m, as aem_electrolyser.wind.farm cites). Our assumptions, not
  fits to a data set: k = 2.2, an offshore-typical shape; φ = 0.975 per hour (correlation
  0.55 after a day, e-folding time 40 h, the synoptic scale); a_s = 0.18 with the maximum on
  16 January (monthly means about 11.8 m/s in January, 8.2 m/s in July, the North Sea's
  winter/summer contrast); a_d = 0.02, small because the sea surface hardly follows the
  daily cycle of heating, with the maximum at 18 h.
* 1 s wind at turbine i: V(t) (1 + TI u_i(t)), V(t) the hourly means interpolated linearly
  between hour midpoints (held before the first; an hour's mean of V(t) is
  V_(h-1)/8 + 3 V_h/4 + V_(h+1)/8), TI = 8 %. u_i is the turbulence of aem_electrolyser.wind.farm
  (Kaimal spectrum, Davenport coherence between turbines; each record scaled to σ exactly)
  normalised to unit standard deviation and passed through its rotor filter τ = D/(2V). It is
  synthesised in records ("chunks") of 3 h + 12 min overlap, each at the record's mean wind
  (the Kaimal time scale L/V follows the weather) from its own seed. Records are independent
  and periodic (circular FFT synthesis, circular rotor filter), so consecutive ones are
  blended over the overlap, s = 0 … 1, with weights cos(πs/2) and sin(πs/2) (cos² + sin² = 1
  keeps the variance; nothing jumps). Power = Σ_i power_curve(speed_i), the 8 MW curve, with
  its cut-out (25 m/s) decided on the mean wind V(t) rather than on each 1 s gust, as turbine
  controllers decide it on a 10-minute average: a storm stops the farm once, not in a flicker
  of 8 MW steps (the instantaneous cut-out gave 157 000 steps of 8 MW or more in a year).
* Seeds: SeedSequence(seed) with spawn key (0,) for the hourly process and (1, j) for
  record j, i.e. SeedSequence(seed).spawn(2)[a].spawn(...)[j]. Records start at multiples of
  round(chunk/dt) samples and are always synthesised whole, so a shorter run is the start of
  a longer one with the same dt, and the thread count does not change the result.
"""

import math
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np

from aem_electrolyser import cli
from aem_electrolyser.wind.farm import N_TURBINES, Site, Turbine, power_curve, rotor_effective, turbulent_speeds

FARM_RATING = N_TURBINES * Turbine().rated_power  # [W]
HOUR, DAY, YEAR_DAYS = 3600.0, 86400.0, 365.25  # [s], [s], [d]


@dataclass(frozen=True)
class WindClimate:
    mean_speed: float = 10.0  # long-term mean hourly hub-height wind V̄ [m/s]
    weibull_shape: float = 2.2  # k [1]
    persistence: float = 0.975  # φ, lag-1 h autocorrelation of z_h [1]
    seasonal_amplitude: float = 0.18  # a_s [1]
    peak_day: float = 15.0  # winter maximum, days after 1 January 00:00 [d]
    diurnal_amplitude: float = 0.02  # a_d [1]
    peak_hour: float = 18.0  # hour of the diurnal maximum [h]
    turbulence_intensity: float = 0.08  # TI = σ/V [1]
    chunk: float = 3 * HOUR  # turbulence record without its overlap [s]
    overlap: float = 720.0  # blend of consecutive records [s]; 3 h + 12 min = 2^8·3²·5 s

    @property
    def weibull_scale(self):
        """c0 = V̄ / Γ(1 + 1/k) [m/s]."""
        from scipy.special import gamma  # 1 s to import: not before a command's arguments are checked

        return self.mean_speed / gamma(1.0 + 1.0 / self.weibull_shape)


def _seeds(seed, *key):
    """The SeedSequence(seed).spawn(...) descendant with spawn key `key`."""
    return np.random.SeedSequence(seed, spawn_key=key)


def weibull_scale_at(t, climate=WindClimate()):
    """c(t) = c0 (1 + a_s cos 2π(day - day_peak)/365.25)(1 + a_d cos 2π(hour - hour_peak)/24)
    [m/s] at times t [s] after 1 January 00:00."""
    day, hour = t / DAY, (t % DAY) / HOUR
    season = 1.0 + climate.seasonal_amplitude * np.cos(2 * np.pi * (day - climate.peak_day) / YEAR_DAYS)
    diurnal = 1.0 + climate.diurnal_amplitude * np.cos(2 * np.pi * (hour - climate.peak_hour) / 24.0)
    return climate.weibull_scale * season * diurnal


def hourly_mean_wind(hours, seed=1, climate=WindClimate()):
    """V_h = c(t_h) (-ln Φ(-z_h))^(1/k) [m/s] for hours h = 0 … hours-1, t_h = (h + ½) 3600 s;
    z_h = φ z_(h-1) + √(1-φ²) ε_h, z_0 = ε_0. A shorter run is the start of a longer one."""
    phi = climate.persistence
    eps = np.random.default_rng(_seeds(seed, 0)).standard_normal(int(hours))
    eps[1:] *= math.sqrt(1.0 - phi * phi)
    from scipy.signal import lfilter  # 2 s to import: not before the command's arguments are checked
    from scipy.special import log_ndtr

    z = lfilter([1.0], [1.0, -phi], eps)
    t = (np.arange(int(hours)) + 0.5) * HOUR
    return weibull_scale_at(t, climate) * (-log_ndtr(-z)) ** (1.0 / climate.weibull_shape)


def _synthesise(duration, dt, seed, climate, emit, threads, rotor_filter=True):
    """Turbine speeds [m/s] of samples 0 … round(duration/dt)-1, sample k at (k + ½) dt, handed
    to emit(k0, k1, speeds[N_TURBINES, k1-k0], mean[k1-k0]) in consecutive or parallel pieces,
    with the mean wind V(t) [m/s] of the same samples."""
    n = int(round(duration / dt))
    m, o = int(round(climate.chunk / dt)), int(round(climate.overlap / dt))
    if n < 1 or m < 2 or not 0 <= o <= m:
        raise ValueError(
            f"need duration ≥ dt, chunk ≥ 2 dt and 0 ≤ overlap ≤ chunk (duration {duration} s, dt {dt} s, {climate})"
        )
    chunks = -(-n // m)
    hours = math.ceil((chunks * m + o) * dt / HOUR) + 1
    midpoints, hourly = (np.arange(hours) + 0.5) * HOUR, hourly_mean_wind(hours, seed, climate)
    ramp = (np.arange(o) + 0.5) / max(o, 1) * (np.pi / 2.0)  # s of the blend, as an angle
    fade_out, fade_in = np.cos(ramp), np.sin(ramp)
    ti, diameter = climate.turbulence_intensity, Turbine().rotor_diameter

    def send(k0, mean, u):
        k1 = min(k0 + mean.size, n)
        if k1 > k0:
            v = u[:, : k1 - k0] * ti
            v += 1.0
            v *= mean[: k1 - k0]
            emit(k0, k1, v, mean[: k1 - k0])

    def record(j):
        """Mean wind [m/s] and unit rotor-effective turbulence [1] of samples j m … (j+1) m + o."""
        mean = np.interp((j * m + np.arange(m + o) + 0.5) * dt, midpoints, hourly)
        site = Site(mean_speed=float(mean.mean()), turbulence_intensity=ti)
        u = turbulent_speeds((m + o) * dt, dt, site, N_TURBINES, _seeds(seed, 1, j))
        u -= site.mean_speed
        u /= site.sigma
        if rotor_filter:
            u = rotor_effective(u, dt, site.mean_speed, diameter)
        body = o if j else 0  # the head of records after the first is blended
        send(j * m + body, mean[body:m], u[:, body:m])
        return mean[:o], u[:, :o], u[:, m:]

    ahead = 2 * max(1, threads)  # records in flight: memory stays a few records
    tail = None
    with ThreadPoolExecutor(max(1, threads)) as pool:
        pending = deque(pool.submit(record, j) for j in range(min(ahead, chunks)))
        for j in range(chunks):
            mean, head, next_tail = pending.popleft().result()
            if j + ahead < chunks:
                pending.append(pool.submit(record, j + ahead))
            if j:
                send(j * m, mean, fade_out * tail + fade_in * head)
            tail = next_tail


def wind_speeds(duration, dt=1.0, seed=1, climate=WindClimate(), rotor_filter=True, threads=2):
    """Hub-height speed [m/s] of every turbine, shape (N_TURBINES, round(duration/dt)); the
    rotor-effective ones (the power curve's input) unless rotor_filter=False. For short
    records: a year takes 2 GB."""
    out = np.empty((N_TURBINES, int(round(duration / dt))))

    def emit(k0, k1, speeds, mean):
        out[:, k0:k1] = speeds

    _synthesise(duration, dt, seed, climate, emit, threads, rotor_filter)
    return out


def farm_power_year(duration, dt=1.0, seed=1, climate=WindClimate(), threads=2):
    """Farm power [W] in [0, FARM_RATING], float64, length round(duration/dt); sample k holds
    for [k dt, (k+1) dt). Records are synthesised on `threads` threads (numpy releases the
    GIL); the result does not depend on it: use 1 where every core already runs a task."""
    out = np.empty(int(round(duration / dt)))

    turbine = Turbine()
    no_cut_out = replace(turbine, cut_out=np.inf)

    def emit(k0, k1, speeds, mean):
        # Cut-out on the mean wind (a turbine controller's 10-min average), not on each gust.
        out[k0:k1] = power_curve(speeds, no_cut_out).sum(axis=0) * (mean < turbine.cut_out)

    _synthesise(duration, dt, seed, climate, emit, threads)
    return out


def plot(power, dt, path):
    """Monthly (calendar, 365-day years) mean power and the first week, in MW, to a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    months = np.tile([31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31], math.ceil(power.size * dt / DAY / 365) or 1)
    edges = np.concatenate([[0], np.cumsum(months)]) * DAY / dt
    edges = np.unique(np.minimum(edges.astype(np.int64), power.size))
    monthly = np.add.reduceat(power, edges[:-1]) / np.diff(edges)
    week = power[: int(7 * DAY / dt)]
    fig, (a, b) = plt.subplots(2, 1, figsize=(9, 7))
    a.bar(np.arange(monthly.size) + 1, monthly / 1e6)
    a.set(xlabel="month", ylabel="mean farm power [MW]", title=f"{FARM_RATING / 1e6:.0f} MW wind farm")
    b.plot(np.arange(week.size) * dt / DAY, week / 1e6, lw=0.5)
    b.set(xlabel="time [d]", ylabel="farm power [MW]", ylim=(0, FARM_RATING / 1e6 * 1.05))
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main(argv=None):
    parser = cli.CommandLine(description=__doc__)
    parser.add_argument("--days", type=cli.positive(float), default=365.0, help="days [default: 365]")
    parser.add_argument("--seed", type=int, default=1, help="seed [default: 1]")
    parser.add_argument("--dt", type=cli.positive(float), default=1.0, help="time step [s] [default: 1]")
    cli.add_out_option(parser, "out", "wind_year.png")
    args = parser.parse_args(argv)
    if args.days * DAY < 2 * HOUR:
        parser.error(f"--days: {args.days:g} days is shorter than two hours")
    if args.dt > HOUR:
        parser.error(f"--dt: {args.dt:g} s is longer than an hour")
    path = cli.writable_folder(args.out) / "wind_year.png"
    p = farm_power_year(args.days * DAY, args.dt, args.seed)
    plot(p, args.dt, path)
    if args.quiet:
        return
    h = args.dt / HOUR
    print(
        f"{args.days:g} days at {args.dt:g} s, seed {args.seed}: mean {p.mean() / 1e6:.2f} MW "
        f"(capacity factor {p.mean() / FARM_RATING:.3f}), {np.count_nonzero(p == 0) * h:.0f} h at zero, "
        f"{np.count_nonzero(p >= FARM_RATING) * h:.0f} h at rated, "
        f"largest {args.dt:g} s change {np.abs(np.diff(p)).max(initial=0) / 1e6:.2f} MW"
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    cli.run_command(main)
