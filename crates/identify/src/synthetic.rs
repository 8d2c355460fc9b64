//! Synthetic operating campaigns with known parameters, for tests, benchmarks and examples.
//!
//! One day at 1 Hz: a few minutes off, a start-up (current rises from zero under the model's
//! own rate limit while temperature and pressure come up), random setpoint levels of
//! 120…1800 s on the 60…100 % grid in steps of 5 % (step sizes 5…40 %), a shut-down
//! (setpoint 0, current decays in ~5 s), a few minutes off. The current is the crate's
//! [`Module`] driven by the logged setpoints (row n's setpoint acts from row n − 1 on), so
//! the truth is exactly the model with [`CampaignSpec::truth`]. On top:
//! - Gaussian sensor noise on every measured channel;
//! - temperature dips (water refills: −1…−3 °C, recovering over ~5 min) that raise the
//!   voltage by `temperature_coefficient` per °C, which the nominal-condition filter must
//!   remove; the voltage also rises while the stack is cold after start-up;
//! - rare disturbed steps (a 2…3 A dip decaying over a minute right after a step) that the
//!   outlier removal must catch;
//! - on request ([`CsvOptions::broken`]), broken rows of every kind and one gap, counted in
//!   [`Injected`] so tests can compare with the reader's counts;
//! - on request ([`CampaignSpec::drift`]), the FMU's ageing: a voltage drift that rises per
//!   running hour and per start and builds up over each run, recovering between runs.

use std::fmt::Write as _;

use aem_model::thermal::THERMONEUTRAL_CELL_VOLTAGE;
use aem_model::{CurrentState, Module, ModuleState, ParameterError, Parameters};

/// Seeded SplitMix64 generator with Gaussian draws (Box–Muller).
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform integer in [0, n).
    pub fn below(&mut self, n: usize) -> usize {
        (self.uniform() * n as f64) as usize % n.max(1)
    }

    /// Standard normal draw.
    pub fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// What to generate.
#[derive(Clone, Debug)]
pub struct CampaignSpec {
    /// The true module (the model's parameters).
    pub truth: Parameters,
    /// Seed of everything random.
    pub seed: u64,
    /// Running time per day [h].
    pub running_hours: f64,
    /// Running time of day d [h]: `run_hours[d % len]`, where given (empty: `running_hours`
    /// every day), for runs of several lengths.
    pub run_hours: Vec<f64>,
    /// Unix time of the first day's first row [s]; later days start 24 h apart.
    pub start_time: f64,
    /// Current sensor noise (standard deviation) [A].
    pub current_noise: f64,
    /// Voltage sensor noise [V].
    pub voltage_noise: f64,
    /// Temperature sensor noise [°C].
    pub temperature_noise: f64,
    /// Pressure sensor noise [bar].
    pub pressure_noise: f64,
    /// Hydrogen flow sensor noise [Nl/h].
    pub h2_noise: f64,
    /// Voltage rise per °C below 55 °C [V/°C] (the model's kV is its negative).
    pub temperature_coefficient: f64,
    /// Change of the ohmic resistance per °C above 55 °C, the model's kR [Ω/K].
    pub resistance_temperature_coefficient: f64,
    /// Voltage rise per bar below 29 bar [V/bar].
    pub pressure_coefficient: f64,
    /// Temperature dips per day.
    pub dips_per_day: usize,
    /// Probability that a step is disturbed (an outlier).
    pub disturbed_fraction: f64,
    /// The stack temperature from a heat balance instead of the scripted warm-up and dips,
    /// with an ambient-temperature column (None: the scripted temperature, no such column).
    pub thermal: Option<SyntheticThermal>,
    /// The voltage's drift with use (None: no drift).
    pub drift: Option<SyntheticDrift>,
}

