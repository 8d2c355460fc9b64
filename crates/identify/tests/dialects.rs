//! European exports: the same campaign written with `;` or tab between fields and a decimal
//! comma (with Excel's byte order mark and CRLF line ends) is read as such, detected or given
//! with --separator/--decimal, and gives bit for bit the parameters of the comma-separated
//! original; `validate` reads it too. Contradicting options are refused with a message.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use aem_model::parameter_file::ParameterFile;

fn tool(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_aem-identify")).args(args).output().expect("run aem-identify")
}

fn ok(args: &[&str]) -> String {
    let out = tool(args);
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{args:?}: {stdout}\n{stderr}");
    stdout.into_owned()
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
        let mut out = if excel { "\u{feff}".to_string() } else { String::new() };
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
    entry.parameters.iter().map(|(name, p)| (name.clone(), p.value)).collect()
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
    assert!(head.starts_with("\u{feff}time;setpoint;current") && head.contains(",0"), "{}", &head[..80]);

    let fit = |input: &Path, name: &str, extra: &[&str]| {
        let out = dir.join(name);
        let mut args = vec!["fit", s(input), "-o", s(&out)];
        args.extend_from_slice(extra);
        (ok(&args), parameters(&out))
    };
    let (report, want) = fit(&original, "original.json", &[]);
    assert!(!report.contains("read as"), "a plain CSV needs no word on its dialect:\n{report}");
    assert!(want.len() >= 8, "{want:?}");
    for (input, name, extra, read_as) in [
        (&semicolon, "semicolon.json", &[][..], "`;`-separated, decimal comma"),
        (&tab, "tab.json", &[][..], "tab-separated, decimal comma"),
        (&semicolon, "given.json", &["--separator", "semicolon", "--decimal", "comma"][..], "`;`-separated, decimal comma"),
    ] {
        let (report, got) = fit(input, name, extra);
        assert!(report.contains(&format!("read as {read_as}")), "{name}:\n{report}");
        assert_eq!(got, want, "{name}: the parameters of the original, bit for bit");
    }

    let day = semicolon.join("day02.csv");
    let european = ok(&["validate", s(&dir.join("original.json")), s(&day)]);
    let plain = ok(&["validate", s(&dir.join("original.json")), s(&original.join("day02.csv"))]);
    let rmse = |text: &str| text.lines().find(|l| l.contains("RMSE current")).map(str::to_string);
    assert_eq!(rmse(&european), rmse(&plain));
    assert!(rmse(&plain).is_some(), "{plain}");
}

#[test]
fn a_wrong_or_contradicting_dialect_is_refused_with_a_hint() {
    let dir = scratch("dialects_errors");
    let path = dir.join("eu.csv");
    std::fs::write(&path, "time;current\n0;53,35\n1;53,40\n").unwrap();
    let out = tool(&["fit", s(&path), "--separator", "comma"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("no column `time`") && err.contains("read as `,`-separated") && err.contains("--separator"), "{err}");
    let out = tool(&["fit", s(&path), "--separator", "comma", "--decimal", "comma"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("both the separator and the decimal mark"), "{err}");
    let out = tool(&["fit", s(&path), "--decimal", "dot"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("--decimal `dot`"));
    // Given as point, decimal commas are text: every row is skipped, and the message says why.
    let out = tool(&["fit", s(&path), "--decimal", "point"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    for want in ["no usable row", "2 rows read", "non-numeric text 2, first", "eu.csv:2", "read as `;`-separated, decimal point", "--decimal"] {
        assert!(err.contains(want), "missing `{want}`: {err}");
    }
}
