//! aem-identify's CSV reader with any bytes (header, separators, timestamps, broken rows);
//! the first byte chooses the default column names or a `unit` column of module ids (bit 0)
//! and the separator and decimal mark: detected, or given (bits 1-3). Every log read is then
//! split into segments and steps as the fit does.
#![no_main]

use std::path::Path;

use aem_identify::columns::ColumnMap;
use aem_identify::read::{read_csv, DecimalMark, DialectChoice, ReadOptions};
use aem_identify::segments::{find_steps, running_segments, StepOptions};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((choice, text)) = data.split_first() else {
        return;
    };
    let mut options = ReadOptions::default();
    if choice & 1 == 1 {
        options.columns = ColumnMap::with_mappings(&["module=unit".to_string()]).unwrap();
    }
    options.dialect = DialectChoice {
        separator: [None, Some(b';'), Some(b'\t'), Some(b',')][usize::from(choice >> 1 & 3)],
        decimal: (choice & 8 == 8).then_some(DecimalMark::Comma),
    };
    if let Ok(logs) = read_csv(text, Path::new("fuzz.csv"), &options) {
        let steps = StepOptions::default();
        for log in &logs {
            let _ = find_steps(running_segments(log, &steps), &steps);
        }
    }
});
