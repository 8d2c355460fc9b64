//! Identification of the model's parameters from a user's operational data (the paper's §III),
//! as a library and the `aem-identify` command (`main.rs`).
//!
//! Dependencies: this crate uses the model crate `aem-model` only, never the FMU; every
//! simulated response comes from [`aem_model::Module`], the code the FMU steps, and the result
//! is the model's [`aem_model::parameter_file`], which the FMU reads.
//!
//! Pipeline per module ([`fit_module`]):
//! 1. [`read`]: CSV files into gap-free blocks, bad rows skipped and counted (separator and
//!    decimal mark given or detected: [`dialect`]);
//! 2. [`segments`]: running segments, setpoint steps during steady running;
//! 3. [`polarisation`]: V = V0 + R·I at nominal temperature and pressure;
//! 4. [`dynamics`]: K, τz, τp1, τp2 from the negative steps, then the ramp limit r from the
//!    positive steps, outliers removed, uncertainties from the Jacobian;
//! 5. [`structure`]: first- and third-order candidates beside the second order (RMSE, AICc);
//! 6. [`hydrogen`]: flow = c·I and the Faraday efficiency for the cell count;
//! 7. [`temperature`]: the curve's temperature coefficients kV, kR from the temperature
//!    variation around the nominal temperature (for the FMU's thermal model);
//! 8. [`heat`]: the stack's heat capacity and thermal resistance from its warm-ups and
//!    cool-downs below the setpoint (with an ambient-temperature column);
//! 9. [`drift`]: the voltage's drift with use (the FMU's ageing) from the voltage against
//!    consecutive runtime, running hours and starts.
//!
//! [`parameter_file`] gathers the fits under the FMU's parameter names and units with the
//! statistics, [`report`] writes the Table-I-like text, [`validate`] compares a held-out day with the identified model, and
//! [`synthetic`] generates campaigns with known parameters.

#![deny(unsafe_op_in_unsafe_fn)]
// `!(x > 0.0)` is used on purpose: it is true for NaN, which must be refused too.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod columns;
pub mod dialect;
pub mod drift;
pub mod dynamics;
pub mod error;
pub mod heat;
pub mod hydrogen;
pub mod lsq;
pub mod modal;
pub mod polarisation;
pub mod read;
pub mod report;
pub mod segments;
pub mod stats;
pub mod structure;
pub mod synthetic;
pub mod temperature;
pub mod validate;

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use aem_model::parameter_file::{ModuleEntry, ParameterEntry, ParameterFile, Source, Spread};
use aem_model::{ModuleParameter, Parameters};

pub use error::{Error, Result};

use drift::DriftFit;
use dynamics::{DynamicsFit, DynamicsOptions, Estimate};
use heat::{HeatFit, HeatOptions};
use hydrogen::HydrogenFit;
use polarisation::{PolarisationFit, PolarisationOptions};
use read::{BadRowCounts, ModuleLog};
use segments::StepOptions;
use structure::StructureCheck;
use temperature::{TemperatureFit, TemperatureOptions};

/// Settings of the whole identification.
#[derive(Clone, Debug)]
pub struct FitOptions {
    /// Segmentation and step selection.
    pub steps: StepOptions,
    /// Nominal-condition filter of the polarisation fit.
    pub polarisation: PolarisationOptions,
    /// Dynamics fit.
    pub dynamics: DynamicsOptions,
    /// Temperature dependence of the curve.
    pub temperature: TemperatureOptions,
    /// Heat balance.
    pub heat: HeatOptions,
    /// Cells in the stack, for the Faraday efficiency.
    pub cells: u32,
    /// A parameter whose relative standard error exceeds this is flagged [-].
    pub poorly_determined: f64,
    /// Parameters not identified from data (nominalCurrent, the setpoint window) and the
    /// fallback for any step that cannot run.
    pub base: Parameters,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            steps: StepOptions::default(),
            polarisation: PolarisationOptions::default(),
            dynamics: DynamicsOptions::default(),
            temperature: TemperatureOptions::default(),
            heat: HeatOptions::default(),
            cells: 23,
            poorly_determined: 0.05,
            base: Parameters::default(),
        }
    }
}

/// A pipeline step's result, or why it did not run.
#[derive(Clone, Debug)]
pub enum Stage<T> {
    /// The step ran.
    Done(T),
    /// It did not: a missing column, too little data, or a failed fit.
    Skipped(String),
}

impl<T> Stage<T> {
    /// The result, if the step ran.
    pub fn done(&self) -> Option<&T> {
        match self {
            Stage::Done(t) => Some(t),
            Stage::Skipped(_) => None,
        }
    }
}

impl<T> From<std::result::Result<T, String>> for Stage<T> {
    fn from(r: std::result::Result<T, String>) -> Self {
        match r {
            Ok(t) => Stage::Done(t),
            Err(e) => Stage::Skipped(e),
        }
    }
}

