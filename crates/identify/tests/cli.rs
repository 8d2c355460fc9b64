//! The `aem-identify` command line: fit a directory and write the parameter file, validate on
//! a held-out day with a CSV trace, one file set per module, errors (exit status 1, a
//! message naming the file) instead of panics, a closed stdout, and output paths checked
//! before the work.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use aem_model::parameter_file::ParameterFile;
use aem_identify::validate::TRACE_HEADER;

fn tool(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_aem-identify")).args(args).output().expect("run aem-identify")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn ok(args: &[&str]) -> String {
    let out = tool(args);
    assert!(out.status.success(), "{args:?}: {}\n{}", text(&out.stdout), text(&out.stderr));
    text(&out.stdout)
}

/// Exit status 1 with a message containing `want`, and no panic.
fn fails(args: &[&str], want: &str) {
    let out = tool(args);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    assert!(err.contains("aem-identify: error:") && err.contains(want), "{args:?}: {err}");
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
    ok(&["synthesize", s(&train), "--days", "3", "--broken", "--rfc3339"]);
    ok(&["synthesize", s(&held), "--days", "1", "--skip", "3"]);
    let params = dir.join("params.json");
    let out = tool(&["fit", s(&train), "-o", s(&params), "--timings"]);
    let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
    assert!(out.status.success(), "{stdout}{stderr}");
    for want in ["Voltage intercept V0", "τz/τp2", "corr(τz, τp2)", "Positive ramp-rate limit", "Faraday efficiency", "Structure check", "duplicated timestamp 6", "gaps: 3"] {
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
    let out = ok(&["validate", s(&params), s(&held.join("day01.csv")), "--csv", s(&trace)]);
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
    let out = ok(&["fit", "--module", &arg_a, "--module", &arg_b, "-o", s(&params)]);
    assert!(out.contains("Module A:") && out.contains("Module B:") && out.contains("Spread over 2 modules"), "{out}");
    let file = ParameterFile::load(&params).unwrap();
    assert_eq!(file.modules.len(), 2);
    // Validate needs to know which module.
    let day = a.join("day01.csv");
    fails(&["validate", s(&params), s(&day)], "choose one with --module");
    ok(&["validate", s(&params), s(&day), "--module", "A"]);
}

#[test]
fn bad_input_is_an_error_naming_the_file() {
    let dir = scratch("cli_errors");
    let missing = dir.join("missing.csv");
    fails(&["fit", s(&missing)], "missing.csv");
    let data = dir.join("data.csv");
    std::fs::write(&data, "t,I\n0,1\n").unwrap();
    fails(&["fit", s(&data)], "data.csv:1: no column `time`");
    fails(&["fit", s(&data), "--column", "amps=I"], "unknown key `amps`");
    fails(&["fit", "--module", "noequals"], "ID=PATH");
    let params = dir.join("p.json");
    std::fs::write(&params, r#"{"generator":"x","modules":[{"module":"m","parameters":{"gainz":{"value":1,"unit":"A/%","source":"identified"}}}]}"#).unwrap();
    fails(&["validate", s(&params), s(&data), "--column", "time=t", "--column", "current=I"], "unknown parameter `gainz`");
    std::fs::write(&params, "{ not json").unwrap();
    fails(&["validate", s(&params), s(&data)], "p.json:1: not a parameter file");
    // Usage errors are clap's (status 2).
    assert_eq!(tool(&["fit", "--cells", "many"]).status.code(), Some(2));
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
        assert!(!err.contains("panicked") && !err.contains("Broken pipe"), "{args:?}: {err}");
    }
    assert_eq!(std::fs::read_dir(&train).unwrap().count(), 2);
    assert!(ParameterFile::load(&params).unwrap().module(None).is_ok(), "params.json written in full");
    assert_eq!(std::fs::read_to_string(&trace).unwrap().lines().next(), Some(TRACE_HEADER));
}

#[test]
fn an_output_path_that_cannot_be_written_is_refused_before_the_work() {
    let dir = scratch("cli_output_paths");
    let nowhere = dir.join("no-such-dir").join("params.json");
    // The input does not exist either: the output path is checked first.
    fails(&["fit", s(&dir.join("missing.csv")), "-o", s(&nowhere)], "no-such-dir");
    fails(&["fit", s(&dir.join("missing.csv")), "-o", s(&dir)], "is a directory");
    fails(&["validate", s(&dir.join("missing.json")), s(&dir), "--csv", s(&nowhere)], "no-such-dir");
    // A file made to prove the path is removed again when the work fails.
    let fresh = dir.join("fresh.json");
    fails(&["fit", s(&dir.join("missing.csv")), "-o", s(&fresh)], "missing.csv");
    assert!(!fresh.exists(), "an empty result file was left behind");
    let blocked = dir.join("file");
    std::fs::write(&blocked, "").unwrap();
    fails(&["synthesize", s(&blocked.join("sub"))], "cannot write here");
}
