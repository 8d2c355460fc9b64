//! The `aem-identify` command line: fit a directory and write the parameter file, validate on
//! a held-out day with a CSV trace, one file set per module, errors (exit status 1, a
//! message naming the file) instead of panics, a closed stdout, output paths checked
//! before the work, and European exports: the same campaign written with `;` or tab between
//! fields and a decimal comma (with Excel's byte order mark and CRLF line ends) is read as
//! such, detected or given with --separator/--decimal, and gives bit for bit the parameters of
//! the comma-separated original; contradicting options are refused with a message.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use aem_identify::validate::TRACE_HEADER;
use aem_model::parameter_file::ParameterFile;

fn tool(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_aem-identify"))
        .args(args)
        .output()
        .expect("run aem-identify")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn ok(args: &[&str]) -> String {
    let out = tool(args);
    assert!(
        out.status.success(),
        "{args:?}: {}\n{}",
        text(&out.stdout),
        text(&out.stderr)
    );
    text(&out.stdout)
}

/// Exit status 2 (a bad argument, found before any work) with one line containing `want`.
fn refused(args: &[&str], want: &str) {
    let out = tool(args);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(
        err.starts_with("aem-identify: error:")
            && err.contains(want)
            && err.trim().lines().count() == 1,
        "{args:?}: {err}"
    );
}

/// Exit status 1 with a message containing `want`, and no panic.
fn fails(args: &[&str], want: &str) {
    let out = tool(args);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    assert!(
        err.contains("aem-identify: error:") && err.contains(want),
        "{args:?}: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn fit_then_validate_on_a_held_out_day() {
    let dir = scratch("cli_fit");
    let (train, held) = (dir.join("train"), dir.join("held"));
    ok(&[
        "synthesize",
        s(&train),
        "--days",
        "3",
        "--broken",
        "--rfc3339",
    ]);
    ok(&["synthesize", s(&held), "--days", "1", "--skip", "3"]);
    let params = dir.join("params.json");
    let out = tool(&["fit", s(&train), "-o", s(&params), "--timings"]);
    let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
    assert!(out.status.success(), "{stdout}{stderr}");
    for want in [
        "Voltage intercept V0",
        "τz/τp2",
        "corr(τz, τp2)",
        "Positive ramp-rate limit",
        "Faraday efficiency",
        "Structure check",
        "duplicated timestamp 6",
        "gaps: 3",
    ] {
        assert!(stdout.contains(want), "missing `{want}`:\n{stdout}");
    }
    assert!(stderr.contains("timing: total"), "{stderr}");
    // No progress bar when stderr is not a terminal.
    assert!(!stderr.contains('['), "{stderr}");
    let file = ParameterFile::load(&params).unwrap();
    let entry = file.module(None).unwrap();
    assert_eq!(entry.parameters["gain"].unit, "A/%");
    assert_eq!(entry.parameters["h2Coefficient"].unit, "Nl/(h.A)");
    let gain = entry.parameters["gain"].value;
    assert!((gain / 0.512 - 1.0).abs() < 0.01, "gain {gain}");

    let trace = dir.join("validation.csv");
    let out = ok(&[
        "validate",
        s(&params),
        s(&held.join("day01.csv")),
        "--csv",
        s(&trace),
    ]);
    assert!(out.contains("RMSE current"), "{out}");
    let rmse: f64 = out
        .lines()
        .find(|l| l.contains("RMSE current"))
        .and_then(|l| l.split_whitespace().nth(2))
        .and_then(|v| v.parse().ok())
        .unwrap();
    assert!(rmse < 0.2, "held-out current RMSE {rmse}\n{out}");
    let csv = std::fs::read_to_string(&trace).unwrap();
    assert_eq!(csv.lines().next(), Some(TRACE_HEADER));
    assert!(csv.lines().count() > 25_000);
}

#[test]
fn one_file_set_per_module() {
    let dir = scratch("cli_modules");
    let (a, b) = (dir.join("a"), dir.join("b"));
    ok(&["synthesize", s(&a), "--days", "2", "--seed", "1"]);
    ok(&["synthesize", s(&b), "--days", "2", "--seed", "2"]);
    let params = dir.join("p.json");
    let arg_a = format!("A={}", s(&a));
    let arg_b = format!("B={}", s(&b));
    let out = ok(&[
        "fit",
        "--module",
        &arg_a,
        "--module",
        &arg_b,
        "-o",
        s(&params),
    ]);
    assert!(
        out.contains("Module A:")
            && out.contains("Module B:")
            && out.contains("Spread over 2 modules"),
        "{out}"
    );
    let file = ParameterFile::load(&params).unwrap();
    assert_eq!(file.modules.len(), 2);
    // Validate needs to know which module.
    let day = a.join("day01.csv");
    fails(
        &["validate", s(&params), s(&day)],
        "choose one with --module",
    );
    ok(&["validate", s(&params), s(&day), "--module", "A"]);
}

#[test]
fn bad_input_is_an_error_naming_the_file() {
    let dir = scratch("cli_errors");
    let missing = dir.join("missing.csv");
    refused(&["fit", s(&missing)], "missing.csv");
    refused(&["validate", s(&missing)], "missing.csv");
    refused(&["synthesize", s(&dir), "--days", "0"], "--days 0");
    refused(&["synthesize", s(&dir), "--hours", "30"], "--hours 30");
    refused(&["fit", "--sperator", ";"], "did you mean");
    refused(&["fitt"], "did you mean 'fit'?");
    let data = dir.join("data.csv");
    std::fs::write(&data, "t,I\n0,1\n").unwrap();
    fails(&["fit", s(&data)], "data.csv:1: no column `time`");
    refused(
        &["fit", s(&data), "--column", "amps=I"],
        "unknown key `amps`",
    );
    refused(&["fit", "--module", "noequals"], "ID=PATH");
    let params = dir.join("p.json");
    std::fs::write(&params, r#"{"generator":"x","modules":[{"module":"m","parameters":{"gainz":{"value":1,"unit":"A/%","source":"identified"}}}]}"#).unwrap();
    fails(
        &[
            "validate",
            s(&params),
            s(&data),
            "--column",
            "time=t",
            "--column",
            "current=I",
        ],
        "unknown parameter `gainz`",
    );
    std::fs::write(&params, "{ not json").unwrap();
    fails(
        &["validate", s(&params), s(&data)],
        "p.json:1: not a parameter file",
    );
    // Usage errors of clap's: status 2, one line.
    refused(&["fit", "--cells", "many"], "--cells");
}

/// Runs the tool with its stdout a pipe whose reading end is closed at once (as `| head`
/// does after its lines): the command's report meets a closed pipe.
fn with_closed_stdout(args: &[&str]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_aem-identify"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run aem-identify");
    drop(child.stdout.take());
    child.wait_with_output().expect("wait for aem-identify")
}

#[test]
fn a_closed_stdout_ends_every_command_quietly_after_its_files_are_written() {
    let dir = scratch("cli_closed_stdout");
    let (train, held) = (dir.join("train"), dir.join("held"));
    let (params, trace) = (dir.join("params.json"), dir.join("trace.csv"));
    let commands: [Vec<&str>; 4] = [
        vec!["synthesize", s(&train), "--days", "2"],
        vec!["synthesize", s(&held), "--days", "1", "--skip", "2"],
        vec!["fit", s(&train), "-o", s(&params), "--timings"],
        vec!["validate", s(&params), s(&held), "--csv", s(&trace)],
    ];
    for args in &commands {
        let out = with_closed_stdout(args);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{args:?}: {err}");
        assert!(
            !err.contains("panicked") && !err.contains("Broken pipe"),
            "{args:?}: {err}"
        );
    }
    assert_eq!(std::fs::read_dir(&train).unwrap().count(), 2);
    assert!(
        ParameterFile::load(&params).unwrap().module(None).is_ok(),
        "params.json written in full"
    );
    assert_eq!(
        std::fs::read_to_string(&trace).unwrap().lines().next(),
        Some(TRACE_HEADER)
    );
}

#[test]
fn an_output_path_that_cannot_be_written_is_refused_before_the_work() {
    let dir = scratch("cli_output_paths");
    let nowhere = dir.join("no-such-dir").join("params.json");
    // The input is unusable too: the output path is checked before it is read.
    let unusable = dir.join("unusable.csv");
    std::fs::write(&unusable, "t,I\n0,1\n").unwrap();
    fails(&["fit", s(&unusable), "-o", s(&nowhere)], "no-such-dir");
    fails(&["fit", s(&unusable), "-o", s(&dir)], "is a directory");
    fails(
        &["validate", s(&unusable), s(&unusable), "--csv", s(&nowhere)],
        "no-such-dir",
    );
    // A file made to prove the path is removed again when the work fails.
    let fresh = dir.join("fresh.json");
    fails(&["fit", s(&unusable), "-o", s(&fresh)], "unusable.csv");
    assert!(!fresh.exists(), "an empty result file was left behind");
    let blocked = dir.join("file");
    std::fs::write(&blocked, "").unwrap();
    fails(
        &["synthesize", s(&blocked.join("sub"))],
        "cannot write here",
    );
}

/// Rewrites every `*.csv` of `from` into `to` with `separator` and a decimal comma; `excel`
/// adds a UTF-8 byte order mark and CRLF line ends.
fn europeanise(from: &Path, to: &Path, separator: char, excel: bool) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|x| x != "csv") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        let end = if excel { "\r\n" } else { "\n" };
        let mut out = if excel {
            "\u{feff}".to_string()
        } else {
            String::new()
        };
        for line in text.lines() {
            let fields: Vec<String> = line.split(',').map(|f| f.replace('.', ",")).collect();
            out += &fields.join(&separator.to_string());
            out += end;
        }
        std::fs::write(to.join(path.file_name().unwrap()), out).unwrap();
    }
}