/// What was read for a module.
#[derive(Clone, Debug)]
pub struct LogSummary {
    /// Module id.
    pub id: String,
    /// Files.
    pub files: usize,
    /// The separators and decimal marks the files were read with.
    pub dialects: Vec<read::Dialect>,
    /// Data rows read.
    pub rows_read: u64,
    /// Rows used.
    pub rows_used: u64,
    /// Skipped rows and gaps.
    pub bad: BadRowCounts,
}

/// Step counts of a module's data.
#[derive(Clone, Debug, Default)]
pub struct StepSummary {
    /// Running segments.
    pub segments: usize,
    /// Setpoint changes while running.
    pub changes: usize,
    /// Steps qualifying for the fit.
    pub qualified: usize,
    /// Left out: within the settle time after a start-up or gap.
    pub after_start: usize,
    /// Left out: from or to outside the operating window (shut-downs).
    pub outside_window: usize,
    /// Left out: too small.
    pub too_small: usize,
    /// Left out: preceding level shorter than the pre-step window.
    pub short_level: usize,
    /// Left out: response shorter than the minimum.
    pub short_response: usize,
}

/// Everything identified for one module.
#[derive(Clone, Debug)]
pub struct ModuleFit {
    /// What was read.
    pub log: LogSummary,
    /// Steps found.
    pub steps: StepSummary,
    /// Polarisation curve.
    pub polarisation: Stage<PolarisationFit>,
    /// Current dynamics.
    pub dynamics: Stage<DynamicsFit>,
    /// Structure check.
    pub structure: Stage<StructureCheck>,
    /// Hydrogen coefficient.
    pub hydrogen: Stage<HydrogenFit>,
    /// The curve's temperature coefficients (for the thermal model; not part of the
    /// parameter file's module sets).
    pub temperature: Stage<TemperatureFit>,
    /// The stack's heat capacity and thermal resistance (for the thermal model, likewise).
    pub heat: Stage<HeatFit>,
    /// The voltage's drift with use (for the FMU's ageing, likewise).
    pub drift: Stage<DriftFit>,
    /// The resulting parameter set (identified values over the base set).
    pub parameters: Parameters,
    /// Which parameters were identified, with their estimates.
    pub estimates: BTreeMap<&'static str, Estimate>,
    /// Wall time per stage.
    pub timings: Vec<(&'static str, Duration)>,
    /// Relative-error threshold used for the flags.
    pub poorly_determined: f64,
}

impl ModuleFit {
    /// True if `name`'s estimate is missing, not finite, or its relative standard error
    /// exceeds the threshold.
    pub fn is_poorly_determined(&self, name: &str) -> bool {
        match self.estimates.get(name) {
            None => true,
            Some(e) => {
                let relative = e.relative_error();
                relative.is_nan() || relative > self.poorly_determined
            }
        }
    }
}

/// Runs the whole identification for one module.
pub fn fit_module(log: &ModuleLog, options: &FitOptions) -> ModuleFit {
    let mut timings = Vec::new();
    let mut clock = Instant::now();
    let mut lap = |name: &'static str, timings: &mut Vec<(&'static str, Duration)>| {
        let now = Instant::now();
        timings.push((name, now - clock));
        clock = now;
    };
    let base = options.base;
    let mut step_options = options.steps.clone();
    step_options.setpoint_window = (base.min_setpoint, base.max_setpoint);
    let segments = segments::running_segments(log, &step_options);
    let set = segments::find_steps(segments, &step_options);
    let steps = StepSummary {
        segments: set.segments.len(),
        changes: set.changes,
        qualified: set.steps.len(),
        after_start: set.after_start,
        outside_window: set.outside_window,
        too_small: set.too_small,
        short_level: set.short_level,
        short_response: set.short_response,
    };
    lap("segments and steps", &mut timings);

    let polarisation: Stage<PolarisationFit> =
        polarisation::fit_polarisation(log, &options.polarisation).into();
    lap("polarisation", &mut timings);

    let has_setpoint = log.has(columns::Channel::Setpoint);
    let dynamics: Stage<DynamicsFit> = if has_setpoint {
        dynamics::fit_dynamics(&set, base, &options.dynamics).into()
    } else {
        Stage::Skipped("no setpoint column".into())
    };
    lap("current dynamics", &mut timings);

    let structure = match &dynamics {
        Stage::Done(d) => Stage::Done(structure::check_structure(&set, d, &base)),
        Stage::Skipped(_) => Stage::Skipped("needs the dynamics fit".into()),
    };
    lap("structure check", &mut timings);

    let hydrogen: Stage<HydrogenFit> =
        hydrogen::fit_hydrogen(log, options.polarisation.running_current, options.cells).into();
    lap("hydrogen", &mut timings);

    let heat: Stage<HeatFit> = heat::fit_heat_balance(log, &options.heat).into();
    lap("heat balance", &mut timings);

    let (temperature, drift) = fit_temperature_and_drift(log, options);
    lap("temperature dependence and voltage drift", &mut timings);

