//! `aem-identify`: identify the AEM electrolyser model's parameters from operational logs,
//! validate them on a held-out day, or write a synthetic campaign to try the tool on.
//!
//! ```text
//! aem-identify fit logs/ -o params.json                  # a directory of daily CSV files
//! aem-identify fit --module A=logsA/ --module B=logsB/ -o params.json
//! aem-identify fit plant.csv --column current=StackCurrent --column module=Unit
//! aem-identify validate params.json day11.csv --csv out/validation.csv
//! aem-identify synthesize data/ --days 10 --broken
//! ```
//! The report goes to stdout, errors and timings to stderr; a progress bar is drawn on
//! stderr when it is a terminal. Result files are written before the report is printed, and
//! their paths are checked for writing before any input is read; a closed stdout (`| head`)
//! ends the command quietly with exit status 0.

use std::fs::OpenOptions;
use std::io::{IsTerminal as _, Write as _};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use aem_identify::columns::ColumnMap;
use aem_identify::read::{self, DialectChoice, ModuleLog, ReadOptions};
use aem_identify::synthetic::{self, CampaignSpec, CsvOptions};
use aem_identify::validate::{self, ValidateOptions};
use aem_identify::{self as id, Error, FitOptions};
use aem_model::parameter_file::ParameterFile;

#[derive(Parser)]
#[command(
    name = "aem-identify",
    version,
    about = "Identify the AEM electrolyser model's parameters from operational data"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Fit the parameters of one or more modules and print a Table-I-like report.
    #[command(allow_negative_numbers = true)]
    Fit(FitArgs),
    /// Simulate identified parameters on a held-out day and report the RMSE.
    #[command(allow_negative_numbers = true)]
    Validate(ValidateArgs),
    /// Write a synthetic campaign (daily CSV files at 1 Hz) with known parameters.
    #[command(allow_negative_numbers = true)]
    Synthesize(SynthesizeArgs),
}

#[derive(Args)]
struct InputArgs {
    /// Map a channel to a column: KEY=NAME with KEY one of time, setpoint, current, voltage,
    /// temperature, pressure, h2_flow, module (repeatable).
    #[arg(long = "column", value_name = "KEY=NAME")]
    columns: Vec<String>,
    /// Field separator: auto (detected per file from its header and first rows), comma,
    /// semicolon, tab or one punctuation character.
    #[arg(long, default_value = "auto")]
    separator: String,
    /// Decimal mark of numbers: auto (detected per file), point or comma.
    #[arg(long, default_value = "auto")]
    decimal: String,
    /// Longest time step that is not a gap [s].
    #[arg(long, default_value_t = 10.0)]
    max_gap: f64,
    /// A row runs when its current exceeds this [A] (and its setpoint exceeds 0).
    #[arg(long, default_value_t = 1.0)]
    running_current: f64,
    /// Rows within this time after a start-up or gap are not steady running [s].
    #[arg(long, default_value_t = 600.0)]
    settle: f64,
}

#[derive(Args)]
struct FitArgs {
    /// CSV files or directories of CSV files (one module, or several with a module column).
    inputs: Vec<PathBuf>,
    /// A file set per module: ID=PATH (file or directory; repeatable).
    #[arg(long = "module", value_name = "ID=PATH")]
    modules: Vec<String>,
    /// Write the parameters (the FMU's names and units) and fit statistics as JSON.
    #[arg(short, long, value_name = "params.json")]
    output: Option<PathBuf>,
    #[command(flatten)]
    input: InputArgs,
    /// Cells in the stack, for the Faraday efficiency.
    #[arg(long, default_value_t = 23)]
    cells: u32,
    /// Nominal electrolyte temperature [°C].
    #[arg(long, default_value_t = 55.0)]
    nominal_temperature: f64,
    /// Allowed deviation from the nominal temperature for polarisation points [°C].
    #[arg(long, default_value_t = 0.1)]
    temperature_tolerance: f64,
    /// Nominal pressure [bar].
    #[arg(long, default_value_t = 29.0)]
    nominal_pressure: f64,
    /// Allowed deviation from the nominal pressure for polarisation points [bar].
    #[arg(long, default_value_t = 0.1)]
    pressure_tolerance: f64,
    /// Running samples within this distance of the nominal temperature fit the curve's
    /// temperature coefficients kV, kR [K].
    #[arg(long, default_value_t = 15.0)]
    temperature_window: f64,
    /// Length of the pre-step window whose mean is subtracted [s].
    #[arg(long, default_value_t = 60.0)]
    pre_window: f64,
    /// Smallest setpoint step used [%].
    #[arg(long, default_value_t = 1.0)]
    min_step: f64,
    /// Shortest response used [s].
    #[arg(long, default_value_t = 60.0)]
    min_response: f64,
    /// Outlier threshold: robust standard deviations of the step RMSEs above their median.
    #[arg(long, default_value_t = 5.0)]
    outlier_sigmas: f64,
    /// Flag parameters whose relative standard error exceeds this fraction.
    #[arg(long, default_value_t = 0.05)]
    poorly_determined: f64,
    /// Nominal stack current to write [A] (not identified; default: the FMU's start value).
    #[arg(long)]
    nominal_current: Option<f64>,
    /// Also fit all five dynamic parameters to the whole record (a cross-check).
    #[arg(long)]
    trajectory: bool,
    /// Print the wall time of each stage to stderr.
    #[arg(long)]
    timings: bool,
}

