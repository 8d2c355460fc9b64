//! aem-identify's CSV reader with any bytes (header, separators, timestamps, broken rows),
//! with the default column names and with a module column; every log read is then split into
//! segments and steps as the fit does.
#![no_main]

use std::path::Path;

use aem_identify::columns::ColumnMap;
use aem_identify::read::{read_csv, ReadOptions};
use aem_identify::segments::{find_steps, running_segments, StepOptions};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let plain = ReadOptions::default();
    let with_module = ReadOptions {
        columns: ColumnMap::with_mappings(&["module=unit".to_string()]).unwrap(),
        ..ReadOptions::default()
    };
    for options in [plain, with_module] {
        if let Ok(logs) = read_csv(data, Path::new("fuzz.csv"), &options) {
            let steps = StepOptions::default();
            for log in &logs {
                let _ = find_steps(running_segments(log, &steps), &steps);
            }
        }
    }
});
