//! The module parameter file (`moduleParameterFile`) with any bytes: parsed as the FMU parses
//! it, every module's set validated over the defaults, and a hub of the accepted sets built
//! and stepped, as the FMU does at initialisation.
#![no_main]

use std::path::Path;

use aem_model::parameter_file::ParameterFile;
use aem_model::{Parameters, PlantSettings};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(file) = ParameterFile::parse(data, Path::new("fuzz.json")) else {
        return;
    };
    let _ = file.module(None);
    let sets: Vec<Parameters> = file
        .modules
        .iter()
        .filter_map(|m| m.parameters().ok())
        .take(16)
        .collect();
    if sets.is_empty() {
        return;
    }
    let settings = PlantSettings {
        n_modules: 2 * sets.len() as i32,
        dispatch: 2,
        below_minimum: 1,
        ..PlantSettings::default()
    };
    let Ok(config) = settings.config() else {
        return;
    };
    let Ok(mut plant) =
        aem_model::Plant::new(Parameters::default(), &config, Some(&sets), 80.0, 0.0)
    else {
        return;
    };
    for (setpoint, h) in [(100.0, 10.0), (30.0, 400.0), (65.0, 30.0)] {
        let _ = plant.step(&config, setpoint, 0.0, 0.0, h);
    }
});
