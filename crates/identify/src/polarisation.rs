//! Polarisation curve at nominal conditions (paper §III-B): V = V0 + R·I by linear least
//! squares on the running samples whose temperature and pressure are within a tolerance of
//! nominal (55 °C and 29 bar, ±0.1 by default).
//!
//! With n points, Sxx = Σ(I − Ī)², s² = Σ(V − V0 − R·I)²/(n − 2):
//!   R = Σ(I − Ī)(V − V̄)/Sxx,  V0 = V̄ − R·Ī,
//!   SE(R) = s/√Sxx,  SE(V0) = s·√(1/n + Ī²/Sxx).

use super::columns::Channel;
use super::dynamics::Estimate;
use super::read::ModuleLog;

/// Which samples count as nominal.
#[derive(Clone, Debug)]
pub struct PolarisationOptions {
    /// Nominal electrolyte temperature [°C].
    pub temperature: f64,
    /// Allowed |T − nominal| [°C].
    pub temperature_tolerance: f64,
    /// Nominal pressure [bar].
    pub pressure: f64,
    /// Allowed |p − nominal| [bar].
    pub pressure_tolerance: f64,
    /// Samples with current above this run [A].
    pub running_current: f64,
}

impl Default for PolarisationOptions {
    fn default() -> Self {
        PolarisationOptions {
            temperature: 55.0,
            temperature_tolerance: 0.1,
            pressure: 29.0,
            pressure_tolerance: 0.1,
            running_current: 1.0,
        }
    }
}

impl PolarisationOptions {
    /// Whether row `r` is at nominal conditions: its temperature and pressure within their
    /// tolerances, where the log has them.
    pub fn is_nominal(
        &self,
        temperature: Option<&[f64]>,
        pressure: Option<&[f64]>,
        r: usize,
    ) -> bool {
        !(temperature.is_some_and(|t| (t[r] - self.temperature).abs() > self.temperature_tolerance)
            || pressure.is_some_and(|p| (p[r] - self.pressure).abs() > self.pressure_tolerance))
    }
}

/// The fitted polarisation curve.
#[derive(Clone, Debug)]
pub struct PolarisationFit {
    /// V0 [V].
    pub voltage_intercept: Estimate,
    /// R [Ω].
    pub ohmic_resistance: Estimate,
    /// RMSE of V [V].
    pub rmse: f64,
    /// Points used.
    pub points: usize,
    /// Running samples with voltage considered.
    pub candidates: usize,
    /// Current range of the points [A].
    pub current_range: (f64, f64),
    /// Filters that could not be applied (a missing column), for the report.
    pub notes: Vec<String>,
}

/// Fits V = V0 + R·I; needs current and voltage.
pub fn fit_polarisation(
    log: &ModuleLog,
    options: &PolarisationOptions,
) -> Result<PolarisationFit, String> {
    if !log.has(Channel::Voltage) {
        return Err("no voltage column".into());
    }
    let mut notes = Vec::new();
    if !log.has(Channel::Temperature) {
        notes.push("no temperature column: samples not filtered on temperature".to_string());
    }
    if !log.has(Channel::Pressure) {
        notes.push("no pressure column: samples not filtered on pressure".to_string());
    }
    // Sums for a numerically stable fit: shift by the first point.
    let (mut n, mut candidates) = (0usize, 0usize);
    let (mut shift_i, mut shift_v) = (f64::NAN, f64::NAN);
    let (mut si, mut sv, mut sii, mut siv, mut svv) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for block in &log.blocks {
        let (Some(current), Some(voltage)) = (
            block.channel(Channel::Current),
            block.channel(Channel::Voltage),
        ) else {
            continue;
        };
        let temperature = block.channel(Channel::Temperature);
        let pressure = block.channel(Channel::Pressure);
        for r in 0..block.len() {
            if current[r] <= options.running_current {
                continue;
            }
            candidates += 1;
            if !options.is_nominal(temperature, pressure, r) {
                continue;
            }
            if n == 0 {
                shift_i = current[r];
                shift_v = voltage[r];
            }
            let (i, v) = (current[r] - shift_i, voltage[r] - shift_v);
            n += 1;
            si += i;
            sv += v;
            sii += i * i;
            siv += i * v;
            svv += v * v;
            lo = lo.min(current[r]);
            hi = hi.max(current[r]);
        }
    }
    if n < 3 {
        return Err(format!("{n} samples at nominal temperature and pressure (of {candidates} running); at least 3 are needed"));
    }
    let nf = n as f64;
    let sxx = sii - si * si / nf;
    if sxx <= 1e-12 * sii.max(1.0) {
        return Err(format!(
            "all {n} nominal samples have the same current; R cannot be fitted"
        ));
    }
    let sxy = siv - si * sv / nf;
    let r = sxy / sxx;
    let mean_i = si / nf;
    let mean_v = sv / nf;
    let v0_shifted = mean_v - r * mean_i;
    let rss = ((svv - sv * sv / nf) - r * sxy).max(0.0);
    let s = (rss / (nf - 2.0)).sqrt();
    let mean_current = mean_i + shift_i;
    let v0 = v0_shifted + shift_v - r * shift_i;
    Ok(PolarisationFit {
        voltage_intercept: Estimate {
            value: v0,
            standard_error: s * (1.0 / nf + mean_current * mean_current / sxx).sqrt(),
        },
        ohmic_resistance: Estimate {
            value: r,
            standard_error: s / sxx.sqrt(),
        },
        rmse: (rss / nf).sqrt(),
        points: n,
        candidates,
        current_range: (lo, hi),
        notes,
    })
}