#[derive(Args)]
struct ValidateArgs {
    /// Parameter file written by `aem-identify fit`.
    params: PathBuf,
    /// The held-out day(s): CSV files or directories.
    days: Vec<PathBuf>,
    /// Module to validate (its parameters, and its rows if the day has a module column).
    #[arg(long)]
    module: Option<String>,
    /// Write measured and simulated values of every running row (plot with
    /// python -m aem_electrolyser.plot_validation).
    #[arg(long, value_name = "out.csv")]
    csv: Option<PathBuf>,
    #[command(flatten)]
    input: InputArgs,
}

#[derive(Args)]
struct SynthesizeArgs {
    /// Directory for day01.csv, day02.csv, ...
    dir: PathBuf,
    /// Days to write.
    #[arg(long, default_value_t = 10)]
    days: usize,
    /// Seed.
    #[arg(long, default_value_t = 2026)]
    seed: u64,
    /// Running hours per day (rows ≈ 3600·hours + 600).
    #[arg(long, default_value_t = 30_000.0 / 3600.0 - 600.0 / 3600.0)]
    hours: f64,
    /// Inject broken rows of every kind and one gap per file.
    #[arg(long)]
    broken: bool,
    /// Write RFC 3339 timestamps instead of seconds.
    #[arg(long)]
    rfc3339: bool,
    /// Write only the first N days' files but draw days from index SKIP on (for a held-out day).
    #[arg(long, default_value_t = 0)]
    skip: usize,
    /// The stack temperature from a heat balance (C = 25 kJ/K, Rth = 0.2 K/W, 5 °C ± 3 K air)
    /// with an ambient_temperature column, instead of the scripted warm-up and dips.
    #[arg(long)]
    thermal: bool,
    /// A voltage drift with use (the FMU's ageing: 0.4 V reversible, building up in 2 h and
    /// recovering in 8 h, 2 mV per running hour, 5 mV per start).
    #[arg(long)]
    drift: bool,
}

/// glibc hands freed blocks above 128 kB straight back to the kernel. The fits allocate and
/// free the same multi-megabyte residual and Jacobian buffers every iteration, and faulting
/// their pages in again cost more system time than the arithmetic took (62 000 page faults
/// for ten days of data). Keep such blocks in the heap: 32 MB is glibc's largest mmap
/// threshold.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn keep_freed_memory() {
    // SAFETY: mallopt only changes allocator parameters; it is called first thing in main,
    // before any other thread exists.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 256 << 20);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn keep_freed_memory() {}

fn main() -> ExitCode {
    keep_freed_memory();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(), // --help, --version
        Err(e) => return usage_error(&one_line(&e.render().to_string())),
    };
    if let Err(message) = check_usage(&cli.command) {
        return usage_error(&message);
    }
    let result = match cli.command {
        Command::Fit(args) => fit(args),
        Command::Validate(args) => run_validate(args),
        Command::Synthesize(args) => synthesize(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            say_err(&format!("aem-identify: error: {e}\n"));
            ExitCode::FAILURE
        }
    }
}

/// A bad argument: one line on stderr, exit status 2 (as clap's own errors).
fn usage_error(message: &str) -> ExitCode {
    say_err(&format!("aem-identify: error: {message}\n"));
    ExitCode::from(2)
}

