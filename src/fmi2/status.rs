//! fmi2Status inside the FMU: success as `Ok(Status)`, failure as `Err(Failure)`;
//! converted to the C enum only at the boundary.

use fmi_sys::fmi2 as sys;

/// A successful call's status, ordered by what deserves more attention.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Status {
    /// fmi2OK.
    Ok,
    /// fmi2Warning: done, but something deserves attention (it was logged).
    Warning,
}

/// How a call failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Severity {
    /// fmi2Discard: the request was refused; the instance is unchanged and usable.
    Discard,
    /// fmi2Error: the request was invalid; the instance is unchanged.
    Error,
}

/// A refused call: its severity and the message that goes to the logger.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Failure {
    /// Returned status.
    pub severity: Severity,
    /// Logged explanation.
    pub message: String,
}

/// Result of one fmi2 call.
pub type CallResult = Result<Status, Failure>;

/// An fmi2Error failure with `message`.
pub fn error(message: impl Into<String>) -> Failure {
    Failure {
        severity: Severity::Error,
        message: message.into(),
    }
}

/// An fmi2Discard failure with `message`.
pub fn discard(message: impl Into<String>) -> Failure {
    Failure {
        severity: Severity::Discard,
        message: message.into(),
    }
}

impl Status {
    /// The C value.
    pub fn to_c(self) -> sys::fmi2Status {
        match self {
            Status::Ok => sys::fmi2Status_fmi2OK,
            Status::Warning => sys::fmi2Status_fmi2Warning,
        }
    }

    /// The more severe of two statuses.
    pub fn merge(self, other: Status) -> Status {
        if self == Status::Warning || other == Status::Warning {
            Status::Warning
        } else {
            Status::Ok
        }
    }
}

impl Severity {
    /// The C value.
    pub fn to_c(self) -> sys::fmi2Status {
        match self {
            Severity::Discard => sys::fmi2Status_fmi2Discard,
            Severity::Error => sys::fmi2Status_fmi2Error,
        }
    }
}
