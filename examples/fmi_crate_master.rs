//! The setpoint schedule of tests/data/importer_schedule.csv through the `fmi` crate, an
//! importer independent of this FMU's code: it unzips the .fmu, reads the model description
//! with its own schema and calls the binary through libloading. Same schedule semantics and
//! output as the C master (tests/c_master/master.c), so tests/python/fmu/test_importers.py can
//! compare them number for number.
//!
//! ```sh
//! cargo run --release --example fmi_crate_master -- \
//!     --fmu target/fmu/AemElectrolyser.fmu --schedule tests/data/importer_schedule.csv \
//!     --step 0.5 --stop 1500 --out out.csv
//! ```
//!
//! Schedule rows are `time,setpoint`: the setpoint holds from that time on; the first row's
//! time is the start time. Output rows are time,current,voltage,power,h2Flow,energy,h2Produced
//! after initialisation and after every step; values are written in Rust's shortest form that
//! reads back to the same double (the C master's %.17g reads back to the same double too).

use std::error::Error;
use std::fmt::Write as _;
use std::path::PathBuf;

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common};
use fmi::fmi2::Fmi2Res;

const OUTPUTS: [&str; 6] = [
    "current",
    "voltage",
    "power",
    "h2Flow",
    "energy",
    "h2Produced",
];

type Result<T> = std::result::Result<T, Box<dyn Error>>;

struct Args {
    fmu: PathBuf,
    schedule: PathBuf,
    step: f64,
    stop: f64,
    out: PathBuf,
}

fn parse_args() -> Result<Args> {
    let argv: Vec<String> = std::env::args().skip(1).collect();
    let value = |name: &str| -> Result<String> {
        let i = argv
            .iter()
            .position(|a| a == name)
            .ok_or(format!("missing {name}"))?;
        Ok(argv
            .get(i + 1)
            .ok_or(format!("{name} needs a value"))?
            .clone())
    };
    Ok(Args {
        fmu: value("--fmu")?.into(),
        schedule: value("--schedule")?.into(),
        step: value("--step")?.parse()?,
        stop: value("--stop")?.parse()?,
        out: value("--out")?.into(),
    })
}

/// (time, setpoint) rows, times increasing.
fn read_schedule(path: &PathBuf) -> Result<Vec<(f64, f64)>> {
    let text = std::fs::read_to_string(path)?;
    let mut lines = text.lines();
    if lines.next().is_none_or(|h| h.trim() != "time,setpoint") {
        return Err("the schedule must start with the header time,setpoint".into());
    }
    let mut rows: Vec<(f64, f64)> = Vec::new();
    for line in lines.filter(|l| !l.trim().is_empty()) {
        let (t, u) = line
            .split_once(',')
            .ok_or("schedule rows are time,setpoint")?;
        let row = (t.trim().parse::<f64>()?, u.trim().parse::<f64>()?);
        if rows.last().is_some_and(|last| !(row.0 > last.0)) {
            return Err("schedule times must increase".into());
        }
        rows.push(row);
    }
    if rows.is_empty() {
        return Err("the schedule is empty".into());
    }
    Ok(rows)
}

/// The setpoint in force at time t: that of the last row with time <= t.
fn setpoint_at(schedule: &[(f64, f64)], t: f64) -> f64 {
    let mut i = 0;
    while i + 1 < schedule.len() && schedule[i + 1].0 <= t {
        i += 1;
    }
    schedule[i].1
}

/// An fmi2 call's result: only OK passes, unless a warning is allowed as well.
fn check(
    what: &str,
    result: std::result::Result<Fmi2Res, fmi::fmi2::Fmi2Error>,
    warning_ok: bool,
) -> Result<()> {
    match result {
        Ok(Fmi2Res::OK) => Ok(()),
        Ok(Fmi2Res::Warning) if warning_ok => Ok(()),
        other => Err(format!("{what} returned {other:?}").into()),
    }
}

fn main() -> Result<()> {
    let args = parse_args()?;
    let schedule = read_schedule(&args.schedule)?;
    let start = schedule[0].0;
    let h = args.step;
    if !(h > 0.0) || !(args.stop > start) {
        return Err("need --step > 0 and --stop after the first schedule time".into());
    }
    let n_steps = ((args.stop - start) / h).round();
    if (start + n_steps * h - args.stop).abs() > 1e-9 * args.stop.abs().max(1.0) {
        return Err("--stop must be the start time plus a whole number of steps".into());
    }

    let import: Fmi2Import = fmi::import::from_path(&args.fmu)?;
    let md = fmi::traits::FmiImport::model_description(&import);
    let vr = |name: &str| -> Result<u32> {
        let var = md.model_variables.variables.iter().find(|v| v.name == name);
        Ok(var.ok_or(format!("no variable {name}"))?.value_reference)
    };
    let setpoint_vr = [vr("setpoint")?];
    let output_vrs = OUTPUTS
        .iter()
        .map(|n| vr(n))
        .collect::<Result<Vec<u32>>>()?;

    let mut fmu = import.instantiate_cs("fmi_crate_master", false, false)?;
    if fmu.get_version() != "2.0" || fmu.get_types_platform() != "default" {
        return Err("fmi2GetVersion or fmi2GetTypesPlatform is wrong".into());
    }
    check(
        "setupExperiment",
        fmu.setup_experiment(None, start, Some(args.stop)),
        false,
    )?;
    check(
        "setReal",
        fmu.set_real(&setpoint_vr, &[setpoint_at(&schedule, start)]),
        true,
    )?;
    check(
        "enterInitializationMode",
        fmu.enter_initialization_mode(),
        false,
    )?;
    check(
        "exitInitializationMode",
        fmu.exit_initialization_mode(),
        true,
    )?;

    let mut csv = String::from("time,current,voltage,power,h2Flow,energy,h2Produced\n");
    let mut values = [0.0; OUTPUTS.len()];
    let mut row =
        |fmu: &mut fmi::fmi2::instance::InstanceCS, t: f64, csv: &mut String| -> Result<()> {
            check("getReal", fmu.get_real(&output_vrs, &mut values), false)?;
            write!(csv, "{t}")?;
            for v in values {
                write!(csv, ",{v}")?;
            }
            csv.push('\n');
            Ok(())
        };
    row(&mut fmu, start, &mut csv)?;
    // Communication points are start + n*h, computed afresh each step (no running sum).
    let mut n = 0.0;
    while n < n_steps {
        let t = start + n * h;
        check(
            "setReal",
            fmu.set_real(&setpoint_vr, &[setpoint_at(&schedule, t)]),
            true,
        )?;
        check("doStep", fmu.do_step(t, h, true), false)?;
        row(&mut fmu, start + (n + 1.0) * h, &mut csv)?;
        n += 1.0;
    }
    let last = fmu
        .last_successful_time()
        .map_err(|e| format!("fmi2GetRealStatus: {e:?}"))?;
    if (last - args.stop).abs() > 1e-9 * args.stop.abs().max(1.0) {
        return Err(format!("fmi2LastSuccessfulTime is {last}, not the stop time").into());
    }
    check("terminate", fmu.terminate(), false)?;
    std::fs::write(&args.out, csv)?;
    Ok(())
}
