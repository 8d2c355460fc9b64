//! The polarisation curve's temperature dependence, from the temperature variation that the
//! nominal fit ([`super::polarisation`]) filters away (the warm-up after a start, water-refill
//! dips): by linear least squares on the running samples within a window around the nominal
//! temperature Tn,
//!
//!   V = V0 + kV·(T − Tn) + (R + kR·(T − Tn))·I,
//!
//! the FMU's `voltageTemperatureCoefficient` kV [V/K] and `resistanceTemperatureCoefficient`
//! kR [Ω/K] (its thermal model). Standard errors from s²·(XᵀX)⁻¹ with s² = RSS/(n − k); 95 %
//! intervals ±1.96 standard errors (n is hundreds to thousands of samples). Where the log does
//! not allow it the stage says why: no temperature column, too few samples in the window, a
//! temperature that hardly varies (kV), or a current that does not vary while it does (kR: the
//! fit then keeps kV alone and says so).

use nalgebra::{DMatrix, DVector};

use super::columns::Channel;
use super::dynamics::Estimate;
use super::read::ModuleLog;

/// Which samples the fit uses and what it needs of them.
#[derive(Clone, Debug)]
pub struct TemperatureOptions {
    /// Tn, the temperature of the nominal curve [°C].
    pub nominal: f64,
    /// Samples within ±window of Tn are used [K]: the linear-in-T model holds within an
    /// operating window, not from a cold start to boiling.
    pub window: f64,
    /// Smallest standard deviation of T over the samples for kV to be identifiable [K].
    pub min_spread: f64,
    /// Samples with current above this run [A].
    pub running_current: f64,
    /// Nominal pressure and its tolerance [bar], applied where the log has a pressure column.
    pub pressure: (f64, f64),
}

impl Default for TemperatureOptions {
    fn default() -> Self {
        TemperatureOptions {
            nominal: 55.0,
            window: 15.0,
            min_spread: 0.5,
            running_current: 1.0,
            pressure: (29.0, 0.1),
        }
    }
}

/// The fitted temperature dependence.
#[derive(Clone, Debug)]
pub struct TemperatureFit {
    /// kV [V/K].
    pub voltage_coefficient: Estimate,
    /// kR [Ω/K]; None where the current did not vary enough with the temperature (the reason
    /// in `notes`).
    pub resistance_coefficient: Option<Estimate>,
    /// V0 at Tn from the same fit [V] (with a current that does not vary: V0 + R·I at it).
    pub voltage_intercept: Estimate,
    /// R at Tn [Ω]; None where the current does not vary.
    pub ohmic_resistance: Option<Estimate>,
    /// RMSE of V [V].
    pub rmse: f64,
    /// Samples used.
    pub points: usize,
    /// Their temperature range [°C] and standard deviation [K].
    pub temperature_range: (f64, f64),
    pub temperature_spread: f64,
    /// Whether the voltage drift was fitted with the temperature terms
    /// ([`crate::drift::fit_temperature_with_drift`]).
    pub drift_terms: bool,
    /// What the fit could not do, for the report.
    pub notes: Vec<String>,
}

/// Largest condition number of the standardised design accepted with kR in it.
const MAX_CONDITION: f64 = 1e6;
/// The 97.5 % normal quantile: 95 % intervals are ±1.96 standard errors.
pub const Z95: f64 = 1.959_963_984_540_054;

