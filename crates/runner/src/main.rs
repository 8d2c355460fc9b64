//! aem-run: one scenario of the packaged hub FMU, driven natively through its C interface
//! (the `fmi` crate), over a reference series held over each step; prints the KPIs as JSON.
//!
//! ```sh
//! aem-run --fmu target/fmu/AemElectrolyser.fmu --reference wind.f64 --step 1 --input power \
//!     --parameter dispatch=2 --parameter belowMinimum=1 --hub-size 0.9 --source-rating 64e6
//! ```
//!
//! `--reference` is a file of little-endian f64, one value per step ([W] for `--input power`,
//! the default; [%] for `--input setpoint`). Parameters are set by their model-description
//! names (enumerations by their codes). `--hub-size F --source-rating W` sizes the hub to
//! F·W of rated power (nModules from one module's steady power at maxSetpoint).
//!
//! Prints one JSON object: `{"status": "done", "kpis": {...}, "messages": [...]}` with the
//! KPIs of aem_electrolyser.study.kpis, or `{"status": "failed", "message": "..."}` naming the failed call
//! and the FMU's own messages (exit status 1). A reader that goes away (`aem-run ... | head`)
//! does not change the exit status, as for the package's other commands.

mod driver;
mod fmu_messages;
mod kpis;

use std::fs::File;
use std::io::{BufReader, ErrorKind, Read, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::{json, Value};

use driver::{Input, Scenario};

struct Args {
    fmu: PathBuf,
    scenario: Scenario,
}

/// What `aem-run --help` prints.
const USAGE: &str = "\
aem-run: one scenario of the hub FMU over a reference series; prints its KPIs as one JSON object

Usage: aem-run --fmu FMU --reference FILE --step SECONDS [OPTIONS]

Options:
  --fmu FMU              the FMU (through the aem-run of the Python package: the installed one)
  --reference FILE       little-endian f64 values, one per step ([W] for --input power, [%] for setpoint)
  --step SECONDS         communication step, > 0
  --start SECONDS        start time [default: 0]
  --input power|setpoint what the reference drives [default: power]
  --parameter NAME=VALUE a parameter by its model-description name (repeatable; enumerations by code)
  --hub-size F           size the hub to F times --source-rating W of rated power (both > 0)
  --source-rating W      rated power of the source [W]
  -h, --help             this text
  -V, --version          the version

Exit status: 0 done, 1 the FMU or the run failed, 2 a bad argument; the JSON on stdout says which.
";

fn parse_args(argv: &[String]) -> Result<Args, String> {
    let mut fmu = None;
    let mut reference = None;
    let mut step = None;
    let mut start = 0.0;
    let mut input = Input::Power;
    let mut parameters = Vec::new();
    let (mut hub_size, mut source_rating) = (None, None);
    let mut it = argv.iter();
    while let Some(flag) = it.next() {
        let mut value = || {
            it.next()
                .cloned()
                .ok_or_else(|| format!("{flag} needs a value"))
        };
        let number = |text: String| {
            text.parse::<f64>()
                .map_err(|_| format!("{flag} {text}: not a number"))
        };
        match flag.as_str() {
            "--fmu" => fmu = Some(PathBuf::from(value()?)),
            "--reference" => reference = Some(PathBuf::from(value()?)),
            "--step" => {
                let h = number(value()?)?;
                if !(h.is_finite() && h > 0.0) {
                    return Err(format!("--step {h}: must be a positive number of seconds"));
                }
                step = Some(h);
            }
            "--start" => start = number(value()?)?,
            "--hub-size" => hub_size = Some(number(value()?)?),
            "--source-rating" => source_rating = Some(number(value()?)?),
            "--input" => {
                input = match value()?.as_str() {
                    "power" => Input::Power,
                    "setpoint" => Input::Setpoint,
                    other => return Err(format!("--input {other}: power or setpoint")),
                }
            }
            // --param: the name before --parameter (aem-study's workers still give it).
            "--parameter" | "--param" => {
                let text = value()?;
                let (name, v) = text
                    .split_once('=')
                    .ok_or(format!("--parameter {text}: NAME=VALUE"))?;
                parameters.push((name.trim().to_string(), v.to_string()));
            }
            other => return Err(unknown(other)),
        }
    }
    let hub_size = match (hub_size, source_rating) {
        (Some(f), Some(w)) if f > 0.0 && w > 0.0 => Some((f, w)),
        (None, None) => None,
        _ => return Err("--hub-size needs --source-rating, both > 0".into()),
    };
    let fmu = fmu.ok_or("--fmu is required")?;
    if !fmu.is_file() {
        return Err(format!(
            "--fmu {}: no such file (the FMU, a .fmu archive)",
            fmu.display()
        ));
    }
    if !is_zip(&fmu) {
        return Err(format!(
            "--fmu {}: not an FMU (not a zip archive)",
            fmu.display()
        ));
    }
    let reference_path = reference.ok_or("--reference is required")?;
    let reference = read_reference(&reference_path).map_err(|e| format!("--reference: {e}"))?;
    if reference.is_empty() {
        return Err(format!(
            "--reference {}: empty (one f64 per step)",
            reference_path.display()
        ));
    }
    Ok(Args {
        fmu,
        scenario: Scenario {
            parameters,
            input,
            reference,
            start,
            step: step.ok_or("--step is required")?,
            hub_size,
        },
    })
}

/// Whether a failure of the run is about an argument (`--fmu …`, `--parameter …`): exit status 2.
fn error_names_an_argument(message: &str) -> bool {
    message.starts_with("--fmu ") || message.starts_with("--parameter")
}

/// Whether `path` starts as a zip archive does ("PK\x03\x04"; an FMU is one).
fn is_zip(path: &Path) -> bool {
    let mut magic = [0u8; 4];
    File::open(path)
        .and_then(|mut f| f.read_exact(&mut magic))
        .is_ok_and(|()| magic == *b"PK\x03\x04")
}

/// The options of aem-run.
const OPTIONS: [&str; 9] = [
    "--fmu",
    "--reference",
    "--step",
    "--start",
    "--input",
    "--parameter",
    "--hub-size",
    "--source-rating",
    "--version",
];

/// "unknown argument X", with the nearest option where one is near (Jaro-Winkler ≥ 0.8).
fn unknown(argument: &str) -> String {
    let nearest = OPTIONS
        .iter()
        .map(|o| (strsim::jaro_winkler(o, argument), o))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    match nearest {
        Some((score, option)) if score >= 0.8 => {
            format!("unknown argument {argument} (did you mean {option}?)")
        }
        _ => format!("unknown argument {argument}"),
    }
}

/// The little-endian f64 values of `path`, read through a buffer (a year at 1 s is 252 MB:
/// never twice in memory).
fn read_reference(path: &Path) -> Result<Vec<f64>, String> {
    let cannot = |e: std::io::Error| format!("cannot read {}: {e}", path.display());
    let file = File::open(path).map_err(cannot)?;
    let bytes = file.metadata().map_err(cannot)?.len();
    if bytes % 8 != 0 {
        return Err(format!(
            "{}: {bytes} bytes is not a whole number of f64",
            path.display()
        ));
    }
    let mut reader = BufReader::with_capacity(1 << 16, file);
    let mut values =
        Vec::with_capacity(usize::try_from(bytes / 8).map_err(|_| "the reference is too large")?);
    let mut value = [0u8; 8];
    for _ in 0..bytes / 8 {
        reader.read_exact(&mut value).map_err(cannot)?;
        values.push(f64::from_le_bytes(value));
    }
    Ok(values)
}

/// Writes `text` to stdout. A reader that went away (`aem-run ... | head`, a worker that died)
/// is no error: the command ends as it would have, quietly, as the package's Python commands do.
/// Any other failure to write is one line on stderr and exit status 1.
fn print_out(text: &str) {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != ErrorKind::BrokenPipe => {
            print_err(&format!("aem-run: error: cannot write to stdout: {e}"));
            std::process::exit(1);
        }
        _ => {}
    }
}

