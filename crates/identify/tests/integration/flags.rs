//! A parameter the data cannot determine is flagged, and the others are still identified.

use aem_identify::read::{self, ReadOptions};
use aem_identify::synthetic::{self, CampaignSpec, CsvOptions};
use aem_identify::{self as identify, FitOptions};

#[test]
fn a_rate_limit_that_never_binds_is_flagged_not_invented() {
    // 50 A/s: far faster than any step's rise, so the data say nothing about it.
    let truth = aem_model::Parameters {
        ramp_up_limit: 50.0,
        ..CampaignSpec::test_truth()
    };
    let spec = CampaignSpec {
        truth,
        ..CampaignSpec::default()
    };
    let days = synthetic::generate_campaign(&spec, 2).unwrap();
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("identify_flags");
    let _ = std::fs::remove_dir_all(&dir);
    synthetic::write_campaign(&dir, &days, &CsvOptions::default()).unwrap();
    let files = read::expand_inputs(&[dir]).unwrap();
    let logs = read::read_files(&files, &ReadOptions::default(), &|| {}).unwrap();
    let fit = identify::fit_module(&logs[0], &FitOptions::default());
    let d = fit.dynamics.done().expect("the linear part is identified");
    assert!(
        (d.gain.value / truth.gain - 1.0).abs() < 0.01,
        "gain {}",
        d.gain.value
    );
    assert!(fit.is_poorly_determined("rampUpLimit"), "ramp {:?}", d.ramp);
    assert!(!fit.is_poorly_determined("gain"));
    let report = identify::report::render(std::slice::from_ref(&fit), None);
    assert!(
        report.contains("Poorly determined") && report.contains("rampUpLimit"),
        "{report}"
    );
    let file = identify::parameter_file(std::slice::from_ref(&fit));
    let ramp = &file.modules[0].parameters["rampUpLimit"];
    assert_ne!(ramp.poorly_determined, Some(false), "{ramp:?}");
}