/// The fitted parameters of a parameter file: (name, value) in file order.
fn parameters(path: &Path) -> Vec<(String, f64)> {
    let file = ParameterFile::load(path).unwrap();
    let entry = file.module(None).unwrap();
    entry
        .parameters
        .iter()
        .map(|(name, p)| (name.clone(), p.value))
        .collect()
}

#[test]
fn semicolon_and_tab_exports_with_decimal_commas_fit_like_the_original() {
    let dir = scratch("dialects_fit");
    let original = dir.join("original");
    ok(&["synthesize", s(&original), "--days", "2", "--seed", "7"]);
    let (semicolon, tab) = (dir.join("semicolon"), dir.join("tab"));
    europeanise(&original, &semicolon, ';', true);
    europeanise(&original, &tab, '\t', false);
    let head = std::fs::read_to_string(semicolon.join("day01.csv")).unwrap();
    assert!(
        head.starts_with("\u{feff}time;setpoint;current") && head.contains(",0"),
        "{}",
        &head[..80]
    );

    let fit = |input: &Path, name: &str, extra: &[&str]| {
        let out = dir.join(name);
        let mut args = vec!["fit", s(input), "-o", s(&out)];
        args.extend_from_slice(extra);
        (ok(&args), parameters(&out))
    };
    let (report, want) = fit(&original, "original.json", &[]);
    assert!(
        !report.contains("read as"),
        "a plain CSV needs no word on its dialect:\n{report}"
    );
    assert!(want.len() >= 8, "{want:?}");
    for (input, name, extra, read_as) in [
        (
            &semicolon,
            "semicolon.json",
            &[][..],
            "`;`-separated, decimal comma",
        ),
        (&tab, "tab.json", &[][..], "tab-separated, decimal comma"),
        (
            &semicolon,
            "given.json",
            &["--separator", "semicolon", "--decimal", "comma"][..],
            "`;`-separated, decimal comma",
        ),
    ] {
        let (report, got) = fit(input, name, extra);
        assert!(
            report.contains(&format!("read as {read_as}")),
            "{name}:\n{report}"
        );
        assert_eq!(
            got, want,
            "{name}: the parameters of the original, bit for bit"
        );
    }

    let day = semicolon.join("day02.csv");
    let european = ok(&["validate", s(&dir.join("original.json")), s(&day)]);
    let plain = ok(&[
        "validate",
        s(&dir.join("original.json")),
        s(&original.join("day02.csv")),
    ]);
    let rmse = |text: &str| {
        text.lines()
            .find(|l| l.contains("RMSE current"))
            .map(str::to_string)
    };
    assert_eq!(rmse(&european), rmse(&plain));
    assert!(rmse(&plain).is_some(), "{plain}");
}

#[test]
fn a_wrong_or_contradicting_dialect_is_refused_with_a_hint() {
    let dir = scratch("dialects_errors");
    let path = dir.join("eu.csv");
    std::fs::write(&path, "time;current\n0;53,35\n1;53,40\n").unwrap();
    let out = tool(&["fit", s(&path), "--separator", "comma"]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("no column `time`")
            && err.contains("read as `,`-separated")
            && err.contains("--separator"),
        "{err}"
    );
    fails(
        &[
            "fit",
            s(&path),
            "--separator",
            "comma",
            "--decimal",
            "comma",
        ],
        "both the separator and the decimal mark",
    );
    refused(&["fit", s(&path), "--decimal", "dot"], "--decimal `dot`");
    // Given as point, decimal commas are text: every row is skipped, and the message says why.
    let out = tool(&["fit", s(&path), "--decimal", "point"]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    for want in [
        "no usable row",
        "2 rows read",
        "non-numeric text 2, first",
        "eu.csv:2",
        "read as `;`-separated, decimal point",
        "--decimal",
    ] {
        assert!(err.contains(want), "missing `{want}`: {err}");
    }
}
