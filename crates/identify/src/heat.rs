//! The stack's heat capacity C and thermal resistance to ambient Rth (the FMU's
//! `heatCapacity` and `thermalResistance`), from the stretches of the log below the
//! thermostat's setpoint (the warm-up after a start, the cool-down after a stop), where
//!
//!   C·dT/dt = (V − n·1.481 V)·I − (T − Ta)/Rth.
//!
//! Integrated over windows of consecutive samples (trapezoids), ΔT = β1·∫heat dt − β2·∫(T − Ta) dt
//! with β1 = 1/C and β2 = 1/(Rth·C): linear least squares without intercept; C = 1/β1 and
//! Rth = β1/β2 with standard errors by the delta method from s²·(XᵀX)⁻¹. Needs current, voltage,
//! temperature and an ambient-temperature column; the report says which is missing, or that
//! the log has too few windows below the setpoint, or no heat in them (a log of cool-downs
//! alone gives Rth·C, not C).

use aem_model::thermal::THERMONEUTRAL_CELL_VOLTAGE;
use nalgebra::{Matrix2, Vector2};

use super::columns::Channel;
use super::dynamics::Estimate;
use super::read::ModuleLog;

/// Which stretches the fit uses.
#[derive(Clone, Debug)]
pub struct HeatOptions {
    /// The thermostat's setpoint [°C] (the nominal temperature).
    pub setpoint: f64,
    /// Windows whose temperatures all lie this far below the setpoint are used [K].
    pub margin: f64,
    /// Samples per window.
    pub window: usize,
    /// Cells in series (the heat is (V − n·1.481 V)·I).
    pub cells: u32,
    /// Samples with current above this run [A] (others carry no heat).
    pub running_current: f64,
}

impl Default for HeatOptions {
    fn default() -> Self {
        HeatOptions {
            setpoint: 55.0,
            margin: 1.0,
            window: 60,
            cells: 23,
            running_current: 1.0,
        }
    }
}

/// The fitted heat balance.
#[derive(Clone, Debug)]
pub struct HeatFit {
    /// C [J/K].
    pub heat_capacity: Estimate,
    /// Rth [K/W].
    pub thermal_resistance: Estimate,
    /// Windows used, of them with heat (running), and the RMSE of ΔT over a window [K].
    pub windows: usize,
    pub heated: usize,
    pub rmse: f64,
}

/// Fewest windows for a fit.
const MIN_WINDOWS: usize = 20;

/// Fits C and Rth; see the module documentation.
pub fn fit_heat_balance(log: &ModuleLog, options: &HeatOptions) -> Result<HeatFit, String> {
    for (channel, what) in [
        (Channel::Voltage, "voltage"),
        (Channel::Temperature, "temperature"),
        (Channel::Ambient, "ambient_temperature"),
    ] {
        if !log.has(channel) {
            return Err(format!(
                "not identifiable from this log: it has no {what} column"
            ));
        }
    }
    let limit = options.setpoint - options.margin;
    let thermoneutral = f64::from(options.cells) * THERMONEUTRAL_CELL_VOLTAGE;
    let (mut xtx, mut xty, mut yy) = (Matrix2::zeros(), Vector2::zeros(), 0.0);
    let (mut windows, mut heated) = (0usize, 0usize);
    let w = options.window.max(2);
    for block in &log.blocks {
        let (Some(current), Some(voltage), Some(temperature), Some(ambient)) = (
            block.channel(Channel::Current),
            block.channel(Channel::Voltage),
            block.channel(Channel::Temperature),
            block.channel(Channel::Ambient),
        ) else {
            continue;
        };
        let time = &block.time;
        let heat = |r: usize| {
            if current[r] > options.running_current {
                (voltage[r] - thermoneutral) * current[r]
            } else {
                0.0
            }
        };
        let mut start = 0;
        while start + w <= block.len() {
            let rows = start..start + w;
            if rows.clone().any(|r| !(temperature[r] < limit)) {
                start += 1;
                continue;
            }
            let (mut h, mut l) = (0.0, 0.0);
            for r in start..start + w - 1 {
                let dt = time[r + 1] - time[r];
                h += 0.5 * dt * (heat(r) + heat(r + 1));
                l += 0.5
                    * dt
                    * ((temperature[r] - ambient[r]) + (temperature[r + 1] - ambient[r + 1]));
            }
            let dtemp = temperature[start + w - 1] - temperature[start];
            let x = Vector2::new(h, -l);
            xtx += x * x.transpose();
            xty += x * dtemp;
            yy += dtemp * dtemp;
            windows += 1;
            heated += usize::from(h > 0.0);
            start += w - 1;
        }
    }
    if windows < MIN_WINDOWS {
        return Err(format!(
            "not identifiable from this log: {windows} windows of {w} samples at least {} K below the {} °C setpoint; at least {MIN_WINDOWS} are needed (a warm-up or a cool-down)",
            options.margin, options.setpoint
        ));
    }
    if heated < MIN_WINDOWS / 2 {
        return Err(format!(
            "heat capacity not identifiable from this log: only {heated} of the {windows} windows below the setpoint carry heat (a warm-up after a start is needed; cool-downs give Rth·C alone)"
        ));
    }
    let inverse = xtx
        .try_inverse()
        .ok_or("not identifiable from this log: the heat and the loss to ambient vary together")?;
    let beta = inverse * xty;
    let rss = (yy - beta.dot(&xty)).max(0.0);
    let s2 = rss / (windows - 2) as f64;
    let cov = inverse * s2;
    let (b1, b2) = (beta[0], beta[1]);
    if !(b1 > 0.0 && b2 > 0.0) {
        return Err(format!(
            "not identifiable from this log: the fit gives 1/C = {b1:.3e} and 1/(Rth·C) = {b2:.3e}, not both positive"
        ));
    }
    // C = 1/β1: ∂C/∂β1 = −1/β1². Rth = β1/β2: ∇ = (1/β2, −β1/β2²).
    let se_c = cov[(0, 0)].max(0.0).sqrt() / (b1 * b1);
    let g = Vector2::new(1.0 / b2, -b1 / (b2 * b2));
    let se_r = (g.transpose() * cov * g)[(0, 0)].max(0.0).sqrt();
    Ok(HeatFit {
        heat_capacity: Estimate {
            value: 1.0 / b1,
            standard_error: se_c,
        },
        thermal_resistance: Estimate {
            value: b1 / b2,
            standard_error: se_r,
        },
        windows,
        heated,
        rmse: (rss / windows as f64).sqrt(),
    })
}