/// The FMU's ageing (`crate`-independent copy of its equations, as the campaign's truth): d =
/// d_irr + d_rev, d_irr rising by `per_running_hour` per hour run and `per_start` per start,
/// τb·d(d_rev)/dt = A − d_rev while running, τr·d(d_rev)/dt = −d_rev otherwise; the campaign
/// starts rested with no drift. A row runs when its setpoint is above 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SyntheticDrift {
    /// A [V].
    pub amplitude: f64,
    /// τb [s].
    pub build_up_time: f64,
    /// τr [s].
    pub recovery_time: f64,
    /// ρ [V/h].
    pub per_running_hour: f64,
    /// δs [V].
    pub per_start: f64,
}

impl Default for SyntheticDrift {
    /// 0.4 V building up in 2 h and recovering in 8 h, 2 mV per running hour, 5 mV per start.
    fn default() -> Self {
        SyntheticDrift {
            amplitude: 0.4,
            build_up_time: 7_200.0,
            recovery_time: 28_800.0,
            per_running_hour: 2e-3,
            per_start: 5e-3,
        }
    }
}

/// A drift's state: (d_irr, d_rev) [V].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct DriftState(f64, f64);

impl SyntheticDrift {
    /// The state after `length` [s] running (`start`: the interval begins with a start).
    fn run(&self, d: DriftState, length: f64, start: bool) -> DriftState {
        let started = if start { self.per_start } else { 0.0 };
        DriftState(
            d.0 + started + self.per_running_hour * length / 3600.0,
            self.amplitude + (d.1 - self.amplitude) * (-length / self.build_up_time).exp(),
        )
    }

    /// The state after `length` [s] at rest.
    fn rest(&self, d: DriftState, length: f64) -> DriftState {
        DriftState(d.0, d.1 * (-length / self.recovery_time).exp())
    }
}

/// A stack whose temperature follows C·dT/dt = (V − n·1.481 V)·I − (T − Ta)/Rth − Qc, a
/// thermostat holding 55 °C with cooling to spare; the ambient swings daily.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SyntheticThermal {
    /// C [J/K].
    pub heat_capacity: f64,
    /// Rth [K/W].
    pub thermal_resistance: f64,
    /// Cells n [1].
    pub cells: u32,
    /// Mean ambient temperature [°C] and its daily swing (amplitude) [K].
    pub ambient: f64,
    pub ambient_swing: f64,
    /// Ambient sensor noise [°C].
    pub ambient_noise: f64,
}

impl Default for SyntheticThermal {
    /// The FMU's assumed stack (C = 25 kJ/K, Rth = 0.2 K/W, 23 cells) in 5 °C ± 3 K air.
    fn default() -> Self {
        SyntheticThermal {
            heat_capacity: 25_000.0,
            thermal_resistance: 0.2,
            cells: 23,
            ambient: 5.0,
            ambient_swing: 3.0,
            ambient_noise: 0.05,
        }
    }
}

impl CampaignSpec {
    /// The running time of day `index` [s] (whole seconds).
    pub fn running_seconds(&self, index: usize) -> usize {
        let hours = match self.run_hours.len() {
            0 => self.running_hours,
            n => self.run_hours[index % n],
        };
        (hours * 3600.0) as usize
    }

    /// Known parameters clearly different from the paper's Table I.
    pub fn test_truth() -> Parameters {
        Parameters {
            gain: 0.512,
            tau_zero: 80.0,
            tau_pole1: 2.6,
            tau_pole2: 102.0,
            ramp_up_limit: 0.18,
            voltage_intercept: 36.4,
            ohmic_resistance: 0.1412,
            h2_coefficient: 9.41,
            nominal_current: 51.2,
            min_setpoint: 60.0,
            max_setpoint: 100.0,
        }
    }
}

