//! Several modules: fitted separately (from one file with a module column), the spread
//! summarised, and the parameter file carries exactly the FMU's names and units.

use std::path::PathBuf;

use aem_identify::columns::ColumnMap;
use aem_identify::read::{self, ReadOptions};
use aem_identify::synthetic::{self, CampaignSpec, CsvOptions};
use aem_identify::{self as identify, FitOptions};
use aem_model::parameter_file::{ParameterFile, Source};
use aem_model::ModuleParameter;
use aem_model::Parameters;

fn module_truth(i: usize) -> Parameters {
    let base = CampaignSpec::test_truth();
    let f = 1.0 + 0.03 * i as f64;
    Parameters {
        gain: base.gain * f,
        tau_zero: base.tau_zero * f,
        tau_pole1: base.tau_pole1 / f,
        ramp_up_limit: base.ramp_up_limit * f,
        voltage_intercept: base.voltage_intercept + 0.3 * i as f64,
        ohmic_resistance: base.ohmic_resistance * f,
        ..base
    }
}

#[test]
fn three_modules_in_one_log_are_fitted_separately_with_their_spread() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("identify_modules");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let ids = ["342A", "A568", "B17"];
    let days = 4;
    for d in 0..days {
        // One file per day holding the three modules' rows one after another.
        let mut text = String::new();
        for (i, id) in ids.iter().enumerate() {
            let spec = CampaignSpec {
                truth: module_truth(i),
                seed: 100 + i as u64,
                ..CampaignSpec::default()
            };
            let day = synthetic::generate_day(&spec, d).unwrap();
            let options = CsvOptions {
                module: Some(("unit".into(), id.to_string())),
                ..CsvOptions::default()
            };
            let (csv, _) = synthetic::to_csv(&day, &options);
            if i > 0 {
                text.push_str(csv.split_once('\n').unwrap().1);
            } else {
                text.push_str(&csv);
            }
        }
        std::fs::write(dir.join(format!("plant_day{d}.csv")), text).unwrap();
    }
    let files = read::expand_inputs(&[dir]).unwrap();
    let options = ReadOptions {
        columns: ColumnMap::with_mappings(&["module=unit"]).unwrap(),
        ..ReadOptions::default()
    };
    let logs = read::read_files(&files, &options, &|| {}).unwrap();
    assert_eq!(logs.iter().map(|l| l.id.as_str()).collect::<Vec<_>>(), ids);
    let fits: Vec<_> = logs
        .iter()
        .map(|l| identify::fit_module(l, &FitOptions::default()))
        .collect();
    for (i, fit) in fits.iter().enumerate() {
        let truth = module_truth(i);
        let p = &fit.parameters;
        // Four days instead of ten: the targets, loosened by √(10/4).
        assert!(
            (p.gain / truth.gain - 1.0).abs() < 0.008,
            "{}: gain {}",
            fit.log.id,
            p.gain
        );
        assert!(
            (p.tau_pole1 / truth.tau_pole1 - 1.0).abs() < 0.05,
            "{}: tauPole1 {}",
            fit.log.id,
            p.tau_pole1
        );
        assert!(
            (p.ramp_up_limit / truth.ramp_up_limit - 1.0).abs() < 0.016,
            "{}: r {}",
            fit.log.id,
            p.ramp_up_limit
        );
        assert!(
            (p.voltage_intercept - truth.voltage_intercept).abs() < 0.1,
            "{}: V0 {}",
            fit.log.id,
            p.voltage_intercept
        );
    }
    // Module-to-module spread of the identified values.
    let spread = identify::spread(&fits);
    let gain = &spread["gain"];
    let gains: Vec<f64> = fits.iter().map(|f| f.parameters.gain).collect();
    assert_eq!(gain.unit, "A/%");
    assert_eq!(
        gain.min,
        gains.iter().copied().fold(f64::INFINITY, f64::min)
    );
    assert!((gain.mean - gains.iter().sum::<f64>() / 3.0).abs() < 1e-12);
    assert!(
        gain.cv_percent > 2.0 && gain.cv_percent < 4.0,
        "cv {}",
        gain.cv_percent
    );
    assert!(
        !spread.contains_key("nominalCurrent"),
        "only identified parameters have a spread"
    );
    let report = identify::report::render(&fits, Some(&spread));
    assert!(report.contains("Spread over 3 modules"), "{report}");
    for id in ids {
        assert!(report.contains(&format!("Module {id}:")), "{report}");
    }

    // The parameter file: exactly the FMU's parameters with its units; round trip.
    let file = identify::parameter_file(&fits);
    let text = serde_json::to_string_pretty(&file).unwrap();
    let back: ParameterFile = serde_json::from_str(&text).unwrap();
    assert!(back
        .module(None)
        .unwrap_err()
        .to_string()
        .contains("3 modules"));
    for (i, id) in ids.iter().enumerate() {
        let entry = back.module(Some(id)).unwrap();
        let names: Vec<(&str, &str)> = entry
            .parameters
            .iter()
            .map(|(n, e)| (n.as_str(), e.unit.as_str()))
            .collect();
        let mut want: Vec<(&str, &str)> = ModuleParameter::ALL
            .iter()
            .map(|p| (p.name(), p.unit()))
            .collect();
        want.sort();
        assert_eq!(names, want);
        assert_eq!(entry.parameters().unwrap(), fits[i].parameters);
        assert_eq!(entry.parameters["gain"].source, Source::Identified);
        assert!(entry.parameters["gain"].standard_error.unwrap() > 0.0);
        assert_eq!(entry.parameters["minSetpoint"].source, Source::Default);
        assert!(
            entry.statistics["dynamics"]["stepsUsed"]["negative"]
                .as_u64()
                .unwrap()
                > 40
        );
    }
    assert!(back.spread.unwrap().contains_key("tauPole2"));
}