/// clap's multi-line error as one line: its first line and its tip ("did you mean").
fn one_line(rendered: &str) -> String {
    let mut lines = rendered.lines().map(str::trim).filter(|l| !l.is_empty());
    let mut first = lines
        .next()
        .unwrap_or("bad arguments")
        .trim_start_matches("error: ")
        .to_string();
    if first.ends_with(':') {
        // "the following required arguments were not provided:" and the list below it
        let listed: Vec<&str> = lines
            .clone()
            .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("tip:"))
            .collect();
        first = format!("{first} {}", listed.join(", "));
    }
    match lines.find_map(|l| l.strip_prefix("tip: ")) {
        // "a similar argument exists: '--separator'" -> "did you mean '--separator'?"
        Some(tip) if tip.starts_with("a similar") => match tip.split_once(": ") {
            Some((_, near)) => format!("{first} (did you mean {near}?)"),
            None => format!("{first} ({tip})"),
        },
        Some(tip) => format!("{first} ({tip}; see --help)"),
        None => format!("{first} (see --help)"),
    }
}

/// The arguments checked before any work: inputs that exist, sizes that make sense.
fn check_usage(command: &Command) -> Result<(), String> {
    let exists = |what: &str, path: &PathBuf| {
        if path.exists() {
            Ok(())
        } else {
            Err(format!("{what} {}: no such file or folder", path.display()))
        }
    };
    let options = |input: &InputArgs| {
        read_options(input, "module")
            .map(|_| ())
            .map_err(|e| e.to_string())
    };
    match command {
        Command::Fit(args) => {
            options(&args.input)?;
            if args.cells == 0 {
                return Err("--cells 0: the stack has at least one cell".into());
            }
            if args.inputs.is_empty() && args.modules.is_empty() {
                return Err(
                    "give the campaign's CSV files or folders (or --module ID=PATH)".into(),
                );
            }
            for path in &args.inputs {
                exists("input", path)?;
            }
            for module in &args.modules {
                match module.split_once('=') {
                    Some((id, path)) if !id.trim().is_empty() && !path.is_empty() => {
                        exists("--module", &PathBuf::from(path))?;
                    }
                    _ => return Err(format!("--module `{module}` must look like ID=PATH")),
                }
            }
        }
        Command::Validate(args) => {
            options(&args.input)?;
            exists("parameter file", &args.params)?;
            if args.days.is_empty() {
                return Err("give the held-out day's CSV file(s) after the parameter file".into());
            }
            for path in &args.days {
                exists("held-out day", path)?;
            }
        }
        Command::Synthesize(args) => {
            if args.days == 0 {
                return Err("--days 0: write at least one day".into());
            }
            if !(args.hours > 0.0 && args.hours <= 23.0) {
                return Err(format!(
                    "--hours {}: running hours per day must be in (0, 23]",
                    args.hours
                ));
            }
        }
    }
    Ok(())
}

/// Prints `text` to stdout. A reader that has gone away (`aem-identify fit … | head`) ends the
/// command quietly with status 0: every result file has been written by then.
fn say(text: &str) -> Result<(), Error> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => std::process::exit(0),
        Err(e) => Err(Error::Input(format!("cannot write to stdout: {e}"))),
        Ok(()) => Ok(()),
    }
}

/// Like [`say`], for stderr (timings).
fn say_err(text: &str) {
    let mut err = std::io::stderr().lock();
    if let Err(e) = err.write_all(text.as_bytes()).and_then(|()| err.flush()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
    }
}

/// A result file whose path was proven writable before the work began: the file is opened
/// (created if missing, never truncated) at once; a file that this made and that never got
/// its contents is removed again.
struct OutputFile {
    path: PathBuf,
    created: bool,
    written: bool,
}

impl OutputFile {
    fn reserve(path: &Path) -> Result<OutputFile, Error> {
        let existed = path.exists();
        if path.is_dir() {
            return Err(Error::Io {
                path: path.into(),
                message: "is a directory, not a file".into(),
            });
        }
        OpenOptions::new()
            .append(true)
            .create(true)
            .open(path)
            .map_err(|e| Error::Io {
                path: path.into(),
                message: format!("cannot write here: {e}"),
            })?;
        Ok(OutputFile {
            path: path.into(),
            created: !existed,
            written: false,
        })
    }

