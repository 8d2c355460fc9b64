//! The FMU's own messages (its logger callback, which the `fmi` crate forwards to `log`):
//! warnings, discards and errors are kept to explain a failed scenario and to report
//! warnings beside the KPIs.

use std::sync::Mutex;

use log::{Level, Metadata, Record};

/// How many messages are kept; later ones are counted only.
const KEPT: usize = 50;

struct Collector {
    messages: Mutex<(Vec<String>, usize)>,
}

static COLLECTOR: Collector = Collector {
    messages: Mutex::new((Vec::new(), 0)),
};

impl log::Log for Collector {
    fn enabled(&self, metadata: &Metadata) -> bool {
        metadata.level() <= Level::Warn || metadata.level() == Level::Trace
    }

    fn log(&self, record: &Record) {
        // The fmi crate's callback marks the FMU's messages with module path "logger"; its
        // own tracing (and fmi2Discard, mapped to Trace) carries other paths or Trace.
        if record.module_path() != Some("logger") || !self.enabled(record.metadata()) {
            return;
        }
        if let Ok(mut guard) = self.messages.lock() {
            let (kept, dropped) = &mut *guard;
            if kept.len() < KEPT {
                let level = if record.level() == Level::Trace {
                    "DISCARD"
                } else {
                    record.level().as_str()
                };
                kept.push(format!("{level} {}: {}", record.target(), record.args()));
            } else {
                *dropped += 1;
            }
        }
    }

    fn flush(&self) {}
}

/// Routes the `log` records to the collector (once per process).
pub fn install() {
    // A second call (or another logger) leaves the first in place, which is what we want.
    if log::set_logger(&COLLECTOR).is_ok() {
        log::set_max_level(log::LevelFilter::Trace);
    }
}

/// The messages so far (and how many more were dropped), emptying the collector.
pub fn take() -> (Vec<String>, usize) {
    COLLECTOR
        .messages
        .lock()
        .map(|mut g| std::mem::take(&mut *g))
        .unwrap_or_default()
}
