//! Reading operational logs: every bad-row kind counted at its line, gaps, column mapping,
//! RFC 3339 timestamps, directories of daily files, a module column, and errors that name the
//! file and line instead of panicking.

use std::path::{Path, PathBuf};

use aem_identify::columns::{Channel, ColumnMap};
use aem_identify::read::{self, BadRow, ReadOptions};
use aem_identify::synthetic::{self, CampaignSpec, CsvOptions};
use aem_identify::{self as identify, Error, FitOptions, Stage};

fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn every_bad_row_kind_is_counted_at_its_line() {
    let dir = scratch("input_bad_rows");
    let text = "\
time,setpoint,current,voltage
0,80,40.0,42.0
1,80,,42.0
2,80,nan,42.0
3,80,40.0,inf
4,80,forty,42.0
5,80
6,80,40.0,42.0
6,80,40.1,42.0
5.5,80,40.0,42.0
7,80,40.0,42.0
30,80,40.0,42.0
31,80,40.0,42.0
";
    let path = write(&dir, "bad.csv", text);
    let logs = read::read_file(&path, &ReadOptions::default()).unwrap();
    let log = &logs[0];
    let expect = [
        (BadRow::EmptyField, 1, 3),
        (BadRow::NotANumber, 2, 4),
        (BadRow::Text, 1, 6),
        (BadRow::ShortRow, 1, 7),
        (BadRow::DuplicateTime, 1, 9),
        (BadRow::BackwardsTime, 1, 10),
    ];
    for (reason, count, line) in expect {
        assert_eq!(log.bad.count(reason), count, "{}", reason.label());
        let first = log.bad.first(reason).unwrap();
        assert_eq!(
            (first.path.as_path(), first.line),
            (path.as_path(), line),
            "{}",
            reason.label()
        );
    }
    // 7 → 30 s is a gap (the default maximum is 10 s): it splits the rows into two blocks.
    assert_eq!(log.bad.gaps, 1);
    assert_eq!(log.bad.gap_seconds, 23.0);
    assert_eq!(log.bad.first_gap.as_ref().unwrap().line, 12);
    assert_eq!(log.blocks.len(), 2);
    assert_eq!(log.blocks[0].time, vec![0.0, 6.0, 7.0]);
    assert_eq!(log.blocks[1].time, vec![30.0, 31.0]);
    assert_eq!(log.blocks[1].first_line, 12);
    assert_eq!((log.rows_read, log.rows_used), (12, 5));
    // Columns the file does not have are absent, not zero.
    assert!(log.has(Channel::Voltage) && !log.has(Channel::H2Flow));
}

#[test]
fn columns_are_mapped_and_a_missing_required_column_is_a_clear_error() {
    let dir = scratch("input_columns");
    let day = synthetic::generate_day(&CampaignSpec::default(), 0).unwrap();
    let names = [
        "Timestamp",
        "SP_pct",
        "StackCurrent",
        "StackVoltage",
        "T_electrolyte",
        "P_stack",
        "H2_Nlh",
    ]
    .map(String::from);
    let (text, _) = synthetic::to_csv(
        &day,
        &CsvOptions {
            names,
            ..CsvOptions::default()
        },
    );
    let path = write(&dir, "vendor.csv", &text);

    // Without a mapping: no `time` column, an error naming file, line 1 and the fix.
    let err = read::read_file(&path, &ReadOptions::default()).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, Error::Content { line: 1, .. }), "{msg}");
    assert!(
        msg.contains("vendor.csv:1") && msg.contains("--column time=NAME"),
        "{msg}"
    );

    let columns = ColumnMap::with_mappings(&[
        "time=Timestamp",
        "setpoint=SP_pct",
        "current=StackCurrent",
        "voltage=StackVoltage",
        "temperature=T_electrolyte",
        "pressure=P_stack",
        "h2_flow=H2_Nlh",
    ])
    .unwrap();
    let logs = read::read_file(
        &path,
        &ReadOptions {
            columns,
            ..ReadOptions::default()
        },
    )
    .unwrap();
    let log = &logs[0];
    assert_eq!(log.rows_used as usize, day.len());
    assert_eq!(
        log.blocks[0].channel(Channel::Current).unwrap()[500],
        (day.current[500] * 1e4).round() / 1e4
    );
    assert_eq!(
        log.blocks[0].channel(Channel::H2Flow).unwrap().len(),
        day.len()
    );
}

#[test]
fn a_missing_column_disables_only_the_steps_that_need_it() {
    let dir = scratch("input_missing");
    let spec = CampaignSpec::default();
    let days = synthetic::generate_campaign(&spec, 2).unwrap();
    let options = CsvOptions {
        omit: vec!["h2_flow".into(), "temperature".into()],
        ..CsvOptions::default()
    };
    synthetic::write_campaign(&dir, &days, &options).unwrap();
    let files = read::expand_inputs(&[dir]).unwrap();
    let logs = read::read_files(&files, &ReadOptions::default(), &|| {}).unwrap();
    let fit = identify::fit_module(&logs[0], &FitOptions::default());
    assert!(
        matches!(&fit.hydrogen, Stage::Skipped(why) if why.contains("h2_flow")),
        "{:?}",
        fit.hydrogen
    );
    let Stage::Done(p) = &fit.polarisation else {
        panic!("{:?}", fit.polarisation)
    };
    assert!(
        p.notes.iter().any(|n| n.contains("temperature")),
        "{:?}",
        p.notes
    );
    assert!(fit.dynamics.done().is_some());
    // The hydrogen coefficient stays the model description's start value, marked default.
    let file = identify::parameter_file(std::slice::from_ref(&fit));
    let h2 = &file.modules[0].parameters["h2Coefficient"];
    assert_eq!(h2.value, 9.6174);
    assert_eq!(h2.source, aem_model::parameter_file::Source::Default);
}