impl Default for CampaignSpec {
    /// [`CampaignSpec::test_truth`], 8⅓ h a day (30 000 rows at 1 Hz), noise of 0.15 A,
    /// 0.1 V, 0.02 °C, 0.02 bar and 1 Nl/h, four dips a day, 1 % of the steps disturbed.
    fn default() -> Self {
        CampaignSpec {
            truth: CampaignSpec::test_truth(),
            seed: 2026,
            running_hours: 30_000.0 / 3600.0 - 600.0 / 3600.0,
            run_hours: Vec::new(),
            // 2025-10-06T06:00:00Z
            start_time: 1_759_730_400.0,
            current_noise: 0.15,
            voltage_noise: 0.1,
            temperature_noise: 0.02,
            pressure_noise: 0.02,
            h2_noise: 1.0,
            temperature_coefficient: 0.08,
            resistance_temperature_coefficient: 0.0,
            pressure_coefficient: 0.05,
            dips_per_day: 4,
            disturbed_fraction: 0.01,
            thermal: None,
            drift: None,
        }
    }
}

/// One day of samples, as a logger would record them (noise included).
#[derive(Clone, Debug, Default)]
pub struct Day {
    /// Unix time [s].
    pub time: Vec<f64>,
    /// Setpoint [%].
    pub setpoint: Vec<f64>,
    /// Current [A].
    pub current: Vec<f64>,
    /// Voltage [V].
    pub voltage: Vec<f64>,
    /// Temperature [°C].
    pub temperature: Vec<f64>,
    /// Pressure [bar].
    pub pressure: Vec<f64>,
    /// Hydrogen flow [Nl/h].
    pub h2_flow: Vec<f64>,
    /// Ambient temperature [°C] (empty without [`CampaignSpec::thermal`]).
    pub ambient: Vec<f64>,
    /// Setpoint steps made while running (start-ups and shut-downs excluded).
    pub steps: usize,
    /// Steps that were disturbed.
    pub disturbed: usize,
}

impl Day {
    /// Rows.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// True without rows.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }
}

const OFF_SECONDS: usize = 300;
const LEVEL_SECONDS: [usize; 9] = [120, 200, 300, 350, 400, 600, 900, 1200, 1800];

