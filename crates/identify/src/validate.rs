//! Validation on a held-out day (paper §III-E): the identified model, [`Module`] of the FMU's
//! own code, is driven by the day's setpoints through every running segment (from steady
//! state at the segment's first setpoint; row n's setpoint acts from row n − 1 on) and
//! compared with the measured current, voltage, power (V·I) and hydrogen flow.
//!
//! Rows within the settle time after a start-up or gap are outside the model's scope (the
//! paper models a running module) and are not compared; the current RMSE including them is
//! reported beside.

use std::io::Write as _;
use std::path::Path;

use aem_model::{Module, Parameters};

use super::columns::Channel;
use super::error::{Error, Result};
use super::read::ModuleLog;
use super::stats;

/// Which rows are compared.
#[derive(Clone, Debug)]
pub struct ValidateOptions {
    /// A row runs when its current exceeds this [A] and its setpoint exceeds 0.
    pub running_current: f64,
    /// Rows this long after a segment starts are compared [s].
    pub settle: f64,
}

impl Default for ValidateOptions {
    fn default() -> Self {
        ValidateOptions {
            running_current: 1.0,
            settle: 600.0,
        }
    }
}

/// RMSE of the model against the measurements.
#[derive(Clone, Debug, Default)]
pub struct Validation {
    /// Running segments simulated.
    pub segments: usize,
    /// Running rows.
    pub running_rows: usize,
    /// Rows compared (after the settle time).
    pub compared_rows: usize,
    /// Current RMSE [A].
    pub current: f64,
    /// Current RMSE including start-ups [A].
    pub current_with_startups: f64,
    /// Voltage RMSE [V], if measured.
    pub voltage: Option<f64>,
    /// Power RMSE [W], measured power being V·I.
    pub power: Option<f64>,
    /// Hydrogen flow RMSE [Nl/h], if measured.
    pub h2_flow: Option<f64>,
}

/// Measured and simulated values of every running row.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    /// Rows: time, setpoint, then measured/model pairs of current, voltage, power, h2 flow
    /// (NaN where not measured), and whether the row is compared.
    pub rows: Vec<([f64; 10], bool)>,
}

/// Simulates `params` over the running segments of `log` and compares.
pub fn validate(
    params: &Parameters,
    log: &ModuleLog,
    options: &ValidateOptions,
) -> Result<(Validation, Trace)> {
    if !log.has(Channel::Setpoint) {
        return Err(Error::Input(format!(
            "module {}: no setpoint column to drive the model",
            log.id
        )));
    }
    let mut v = Validation::default();
    let mut trace = Trace::default();
    let (mut e_i, mut e_i_all, mut e_v, mut e_p, mut e_h) =
        (vec![], vec![], vec![], vec![], vec![]);
    for block in &log.blocks {
        let (Some(setpoint), Some(current)) = (
            block.channel(Channel::Setpoint),
            block.channel(Channel::Current),
        ) else {
            continue;
        };
        let voltage = block.channel(Channel::Voltage);
        let h2 = block.channel(Channel::H2Flow);
        let t = &block.time;
        let mut r = 0;
        while r < block.len() {
            let running = |i: usize| current[i] > options.running_current && setpoint[i] > 0.0;
            if !running(r) {
                r += 1;
                continue;
            }
            let start = r;
            let mut module = Module::new(*params, setpoint[r])
                .map_err(|e| Error::Input(format!("parameters: {e}")))?;
            v.segments += 1;
            while r < block.len() && running(r) {
                if r > start {
                    module
                        .step(setpoint[r], t[r] - t[r - 1])
                        .map_err(|e| Error::Content {
                            path: block.source.clone(),
                            line: block.first_line,
                            message: format!("row {r} of the block: {e}"),
                        })?;
                }
                let compared = t[r] - t[start] >= options.settle;
                let mv = voltage.map_or(f64::NAN, |x| x[r]);
                let mh = h2.map_or(f64::NAN, |x| x[r]);
                let row = [
                    t[r],
                    setpoint[r],
                    current[r],
                    module.current(),
                    mv,
                    module.voltage(),
                    mv * current[r],
                    module.power(),
                    mh,
                    module.h2_flow(),
                ];
                e_i_all.push(row[2] - row[3]);
                if compared {
                    e_i.push(row[2] - row[3]);
                    if voltage.is_some() {
                        e_v.push(row[4] - row[5]);
                        e_p.push(row[6] - row[7]);
                    }
                    if h2.is_some() {
                        e_h.push(row[8] - row[9]);
                    }
                }
                v.running_rows += 1;
                trace.rows.push((row, compared));
                r += 1;
            }
        }
    }
    if e_i.is_empty() {
        return Err(Error::Input(format!(
            "module {}: no running row {} s or more after a start-up to compare",
            log.id, options.settle
        )));
    }
    v.compared_rows = e_i.len();
    v.current = stats::rms(&e_i);
    v.current_with_startups = stats::rms(&e_i_all);
    v.voltage = (!e_v.is_empty()).then(|| stats::rms(&e_v));
    v.power = (!e_p.is_empty()).then(|| stats::rms(&e_p));
    v.h2_flow = (!e_h.is_empty()).then(|| stats::rms(&e_h));
    Ok((v, trace))
}

/// Column names of [`write_trace`].
pub const TRACE_HEADER: &str = "time,setpoint,current_measured,current_model,voltage_measured,voltage_model,power_measured,power_model,h2_flow_measured,h2_flow_model,compared";

/// Writes the trace as CSV (for `python -m aem_electrolyser.plot_validation`).
pub fn write_trace(path: &Path, trace: &Trace) -> Result<()> {
    let io = |e: std::io::Error| Error::Io {
        path: path.into(),
        message: e.to_string(),
    };
    let file = std::fs::File::create(path).map_err(io)?;
    let mut w = std::io::BufWriter::new(file);
    writeln!(w, "{TRACE_HEADER}").map_err(io)?;
    for (row, compared) in &trace.rows {
        let fields: Vec<String> = row
            .iter()
            .map(|x| {
                if x.is_finite() {
                    format!("{x}")
                } else {
                    String::new()
                }
            })
            .collect();
        writeln!(w, "{},{}", fields.join(","), u8::from(*compared)).map_err(io)?;
    }
    w.flush().map_err(io)
}