#[test]
fn rfc3339_timestamps_read_like_seconds() {
    let dir = scratch("input_rfc3339");
    let day = synthetic::generate_day(&CampaignSpec::default(), 3).unwrap();
    let seconds = write(
        &dir,
        "s.csv",
        &synthetic::to_csv(&day, &CsvOptions::default()).0,
    );
    let stamped = write(
        &dir,
        "t.csv",
        &synthetic::to_csv(
            &day,
            &CsvOptions {
                rfc3339: true,
                ..CsvOptions::default()
            },
        )
        .0,
    );
    let first_line = std::fs::read_to_string(&stamped)
        .unwrap()
        .lines()
        .nth(1)
        .unwrap()
        .to_string();
    assert!(
        first_line.starts_with("2025-10-09T06:00:00Z,"),
        "{first_line}"
    );
    let a = read::read_file(&seconds, &ReadOptions::default()).unwrap();
    let b = read::read_file(&stamped, &ReadOptions::default()).unwrap();
    assert_eq!(a[0].blocks[0].time, b[0].blocks[0].time);
    assert_eq!(a[0].blocks[0].channels, b[0].blocks[0].channels);
    // An offset is honoured: 08:00:01+02:00 is 06:00:01Z.
    let offset = write(
        &dir,
        "o.csv",
        "time,current\n2025-10-09T08:00:01+02:00,1\n2025-10-09T06:00:02Z,1\n",
    );
    let c = read::read_file(&offset, &ReadOptions::default()).unwrap();
    assert_eq!(
        c[0].blocks[0].time,
        vec![day.time[0] + 1.0, day.time[0] + 2.0]
    );
}

#[test]
fn a_module_column_splits_one_file_into_modules() {
    let dir = scratch("input_module_column");
    let text = "time,current,unit\n0,1,A\n0,2,B\n1,1,A\n1,2,B\n2,1,A\n,2,B\n3,1,\n";
    let path = write(&dir, "two.csv", text);
    let columns = ColumnMap::with_mappings(&["module=unit"]).unwrap();
    let logs = read::read_file(
        &path,
        &ReadOptions {
            columns,
            ..ReadOptions::default()
        },
    )
    .unwrap();
    let ids: Vec<&str> = logs.iter().map(|l| l.id.as_str()).collect();
    assert_eq!(ids, ["A", "B", "module"]);
    assert_eq!(logs[0].blocks[0].time, vec![0.0, 1.0, 2.0]);
    assert_eq!(logs[1].blocks[0].time, vec![0.0, 1.0]);
    assert_eq!(logs[1].bad.count(BadRow::EmptyField), 1);
    // A row without a module id is counted against the default module.
    assert_eq!(logs[2].bad.count(BadRow::EmptyField), 1);
    assert_eq!(logs.iter().map(|l| l.rows_read).sum::<u64>(), 7);
}

#[test]
fn unreadable_inputs_are_errors_with_the_path_not_panics() {
    let dir = scratch("input_errors");
    let missing = dir.join("nope.csv");
    let err = read::expand_inputs(std::slice::from_ref(&missing))
        .unwrap_err()
        .to_string();
    assert!(err.contains("nope.csv"), "{err}");
    let empty_dir = dir.join("empty");
    std::fs::create_dir_all(&empty_dir).unwrap();
    let err = read::expand_inputs(&[empty_dir]).unwrap_err().to_string();
    assert!(err.contains("no .csv file"), "{err}");
    let empty = write(&dir, "empty.csv", "");
    let err = read::read_file(&empty, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("empty.csv:1"), "{err}");
    // Binary garbage: no time column in its "header", an error, not a panic.
    let garbage = dir.join("garbage.csv");
    std::fs::write(
        &garbage,
        [0xffu8, 0xfe, 0x00, b',', b'\n', 0x80, b'"', b'\n'],
    )
    .unwrap();
    assert!(read::read_file(&garbage, &ReadOptions::default()).is_err());
    // A valid header with garbage rows: every row counted, nothing used, no panic.
    let rows = write(
        &dir,
        "rows.csv",
        "time,current\n\u{0}\u{1},x\n\"unterminated,1\n1e999,2\n",
    );
    let logs = read::read_file(&rows, &ReadOptions::default()).unwrap();
    assert_eq!(logs[0].rows_used, 0);
    assert_eq!(logs[0].rows_read, logs[0].bad.total());
    // Fitting data without any step: every stage explains why it did not run.
    let fit = identify::fit_module(&logs[0], &FitOptions::default());
    assert!(
        fit.dynamics.done().is_none()
            && fit.polarisation.done().is_none()
            && fit.hydrogen.done().is_none()
    );
}