/// Day number `index` of the campaign (deterministic in the seed and the index).
pub fn generate_day(spec: &CampaignSpec, index: usize) -> Result<Day, ParameterError> {
    spec.truth.validate()?;
    let mut rng = Rng::new(spec.seed ^ (index as u64 + 1).wrapping_mul(0xD1B5_4A32_D192_ED03));
    let t0 = spec.start_time + 86_400.0 * index as f64;
    let p = spec.truth;
    // Setpoint schedule: (rows, setpoint) levels.
    let mut schedule: Vec<(usize, f64)> = vec![(OFF_SECONDS, 0.0)];
    let running = spec.running_seconds(index);
    let grid: Vec<f64> = (0..=8).map(|i| 60.0 + 5.0 * f64::from(i)).collect();
    let mut total = 0;
    let mut level = grid[rng.below(grid.len())];
    // The first level lasts through the start-up.
    let mut first = true;
    while total < running {
        let rows = if first {
            1200
        } else {
            LEVEL_SECONDS[rng.below(LEVEL_SECONDS.len())]
        }
        .min(running - total);
        schedule.push((rows, level));
        total += rows;
        first = false;
        let mut next = level;
        while next == level {
            next = grid[rng.below(grid.len())];
        }
        level = next;
    }
    schedule.push((OFF_SECONDS, 0.0));
    let rows: usize = schedule.iter().map(|(n, _)| n).sum();

    // Temperature dips: start row and depth, during running after the warm-up.
    let dips: Vec<(usize, f64)> = (0..spec.dips_per_day)
        .map(|_| {
            (
                OFF_SECONDS + 2400 + rng.below(running.saturating_sub(3000).max(1)),
                1.0 + 2.0 * rng.uniform(),
            )
        })
        .collect();

    // The drift at the day's first row: from each earlier day's first row, OFF_SECONDS − 1 s
    // at rest, `running` s running (beginning with a start), and at rest until the next day's
    // first row (row by row below, the same intervals).
    let before = (OFF_SECONDS - 1) as f64;
    let mut drift = DriftState::default();
    if let Some(dr) = &spec.drift {
        for earlier in 0..index {
            let running = spec.running_seconds(earlier) as f64;
            drift = dr.rest(drift, before);
            drift = dr.run(drift, running, true);
            drift = dr.rest(drift, 86_400.0 - before - running);
        }
    }
    let mut day = Day::default();
    let mut module: Option<Module> = None;
    let mut off_current = 0.0;
    let mut run_start = 0usize;
    let mut disturbance: Option<(usize, f64)> = None;
    let mut previous_setpoint = 0.0;
    let mut row = 0usize;
    let ambient_at = |t: f64, th: &SyntheticThermal| {
        th.ambient + th.ambient_swing * (2.0 * std::f64::consts::PI * t / 86_400.0).sin()
    };
    // The stack starts the day at the ambient temperature.
    let mut stack = spec.thermal.map(|th| ambient_at(t0, &th));
    for (n, u) in schedule {
        for _ in 0..n {
            let t = t0 + row as f64;
            let running = u > 0.0;
            let current = if running {
                if module.is_none() {
                    run_start = row;
                    // A cold, stopped stack: every state at zero, then the model takes over.
                    let mut m = Module::new(p, u)?;
                    let zero = CurrentState {
                        z1: 0.0,
                        z2: 0.0,
                        current: 0.0,
                    };
                    m.restore(ModuleState {
                        time: 0.0,
                        current: zero,
                        energy: 0.0,
                        h2_produced: 0.0,
                        ..*m.state()
                    });
                    module = Some(m);
                }
                let Some(m) = module.as_mut() else { continue };
                if previous_setpoint > 0.0 && u != previous_setpoint {
                    day.steps += 1;
                    if rng.uniform() < spec.disturbed_fraction {
                        disturbance = Some((row, 2.0 + rng.uniform()));
                        day.disturbed += 1;
                    }
                }
                // Row n's setpoint acts over (t[n−1], t[n]].
                let _ = m.step(u, 1.0);
                off_current = m.current();
                m.current()
            } else {
                module = None;
                off_current *= (-1.0f64 / 5.0).exp();
                off_current
            };
            let extra = disturbance.map_or(0.0, |(start, depth)| {
                let age = (row - start) as f64;
                -depth * (-age / 60.0).exp() * f64::from(u8::from(age < 400.0))
            });
            let since_start = (row - run_start) as f64;
            // Temperature: warm-up from 45 °C over ~7 min when running, dips, cooling when off;
            // or the heat balance's.
            let mut temperature = if let Some(t) = stack {
                t
            } else if running {
                55.0 - 10.0 * (-since_start / 400.0).exp()
            } else {
                45.0
            };
            for &(start, depth) in &dips {
                if row >= start && running && stack.is_none() {
                    let age = (row - start) as f64;
                    let shape = if age < 60.0 {
                        age / 60.0
                    } else {
                        (-(age - 60.0) / 300.0).exp()
                    };
                    temperature -= depth * shape;
                }
            }
            let pressure = if running {
                29.0 * (since_start / 300.0).min(1.0)
            } else {
                0.0
            };
            let i_true = current + extra;
            if let Some(dr) = &spec.drift {
                // Row n's interval (t[n−1], t[n]]: running if its setpoint is, the first one a start.
                drift = if row == 0 {
                    drift
                } else if running {
                    dr.run(drift, 1.0, previous_setpoint == 0.0)
                } else {
                    dr.rest(drift, 1.0)
                };
            }
            let voltage = if running || off_current > 0.5 {
                p.voltage_intercept
                    + p.ohmic_resistance * i_true
                    + spec.temperature_coefficient * (55.0 - temperature)
                    + spec.resistance_temperature_coefficient * (temperature - 55.0) * i_true
                    + spec.pressure_coefficient * (29.0 - pressure)
                    + drift.0
                    + drift.1
            } else {
                0.0
            };
            if let (Some(t_stack), Some(th)) = (stack.as_mut(), spec.thermal.as_ref()) {
                // One second of C·dT/dt = heat − (T − Ta)/Rth at this row's heat, exactly; the
                // thermostat holds 55 °C against any surplus.
                let ta = ambient_at(t, th);
                let heat = if running && i_true > 0.0 {
                    (voltage - f64::from(th.cells) * THERMONEUTRAL_CELL_VOLTAGE) * i_true
                } else {
                    0.0
                };
                let settles = ta + th.thermal_resistance * heat;
                let decay = (-1.0 / (th.thermal_resistance * th.heat_capacity)).exp();
                let next = settles + (*t_stack - settles) * decay;
                *t_stack = if next > 55.0 { 55.0 } else { next };
                day.ambient.push(ta + th.ambient_noise * rng.normal());
            }
            day.time.push(t);
            day.setpoint.push(u);
            day.current.push(i_true + spec.current_noise * rng.normal());
            day.voltage
                .push(voltage + spec.voltage_noise * rng.normal());
            day.temperature
                .push(temperature + spec.temperature_noise * rng.normal());
            day.pressure
                .push(pressure + spec.pressure_noise * rng.normal());
            day.h2_flow
                .push(p.h2_coefficient * i_true.max(0.0) + spec.h2_noise * rng.normal());
            previous_setpoint = u;
            row += 1;
        }
    }
    debug_assert_eq!(row, rows);
    Ok(day)
}