    fn write(&mut self, contents: &str) -> Result<(), Error> {
        std::fs::write(&self.path, contents).map_err(|e| Error::Io {
            path: self.path.clone(),
            message: e.to_string(),
        })?;
        self.written = true;
        Ok(())
    }
}

impl Drop for OutputFile {
    fn drop(&mut self) {
        if self.created && !self.written {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

fn progress(len: u64, message: &str) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template("{msg:>14} [{bar:30}] {pos}/{len} {elapsed}") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(message.to_string());
    bar
}

fn read_options(input: &InputArgs, module: &str) -> Result<ReadOptions, Error> {
    if !(input.max_gap > 0.0) {
        return Err(Error::Input(format!(
            "--max-gap {} must be > 0",
            input.max_gap
        )));
    }
    Ok(ReadOptions {
        columns: ColumnMap::with_mappings(&input.columns).map_err(Error::Input)?,
        max_gap: input.max_gap,
        module: module.to_string(),
        dialect: DialectChoice {
            separator: DialectChoice::parse_separator(&input.separator).map_err(Error::Input)?,
            decimal: DialectChoice::parse_decimal(&input.decimal).map_err(Error::Input)?,
        },
    })
}

/// Reads every input file set, module ids from `--module ID=PATH` or the module column.
fn read_all(sets: &[(String, Vec<PathBuf>)], input: &InputArgs) -> Result<Vec<ModuleLog>, Error> {
    let mut files_per_set = Vec::new();
    for (id, paths) in sets {
        files_per_set.push((id.clone(), read::expand_inputs(paths)?));
    }
    let total: usize = files_per_set.iter().map(|(_, f)| f.len()).sum();
    let bar = progress(total as u64, "reading");
    let mut logs: Vec<ModuleLog> = Vec::new();
    for (id, files) in &files_per_set {
        let options = read_options(input, id)?;
        let bar_ref = &bar;
        for log in read::read_files(files, &options, &|| bar_ref.inc(1))? {
            if logs.iter().any(|l| l.id == log.id) {
                return Err(Error::Input(format!(
                    "module `{}` appears in two file sets",
                    log.id
                )));
            }
            logs.push(log);
        }
    }
    bar.finish_and_clear();
    if logs.iter().all(|l| l.rows_used == 0) {
        let read: u64 = logs.iter().map(|l| l.rows_read).sum();
        let mut reasons = Vec::new();
        for reason in read::BadRow::ALL {
            let count: u64 = logs.iter().map(|l| l.bad.count(reason)).sum();
            if let Some(first) = logs.iter().find_map(|l| l.bad.first(reason)) {
                reasons.push(format!(
                    "{} {count}, first {}:{}",
                    reason.label(),
                    first.path.display(),
                    first.line
                ));
            }
        }
        let dialects: Vec<String> = logs
            .iter()
            .flat_map(|l| &l.dialects)
            .map(ToString::to_string)
            .collect();
        let mut message = format!("no usable row in the input ({read} rows read");
        if !reasons.is_empty() {
            message += &format!(", skipped: {}", reasons.join("; "));
        }
        if let Some(dialect) = dialects.first() {
            message +=
                &format!("; read as {dialect}: if that is wrong, give --separator and --decimal");
        }
        return Err(Error::Input(message + ")"));
    }
    Ok(logs)
}

fn fit(args: FitArgs) -> Result<(), Error> {
    let start = Instant::now();
    let mut sets: Vec<(String, Vec<PathBuf>)> = Vec::new();
    if !args.inputs.is_empty() {
        sets.push(("module".into(), args.inputs.clone()));
    }
    for m in &args.modules {
        let (id, path) = m
            .split_once('=')
            .filter(|(id, p)| !id.trim().is_empty() && !p.is_empty())
            .ok_or_else(|| Error::Input(format!("--module `{m}` must look like ID=PATH")))?;
        match sets.iter_mut().find(|(i, _)| i == id.trim()) {
            Some((_, paths)) => paths.push(PathBuf::from(path)),
            None => sets.push((id.trim().to_string(), vec![PathBuf::from(path)])),
        }
    }
    if sets.is_empty() {
        return Err(Error::Input(
            "no input: give CSV files or directories, or --module ID=PATH".into(),
        ));
    }
    let mut options = FitOptions::default();
    options.steps.running_current = args.input.running_current;
    options.steps.settle = args.input.settle;
    options.steps.pre_window = args.pre_window;
    options.steps.min_step = args.min_step;
    options.steps.min_response = args.min_response;
    options.polarisation.running_current = args.input.running_current;
    options.polarisation.temperature = args.nominal_temperature;
    options.polarisation.temperature_tolerance = args.temperature_tolerance;
    options.polarisation.pressure = args.nominal_pressure;
    options.polarisation.pressure_tolerance = args.pressure_tolerance;
    options.temperature.nominal = args.nominal_temperature;
    options.temperature.window = args.temperature_window;
    options.temperature.running_current = args.input.running_current;
    options.temperature.pressure = (args.nominal_pressure, args.pressure_tolerance);
    options.heat.setpoint = args.nominal_temperature;
    options.heat.cells = args.cells;
    options.heat.running_current = args.input.running_current;
    options.dynamics.outlier_sigmas = args.outlier_sigmas;
    options.dynamics.trajectory = args.trajectory;
    options.dynamics.settle = args.input.settle;
    options.cells = args.cells;
    options.poorly_determined = args.poorly_determined;
    if let Some(i) = args.nominal_current {
        options.base.nominal_current = i;
    }
    options
        .base
        .validate()
        .map_err(|e| Error::Input(format!("--nominal-current: {e}")))?;
    let mut output = args
        .output
        .as_deref()
        .map(OutputFile::reserve)
        .transpose()?;
    for (name, v) in [
        ("--settle", args.input.settle),
        ("--pre-window", args.pre_window),
        ("--min-step", args.min_step),
        ("--min-response", args.min_response),
        ("--temperature-tolerance", args.temperature_tolerance),
        ("--pressure-tolerance", args.pressure_tolerance),
        ("--outlier-sigmas", args.outlier_sigmas),
        ("--poorly-determined", args.poorly_determined),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(Error::Input(format!(
                "{name} {v} must be a finite number >= 0"
            )));
        }
    }

    let logs = read_all(&sets, &args.input)?;
    let read_time = start.elapsed();
    let bar = progress(logs.len() as u64, "fitting");
    let mut fits = Vec::new();
    for log in &logs {
        bar.set_message(format!("fitting {}", log.id));
        fits.push(id::fit_module(log, &options));
        bar.inc(1);
    }
    bar.finish_and_clear();
    let output_start = Instant::now();
    let file = id::parameter_file(&fits);
    let report = id::report::render(&fits, file.spread.as_ref());
    if let Some(output) = &mut output {
        let text =
            serde_json::to_string_pretty(&file).map_err(|e| Error::Input(format!("JSON: {e}")))?;
        output.write(&(text + "\n"))?;
    }
    say(&report)?;
    if let Some(output) = &output {
        say(&format!("wrote {}\n", output.path.display()))?;
    }
    if args.timings {
        let rows: u64 = logs.iter().map(|l| l.rows_read).sum();
        let mut text = format!(
            "timing: read {:>8.1} ms  ({rows} rows)\n",
            read_time.as_secs_f64() * 1e3
        );
        for fit in &fits {
            for (stage, d) in &fit.timings {
                text += &format!(
                    "timing: {:<20} {:>8.1} ms  (module {})\n",
                    stage,
                    d.as_secs_f64() * 1e3,
                    fit.log.id
                );
            }
        }
        text += &format!(
            "timing: report and JSON {:>8.1} ms\n",
            output_start.elapsed().as_secs_f64() * 1e3
        );
        text += &format!(
            "timing: total {:>8.1} ms\n",
            start.elapsed().as_secs_f64() * 1e3
        );
        say_err(&text);
    }
    Ok(())
}

fn run_validate(args: ValidateArgs) -> Result<(), Error> {
    if args.days.is_empty() {
        return Err(Error::Input("give the held-out day's CSV file(s)".into()));
    }
    let mut csv = args.csv.as_deref().map(OutputFile::reserve).transpose()?;
    let file = ParameterFile::load(&args.params)?;
    let entry = file
        .module(args.module.as_deref())
        .map_err(|e| Error::Input(format!("{}: {e}", args.params.display())))?;
    let params = entry
        .parameters()
        .map_err(|e| Error::Input(format!("{}: {e}", args.params.display())))?;
    let logs = read_all(&[(entry.module.clone(), args.days.clone())], &args.input)?;
    let log = match logs.iter().find(|l| l.id == entry.module) {
        Some(l) => l,
        None if logs.len() == 1 => &logs[0],
        None => {
            let ids: Vec<&str> = logs.iter().map(|l| l.id.as_str()).collect();
            return Err(Error::Input(format!(
                "the day holds modules {} but not `{}`",
                ids.join(", "),
                entry.module
            )));
        }
    };
    let options = ValidateOptions {
        running_current: args.input.running_current,
        settle: args.input.settle,
    };
    let (v, trace) = validate::validate(&params, log, &options)?;
    if let Some(csv) = &mut csv {
        validate::write_trace(&csv.path, &trace)?;
        csv.written = true;
    }
    let days = args
        .days
        .iter()
        .map(|d| d.display().to_string())
        .collect::<Vec<_>>()
        .join(", ");
    let opt = |x: Option<f64>, unit: &str| {
        x.map_or("not measured".to_string(), |x| format!("{x:>10.4} {unit}"))
    };
    let mut report = format!(
        "Validation of module {} on {days} ({} running segments)\n",
        entry.module, v.segments
    );
    report += &format!(
        "  rows compared: {} of {} running ({} s after each start-up or gap)\n",
        v.compared_rows, v.running_rows, args.input.settle
    );
    report += &format!(
        "  RMSE current   {:>10.4} A   (including start-ups {:.4} A)\n",
        v.current, v.current_with_startups
    );
    report += &format!("  RMSE voltage   {}\n", opt(v.voltage, "V"));
    report += &format!("  RMSE power     {}\n", opt(v.power, "W"));
    report += &format!("  RMSE hydrogen  {}\n", opt(v.h2_flow, "Nl/h"));
    if let Some(csv) = &csv {
        let path = csv.path.display();
        report += &format!(
            "wrote {path} (plot: python -m aem_electrolyser.plot_validation {path} out.png)\n"
        );
    }
    say(&report)
}

fn synthesize(args: SynthesizeArgs) -> Result<(), Error> {
    std::fs::create_dir_all(&args.dir).map_err(|e| Error::Io {
        path: args.dir.clone(),
        message: format!("cannot write here: {e}"),
    })?;
    let spec = CampaignSpec {
        seed: args.seed,
        running_hours: args.hours,
        thermal: args.thermal.then(synthetic::SyntheticThermal::default),
        drift: args.drift.then(synthetic::SyntheticDrift::default),
        ..CampaignSpec::default()
    };
    let days: Vec<synthetic::Day> = (args.skip..args.skip + args.days)
        .map(|d| synthetic::generate_day(&spec, d))
        .collect::<Result<_, _>>()
        .map_err(|e| Error::Input(e.to_string()))?;
    let options = CsvOptions {
        rfc3339: args.rfc3339,
        broken: args.broken,
        seed: args.seed,
        ..CsvOptions::default()
    };
    let written = synthetic::write_campaign(&args.dir, &days, &options).map_err(|e| Error::Io {
        path: args.dir.clone(),
        message: e.to_string(),
    })?;
    let rows: u64 = written.iter().map(|(_, i)| i.rows).sum();
    let p = spec.truth;
    if let Some(t) = &spec.thermal {
        say(&format!(
            "stack temperature from the heat balance: heatCapacity {} J/K, thermalResistance {} K/W, {} cells, air {} °C ± {} K\n",
            t.heat_capacity, t.thermal_resistance, t.cells, t.ambient, t.ambient_swing
        ))?;
    }
    if let Some(d) = &spec.drift {
        say(&format!(
            "voltage drift: reversibleDrift {} V, driftBuildUpTime {} s, driftRecoveryTime {} s, driftPerRunningHour {} V/h, driftPerStart {} V\n",
            d.amplitude, d.build_up_time, d.recovery_time, d.per_running_hour, d.per_start
        ))?;
    }
    say(&format!(
        "wrote {} files, {rows} rows to {}; truth: gain {} A/%, tauZero {} s, tauPole1 {} s, tauPole2 {} s, rampUpLimit {} A/s, voltageIntercept {} V, ohmicResistance {} Ohm, h2Coefficient {} Nl/(h.A)\n",
        written.len(),
        args.dir.display(),
        p.gain, p.tau_zero, p.tau_pole1, p.tau_pole2, p.ramp_up_limit, p.voltage_intercept, p.ohmic_resistance, p.h2_coefficient
    ))
}