    let mut parameters = base;
    let mut estimates = BTreeMap::new();
    if let Stage::Done(p) = &polarisation {
        parameters.voltage_intercept = p.voltage_intercept.value;
        parameters.ohmic_resistance = p.ohmic_resistance.value;
        estimates.insert("voltageIntercept", p.voltage_intercept);
        estimates.insert("ohmicResistance", p.ohmic_resistance);
    }
    if let Stage::Done(d) = &dynamics {
        parameters.gain = d.gain.value;
        parameters.tau_zero = d.tau_zero.value;
        parameters.tau_pole1 = d.tau_pole1.value;
        parameters.tau_pole2 = d.tau_pole2.value;
        estimates.insert("gain", d.gain);
        estimates.insert("tauZero", d.tau_zero);
        estimates.insert("tauPole1", d.tau_pole1);
        estimates.insert("tauPole2", d.tau_pole2);
        if let Ok(r) = &d.ramp {
            parameters.ramp_up_limit = r.value;
            estimates.insert("rampUpLimit", *r);
        }
    }
    if let Stage::Done(h) = &hydrogen {
        parameters.h2_coefficient = h.coefficient.value;
        estimates.insert("h2Coefficient", h.coefficient);
    }
    ModuleFit {
        log: LogSummary {
            id: log.id.clone(),
            files: log.files.len(),
            dialects: log.dialects.clone(),
            rows_read: log.rows_read,
            rows_used: log.rows_used,
            bad: log.bad.clone(),
        },
        steps,
        polarisation,
        dynamics,
        structure,
        hydrogen,
        temperature,
        heat,
        drift,
        parameters,
        estimates,
        timings,
        poorly_determined: options.poorly_determined,
    }
}

/// The voltage's temperature terms ([`temperature`]) and its drift ([`drift`]), which a log
/// may carry both: a warm-up early in a run, while the reversible drift builds up, is taken
/// for temperature by a fit of the temperature terms alone. The temperature stage is fitted
/// with the drift's terms wherever the log shows a drift
/// ([`drift::fit_temperature_with_drift`]), and the drift stage then again with the
/// temperature terms so found taken out (the joint fit does not depend on the drift stage's
/// result but for its start, so this alternation has converged); where the log shows none,
/// both stand as fitted alone.
pub fn fit_temperature_and_drift(
    log: &ModuleLog,
    options: &FitOptions,
) -> (Stage<TemperatureFit>, Stage<DriftFit>) {
    let plain = temperature::fit_temperature_dependence(log, &options.temperature);
    let drift = drift::fit_drift(log, &options.polarisation);
    let Ok(plain) = plain else {
        return (plain.into(), drift.into());
    };
    match drift::fit_temperature_with_drift(log, &options.temperature, &plain, drift.as_ref().ok())
    {
        Ok(None) => (Stage::Done(plain), drift.into()),
        Ok(Some(joint)) => {
            let (kv, kr) = (
                joint.voltage_coefficient.value,
                joint.resistance_coefficient.map_or(0.0, |e| e.value),
            );
            let refit = drift::fit_drift_without(log, &options.polarisation, (kv, kr));
            (Stage::Done(joint), refit.into())
        }
        Err(why) => (Stage::Skipped(why), drift.into()),
    }
}

/// Spread of each identified parameter over the modules that identified it.
pub fn spread(fits: &[ModuleFit]) -> BTreeMap<String, Spread> {
    let mut out = BTreeMap::new();
    for parameter in ModuleParameter::ALL {
        let (name, unit) = (parameter.name(), parameter.unit());
        let values: Vec<f64> = fits
            .iter()
            .filter_map(|f| f.estimates.get(name).map(|e| e.value))
            .collect();
        if values.len() < 2 {
            continue;
        }
        let mean = stats::mean(&values);
        let std = stats::sample_std(&values);
        out.insert(
            name.to_string(),
            Spread {
                unit: unit.to_string(),
                mean,
                std,
                min: values.iter().copied().fold(f64::INFINITY, f64::min),
                max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                cv_percent: 100.0 * std / mean.abs(),
            },
        );
    }
    out
}

/// The parameter file for these fits.
pub fn parameter_file(fits: &[ModuleFit]) -> ParameterFile {
    let modules = fits
        .iter()
        .map(|fit| {
            let parameters = ModuleParameter::ALL
                .into_iter()
                .map(|parameter| {
                    let name = parameter.name();
                    let estimate = fit.estimates.get(name);
                    let entry = ParameterEntry {
                        value: fit.parameters.get(parameter),
                        unit: parameter.unit().to_string(),
                        standard_error: estimate
                            .map(|e| e.standard_error)
                            .filter(|s| s.is_finite()),
                        poorly_determined: estimate.map(|_| fit.is_poorly_determined(name)),
                        source: if estimate.is_some() {
                            Source::Identified
                        } else {
                            Source::Default
                        },
                    };
                    (name.to_string(), entry)
                })
                .collect();
            ModuleEntry {
                module: fit.log.id.clone(),
                parameters,
                statistics: report::statistics_json(fit),
            }
        })
        .collect();
    let spread = (fits.len() > 1).then(|| spread(fits));
    ParameterFile {
        generator: format!("aem-identify {}", env!("CARGO_PKG_VERSION")),
        modules,
        spread,
    }
}