/// Days `0..days` of the campaign.
pub fn generate_campaign(spec: &CampaignSpec, days: usize) -> Result<Vec<Day>, ParameterError> {
    (0..days).map(|d| generate_day(spec, d)).collect()
}

/// How to write a day as CSV.
#[derive(Clone, Debug)]
pub struct CsvOptions {
    /// Column names of time, setpoint, current, voltage, temperature, pressure, h2_flow.
    pub names: [String; 7],
    /// Leave out these columns (by default name, e.g. "h2_flow").
    pub omit: Vec<String>,
    /// Write time as RFC 3339 (UTC, whole seconds) instead of seconds.
    pub rfc3339: bool,
    /// Add a module column with this (name, value).
    pub module: Option<(String, String)>,
    /// Inject broken rows of every kind and one gap.
    pub broken: bool,
    /// Seed of the injection places.
    pub seed: u64,
}

impl Default for CsvOptions {
    fn default() -> Self {
        CsvOptions {
            names: [
                "time",
                "setpoint",
                "current",
                "voltage",
                "temperature",
                "pressure",
                "h2_flow",
            ]
            .map(String::from),
            omit: Vec::new(),
            rfc3339: false,
            module: None,
            broken: false,
            seed: 1,
        }
    }
}

/// Broken rows written, by [`super::read::BadRow`] order (empty, nan, text, short,
/// duplicate, backwards), gaps, and the rows written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Injected {
    /// Rows per bad-row reason.
    pub bad: [u64; 6],
    /// Gaps (30 s of rows removed).
    pub gaps: u64,
    /// Data rows written (header excluded).
    pub rows: u64,
}