/// Fits V = V0 + kV·(T − Tn) + (R + kR·(T − Tn))·I; needs current, voltage and temperature.
pub fn fit_temperature_dependence(
    log: &ModuleLog,
    options: &TemperatureOptions,
) -> Result<TemperatureFit, String> {
    if !log.has(Channel::Voltage) {
        return Err("no voltage column".into());
    }
    if !log.has(Channel::Temperature) {
        return Err("not identifiable from this log: it has no temperature column".into());
    }
    let mut rows: Vec<[f64; 3]> = Vec::new(); // (ΔT, I, V)
    for block in &log.blocks {
        let (Some(current), Some(voltage), Some(temperature)) = (
            block.channel(Channel::Current),
            block.channel(Channel::Voltage),
            block.channel(Channel::Temperature),
        ) else {
            continue;
        };
        let pressure = block.channel(Channel::Pressure);
        for r in 0..block.len() {
            let dt = temperature[r] - options.nominal;
            let (p0, tolerance) = options.pressure;
            if current[r] > options.running_current
                && dt.abs() <= options.window
                && !pressure.is_some_and(|p| (p[r] - p0).abs() > tolerance)
            {
                rows.push([dt, current[r], voltage[r]]);
            }
        }
    }
    let n = rows.len();
    if n < 8 {
        return Err(format!(
            "not identifiable from this log: {n} running samples within ±{} K of {} °C; at least 8 are needed",
            options.window, options.nominal
        ));
    }
    let mean_t = rows.iter().map(|r| r[0]).sum::<f64>() / n as f64;
    let spread =
        (rows.iter().map(|r| (r[0] - mean_t).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
    let (lo, hi) = rows
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
            (lo.min(r[0]), hi.max(r[0]))
        });
    if spread < options.min_spread {
        return Err(format!(
            "not identifiable from this log: the running samples' temperature varies by {:.3} K (standard deviation; at least {} K are needed for kV)",
            spread, options.min_spread
        ));
    }
    let mut notes = Vec::new();
    let mean_i = rows.iter().map(|r| r[1]).sum::<f64>() / n as f64;
    let current_varies = rows
        .iter()
        .any(|r| (r[1] - mean_i).abs() > 1e-9 * mean_i.abs().max(1.0));
    let columns = if !current_varies {
        notes.push(
            "R and kR not identifiable from this log: the current does not vary; kV fitted at that current".to_string(),
        );
        2
    } else {
        4
    };
    let fit = match least_squares(&rows, columns) {
        Ok(fit) => fit,
        Err(condition) if columns == 4 => {
            notes.push(format!(
                "kR not identifiable from this log: the current hardly varies while the temperature does (condition number {condition:.3e}); kV fitted with R constant"
            ));
            least_squares(&rows, 3).map_err(|condition| {
                format!("not identifiable from this log: temperature and current vary together (condition number {condition:.3e})")
            })?
        }
        Err(condition) => {
            return Err(format!(
                "not identifiable from this log: the design is singular (condition number {condition:.3e})"
            ))
        }
    };
    let estimate = |k: usize| Estimate {
        value: fit.theta[k],
        standard_error: fit.standard_errors[k],
    };
    Ok(TemperatureFit {
        voltage_intercept: estimate(0),
        voltage_coefficient: estimate(1),
        ohmic_resistance: (fit.theta.len() >= 3).then(|| estimate(2)),
        resistance_coefficient: (fit.theta.len() == 4).then(|| estimate(3)),
        rmse: (fit.rss / n as f64).sqrt(),
        points: n,
        temperature_range: (lo + options.nominal, hi + options.nominal),
        temperature_spread: spread,
        drift_terms: false,
        notes,
    })
}

struct Solution {
    theta: Vec<f64>,
    standard_errors: Vec<f64>,
    rss: f64,
}

/// Least squares on the first `k` of the columns [1, ΔT, I, ΔT·I], each but the first
/// standardised for the solve; Err(condition number) when the design is too ill-conditioned to
/// separate the coefficients.
fn least_squares(rows: &[[f64; 3]], k: usize) -> Result<Solution, f64> {
    let n = rows.len();
    let column = |r: &[f64; 3], j: usize| match j {
        0 => 1.0,
        1 => r[0],
        2 => r[1],
        _ => r[0] * r[1],
    };
    // Centre and scale columns 1.. (the intercept absorbs the means).
    let mut centre = vec![0.0; k];
    let mut scale = vec![1.0; k];
    for j in 1..k {
        centre[j] = rows.iter().map(|r| column(r, j)).sum::<f64>() / n as f64;
        let ss = rows
            .iter()
            .map(|r| (column(r, j) - centre[j]).powi(2))
            .sum::<f64>();
        scale[j] = (ss / n as f64).sqrt();
        if !(scale[j] > 0.0) {
            return Err(f64::INFINITY);
        }
    }
    let x = DMatrix::from_fn(n, k, |i, j| {
        if j == 0 {
            1.0
        } else {
            (column(&rows[i], j) - centre[j]) / scale[j]
        }
    });
    let y = DVector::from_iterator(n, rows.iter().map(|r| r[2]));
    let svd = x.clone().svd(true, true);
    let (max, min) = svd
        .singular_values
        .iter()
        .fold((0.0f64, f64::INFINITY), |(a, b), s| (a.max(*s), b.min(*s)));
    let condition = max / min;
    if !(condition <= MAX_CONDITION) {
        return Err(condition);
    }
    let beta = svd.solve(&y, 0.0).map_err(|_| condition)?;
    let residuals = &y - &x * &beta;
    let rss = residuals.norm_squared();
    let s2 = rss / (n - k) as f64;
    // Covariance of the standardised coefficients: s²·V·Σ⁻²·Vᵀ.
    let v_t = svd.v_t.as_ref().ok_or(condition)?;
    let inv_s2 = DMatrix::from_diagonal(&svd.singular_values.map(|s| 1.0 / (s * s)));
    let cov = v_t.transpose() * inv_s2 * v_t * s2;
    // Back to the original columns: θj = βj/sj (j ≥ 1), θ0 = β0 − Σ βj·cj/sj.
    let mut transform = DMatrix::<f64>::identity(k, k);
    for j in 1..k {
        transform[(j, j)] = 1.0 / scale[j];
        transform[(0, j)] = -centre[j] / scale[j];
    }
    let theta = &transform * &beta;
    let cov_theta = &transform * cov * transform.transpose();
    Ok(Solution {
        theta: theta.iter().copied().collect(),
        standard_errors: (0..k).map(|j| cov_theta[(j, j)].max(0.0).sqrt()).collect(),
        rss,
    })
}
