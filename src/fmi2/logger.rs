//! The importer's logger callback with the standard log categories.
//!
//! Warnings, discards and errors always reach the logger (category logStatusX); informative
//! messages (category logEvents) only when debug logging is on and that category is enabled.

use std::ffi::CString;

use fmi_sys::fmi2 as sys;

use crate::model_description::LOG_CATEGORIES;

/// Log category of model events (clamping, initialisation, reset).
pub const LOG_EVENTS: &str = "logEvents";
/// The category that stands for all others in fmi2SetDebugLogging.
const LOG_ALL: &str = "logAll";

/// The importer's logger, the instance's name and the enabled categories.
pub struct Logger {
    callback: sys::fmi2CallbackLogger,
    environment: sys::fmi2ComponentEnvironment,
    instance_name: CString,
    /// Per entry of LOG_CATEGORIES: is debug logging on for it.
    enabled: Vec<bool>,
    /// loggingOn of fmi2Instantiate, restored by fmi2Reset.
    logging_on_at_instantiation: bool,
}

impl Logger {
    /// A logger that forwards to `callback` (which may be absent).
    pub fn new(
        callback: sys::fmi2CallbackLogger,
        environment: sys::fmi2ComponentEnvironment,
        instance_name: CString,
        debug_logging: bool,
    ) -> Self {
        Logger {
            callback,
            environment,
            instance_name,
            enabled: vec![debug_logging; LOG_CATEGORIES.len()],
            logging_on_at_instantiation: debug_logging,
        }
    }

    /// Debug logging back to what fmi2Instantiate asked for.
    pub fn restore_instantiation_logging(&mut self) {
        let on = self.logging_on_at_instantiation;
        self.enabled.iter_mut().for_each(|e| *e = on);
    }

    /// The instance name given to fmi2Instantiate.
    pub fn instance_name(&self) -> &str {
        self.instance_name.to_str().unwrap_or("?")
    }

    /// fmi2SetDebugLogging (FMI 2.0, section 2.1.5): `on` with no categories enables all,
    /// `on` with categories enables exactly those, `off` with no categories disables all, `off`
    /// with categories disables those. `logAll` stands for every category. Unknown names are
    /// returned as an error and change nothing.
    pub fn set_debug_logging(&mut self, on: bool, categories: &[String]) -> Result<(), String> {
        let mut named = vec![false; LOG_CATEGORIES.len()];
        for name in categories {
            match LOG_CATEGORIES.iter().position(|c| c == name) {
                Some(_) if name == LOG_ALL => named.iter_mut().for_each(|n| *n = true),
                Some(i) => named[i] = true,
                None => {
                    return Err(format!(
                        "unknown log category \"{name}\"; known: {}",
                        LOG_CATEGORIES.join(", ")
                    ))
                }
            }
        }
        if categories.is_empty() {
            self.enabled.iter_mut().for_each(|e| *e = on);
        } else if on {
            self.enabled = named;
        } else {
            for (e, n) in self.enabled.iter_mut().zip(named) {
                *e &= !n;
            }
        }
        Ok(())
    }

    fn category_enabled(&self, category: &str) -> bool {
        LOG_CATEGORIES
            .iter()
            .zip(&self.enabled)
            .any(|(c, on)| *on && *c == category)
    }

    /// An informative message (fmi2OK) in `category`, if enabled.
    pub fn info(&self, category: &str, message: &str) {
        if self.category_enabled(category) {
            self.emit(sys::fmi2Status_fmi2OK, category, message);
        }
    }

    /// A warning; always forwarded.
    pub fn warning(&self, message: &str) {
        self.emit(sys::fmi2Status_fmi2Warning, "logStatusWarning", message);
    }

    /// A failure with its status; always forwarded.
    pub fn failure(&self, status: sys::fmi2Status, message: &str) {
        let category = match status {
            sys::fmi2Status_fmi2Discard => "logStatusDiscard",
            sys::fmi2Status_fmi2Fatal => "logStatusFatal",
            _ => "logStatusError",
        };
        self.emit(status, category, message);
    }

    fn emit(&self, status: sys::fmi2Status, category: &str, message: &str) {
        // SAFETY: the callback and environment are the importer's, given to fmi2Instantiate.
        unsafe {
            emit_to(
                self.callback,
                self.environment,
                &self.instance_name,
                status,
                category,
                message,
            )
        };
    }
}

/// Calls an importer's logger with format "%s", so `message` is never parsed as a format.
///
/// # Safety
/// `callback` must be absent or a logger function the importer gave for `environment`.
pub unsafe fn emit_to(
    callback: sys::fmi2CallbackLogger,
    environment: sys::fmi2ComponentEnvironment,
    instance_name: &CString,
    status: sys::fmi2Status,
    category: &str,
    message: &str,
) {
    let Some(log) = callback else { return };
    let category = c_string(category);
    let message = c_string(message);
    // SAFETY: the importer gave us this function for exactly this call; all strings are
    // NUL-terminated and live across the call; "%s" consumes exactly one char* argument.
    unsafe {
        log(
            environment,
            instance_name.as_ptr(),
            status,
            category.as_ptr(),
            c"%s".as_ptr(),
            message.as_ptr(),
        );
    }
}

/// A C string from any text; interior NULs become spaces.
pub fn c_string(text: &str) -> CString {
    CString::new(text.replace('\0', " ")).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn logger(on: bool) -> Logger {
        Logger::new(None, std::ptr::null_mut(), c_string("t"), on)
    }

    fn names(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn set_debug_logging_follows_the_standard() {
        let mut l = logger(true);
        assert!(l.category_enabled(LOG_EVENTS));
        l.set_debug_logging(false, &names(&[LOG_EVENTS])).unwrap();
        assert!(
            !l.category_enabled(LOG_EVENTS),
            "switching a category off wins over logging on"
        );
        l.set_debug_logging(true, &names(&["logStatusWarning"]))
            .unwrap();
        assert!(
            l.category_enabled("logStatusWarning") && !l.category_enabled(LOG_EVENTS),
            "a list enables exactly those"
        );
        l.set_debug_logging(true, &[]).unwrap();
        assert!(l.category_enabled(LOG_EVENTS));
        l.set_debug_logging(false, &names(&[LOG_ALL])).unwrap();
        assert!(!l.category_enabled(LOG_EVENTS) && !l.category_enabled("logStatusError"));
        let before = l.enabled.clone();
        assert!(l
            .set_debug_logging(true, &names(&[LOG_EVENTS, "noSuchCategory"]))
            .is_err());
        assert_eq!(l.enabled, before, "an unknown name changes nothing");
    }
}