/// The day as CSV text (header first).
pub fn to_csv(day: &Day, options: &CsvOptions) -> (String, Injected) {
    let keep: Vec<bool> = [
        "time",
        "setpoint",
        "current",
        "voltage",
        "temperature",
        "pressure",
        "h2_flow",
    ]
    .iter()
    .map(|k| !options.omit.iter().any(|o| o == k))
    .collect();
    let mut header: Vec<&str> = options
        .names
        .iter()
        .zip(&keep)
        .filter(|(_, k)| **k)
        .map(|(n, _)| n.as_str())
        .collect();
    let ambient =
        !day.ambient.is_empty() && !options.omit.iter().any(|o| o == "ambient_temperature");
    if ambient {
        header.push("ambient_temperature");
    }
    if let Some((name, _)) = &options.module {
        header.push(name);
    }
    let mut out = String::with_capacity(day.len() * 64);
    out.push_str(&header.join(","));
    out.push('\n');
    let n = day.len();
    // Injection places: distinct rows well inside the day, 40 rows apart at least.
    let mut rng = Rng::new(options.seed);
    let mut places: Vec<usize> = Vec::new();
    let kinds = 6 * 2 + 1;
    if options.broken && n > 5000 {
        while places.len() < kinds {
            let r = 1000 + rng.below(n - 2000);
            if places.iter().all(|&q| q.abs_diff(r) > 40) {
                places.push(r);
            }
        }
    }
    let action = |row: usize| places.iter().position(|&q| q == row);
    let mut injected = Injected::default();
    let mut skip_until = 0usize;
    let mut fields: Vec<String> = Vec::with_capacity(8);
    for r in 0..n {
        if r < skip_until {
            continue;
        }
        format_row(day, r, options, &keep, &mut fields);
        match action(r) {
            // Two of each bad-row kind, then one gap.
            Some(a) if a < 12 => {
                let kind = a / 2;
                injected.bad[kind] += 1;
                // Field 2 is the current (always written).
                match kind {
                    0 => fields[2].clear(),
                    1 => {
                        fields[2] = if a % 2 == 0 {
                            "nan".into()
                        } else {
                            "NaN".into()
                        }
                    }
                    2 => {
                        fields[1] = if a % 2 == 0 {
                            "n/a".into()
                        } else {
                            "ERR#3".into()
                        }
                    }
                    3 => fields.truncate(2),
                    4 => {
                        // The good row, then the same timestamp again.
                        push_line(&mut out, &fields);
                        injected.rows += 1;
                    }
                    _ => {
                        // The good row, then a repeat of a row 5 s earlier.
                        push_line(&mut out, &fields);
                        injected.rows += 1;
                        format_row(day, r - 5, options, &keep, &mut fields);
                    }
                }
            }
            Some(_) => {
                injected.gaps += 1;
                skip_until = r + 30;
                continue;
            }
            None => {}
        }
        push_line(&mut out, &fields);
        injected.rows += 1;
    }
    (out, injected)
}

fn push_line(out: &mut String, fields: &[String]) {
    out.push_str(&fields.join(","));
    out.push('\n');
}

fn format_row(day: &Day, r: usize, options: &CsvOptions, keep: &[bool], fields: &mut Vec<String>) {
    fields.clear();
    let time = if options.rfc3339 {
        chrono::DateTime::from_timestamp(day.time[r].floor() as i64, 0).map_or_else(
            || format!("{}", day.time[r]),
            |d| d.to_rfc3339_opts(chrono::SecondsFormat::Secs, true),
        )
    } else {
        format!("{}", day.time[r])
    };
    let values = [
        day.setpoint[r],
        day.current[r],
        day.voltage[r],
        day.temperature[r],
        day.pressure[r],
        day.h2_flow[r],
    ];
    let mut all = vec![time];
    all.extend(values.iter().enumerate().map(|(i, v)| {
        if i == 0 {
            format!("{v}")
        } else {
            format!("{v:.4}")
        }
    }));
    for (f, k) in all.into_iter().zip(keep) {
        if *k {
            fields.push(f);
        }
    }
    if !day.ambient.is_empty() && !options.omit.iter().any(|o| o == "ambient_temperature") {
        fields.push(format!("{:.4}", day.ambient[r]));
    }
    if let Some((_, value)) = &options.module {
        fields.push(value.clone());
    }
}

/// Writes a campaign as daily CSV files `day01.csv`… into `dir`; returns the files and what
/// was injected in each.
pub fn write_campaign(
    dir: &std::path::Path,
    days: &[Day],
    options: &CsvOptions,
) -> std::io::Result<Vec<(std::path::PathBuf, Injected)>> {
    std::fs::create_dir_all(dir)?;
    let mut out = Vec::new();
    for (i, day) in days.iter().enumerate() {
        let path = dir.join(format!("day{:02}.csv", i + 1));
        let mut o = options.clone();
        o.seed = options.seed.wrapping_add(i as u64);
        let (text, injected) = to_csv(day, &o);
        std::fs::write(&path, text)?;
        out.push((path, injected));
    }
    Ok(out)
}

/// Describes a day for messages.
pub fn describe(day: &Day) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "{} rows, {} steps ({} disturbed)",
        day.len(),
        day.steps,
        day.disturbed
    );
    s
}