/// Writes a line to stderr; a closed stderr is ignored (never a panic).
fn print_err(line: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

fn main() {
    let argv: Vec<String> = std::env::args().skip(1).collect();
    if argv.iter().any(|a| a == "--help" || a == "-h") {
        print_out(USAGE);
        return;
    }
    if argv.iter().any(|a| a == "--version" || a == "-V") {
        print_out(&format!("aem-run {}\n", env!("CARGO_PKG_VERSION")));
        return;
    }
    let args = match parse_args(&argv) {
        Ok(args) => args,
        Err(error) => {
            // A bad argument: one line for a person on stderr, the JSON for a worker on stdout.
            print_err(&format!(
                "aem-run: error: {error} (aem-run --help lists the options)"
            ));
            print_out(&format!(
                "{}\n",
                json!({ "status": "failed", "message": error })
            ));
            std::process::exit(2);
        }
    };
    fmu_messages::install();
    let clock = Instant::now();
    let outcome = driver::run(&args.fmu, &args.scenario);
    let (messages, dropped) = fmu_messages::take();
    let mut messages: Vec<Value> = messages.into_iter().map(Value::from).collect();
    if dropped > 0 {
        messages.push(Value::from(format!("... and {dropped} more messages")));
    }
    let (report, code) = match outcome {
        Ok((totals, sums)) => (
            json!({
                "status": "done",
                "kpi version": kpis::KPI_VERSION,
                "kpis": kpis::row(&totals, sums.as_ref()),
                "messages": messages,
                "run time [s]": clock.elapsed().as_secs_f64(),
            }),
            0,
        ),
        Err(error) => {
            let text = messages
                .iter()
                .filter_map(Value::as_str)
                .collect::<Vec<_>>()
                .join(" | ");
            let message = if text.is_empty() {
                error
            } else {
                format!("{error}. The FMU: {text}")
            };
            // The worker reads the JSON; a person reads this line. An FMU that does not load
            // or a parameter it does not have is a bad argument found once the FMU is read.
            print_err(&format!("aem-run: error: {message}"));
            let code = if error_names_an_argument(&message) {
                2
            } else {
                1
            };
            (json!({ "status": "failed", "message": message }), code)
        }
    };
    print_out(&format!("{report}\n"));
    std::process::exit(code);
}
