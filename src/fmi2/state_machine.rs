//! Which fmi2 call is allowed in which state: one table, checked once per call
//! (FMI 2.0 standard, section 4.2.4, state machine of a co-simulation slave).

use std::fmt;

/// States of a co-simulation slave that this FMU can be in. `fmi2DoStep` completes
/// synchronously, so stepInProgress, stepFailed and stepCanceled are never entered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FmiState {
    /// After fmi2Instantiate or fmi2Reset.
    Instantiated,
    /// Between fmi2EnterInitializationMode and fmi2ExitInitializationMode.
    InitializationMode,
    /// Initialised and ready for fmi2DoStep.
    StepComplete,
    /// After fmi2Terminate.
    Terminated,
    /// After an internal failure; only inspection, reset, restore and free are allowed.
    Error,
}

impl FmiState {
    const fn bit(self) -> u8 {
        match self {
            FmiState::Instantiated => 1,
            FmiState::InitializationMode => 2,
            FmiState::StepComplete => 4,
            FmiState::Terminated => 8,
            FmiState::Error => 16,
        }
    }

    /// Stable number for serialised states (independent of the table's bit layout).
    pub const fn code(self) -> u8 {
        match self {
            FmiState::Instantiated => 1,
            FmiState::InitializationMode => 2,
            FmiState::StepComplete => 4,
            FmiState::Terminated => 8,
            FmiState::Error => 16,
        }
    }

    /// Inverse of [`FmiState::code`].
    pub fn from_code(code: u8) -> Option<Self> {
        [
            Self::Instantiated,
            Self::InitializationMode,
            Self::StepComplete,
            Self::Terminated,
            Self::Error,
        ]
        .into_iter()
        .find(|s| s.code() == code)
    }
}

impl fmt::Display for FmiState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            FmiState::Instantiated => "instantiated",
            FmiState::InitializationMode => "initializationMode",
            FmiState::StepComplete => "stepComplete",
            FmiState::Terminated => "terminated",
            FmiState::Error => "error",
        };
        f.write_str(name)
    }
}

const INST: u8 = FmiState::Instantiated.bit();
const INIT: u8 = FmiState::InitializationMode.bit();
const STEP: u8 = FmiState::StepComplete.bit();
const TERM: u8 = FmiState::Terminated.bit();
const ERR: u8 = FmiState::Error.bit();
const ANY: u8 = INST | INIT | STEP | TERM | ERR;

/// Every fmi2 function that takes an instance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum Call {
    SetDebugLogging,
    FreeInstance,
    SetupExperiment,
    EnterInitializationMode,
    ExitInitializationMode,
    Terminate,
    Reset,
    GetReal,
    GetInteger,
    GetBoolean,
    GetString,
    SetReal,
    SetInteger,
    SetBoolean,
    SetString,
    GetFmuState,
    SetFmuState,
    FreeFmuState,
    SerializedFmuStateSize,
    SerializeFmuState,
    DeSerializeFmuState,
    GetDirectionalDerivative,
    SetRealInputDerivatives,
    GetRealOutputDerivatives,
    DoStep,
    CancelStep,
    GetStatus,
    GetRealStatus,
    GetIntegerStatus,
    GetBooleanStatus,
    GetStringStatus,
}

impl Call {
    /// The states in which the standard allows this call (bit set of [`FmiState`]).
    const fn allowed_states(self) -> u8 {
        match self {
            Call::SetDebugLogging
            | Call::FreeInstance
            | Call::Reset
            | Call::GetFmuState
            | Call::SetFmuState
            | Call::FreeFmuState
            | Call::SerializedFmuStateSize
            | Call::SerializeFmuState
            | Call::DeSerializeFmuState => ANY,
            Call::SetupExperiment | Call::EnterInitializationMode => INST,
            Call::ExitInitializationMode => INIT,
            Call::Terminate => STEP,
            Call::GetReal | Call::GetInteger | Call::GetBoolean | Call::GetString => {
                INIT | STEP | TERM | ERR
            }
            Call::SetReal | Call::SetInteger | Call::SetBoolean | Call::SetString => {
                INST | INIT | STEP
            }
            Call::GetDirectionalDerivative => INIT | STEP | TERM | ERR,
            Call::SetRealInputDerivatives => INST | INIT | STEP,
            Call::GetRealOutputDerivatives => STEP | TERM | ERR,
            Call::DoStep => STEP,
            // Only while a step is in progress, which never happens here.
            Call::CancelStep => 0,
            Call::GetStatus
            | Call::GetRealStatus
            | Call::GetIntegerStatus
            | Call::GetBooleanStatus
            | Call::GetStringStatus => STEP | TERM,
        }
    }

    /// Whether the call is allowed in `state`.
    pub const fn allowed_in(self, state: FmiState) -> bool {
        self.allowed_states() & state.bit() != 0
    }

    /// States in which the call is allowed, for error messages.
    pub fn allowed_state_names(self) -> String {
        let names: Vec<String> = [
            FmiState::Instantiated,
            FmiState::InitializationMode,
            FmiState::StepComplete,
            FmiState::Terminated,
            FmiState::Error,
        ]
        .into_iter()
        .filter(|s| self.allowed_in(*s))
        .map(|s| s.to_string())
        .collect();
        if names.is_empty() {
            "stepInProgress only, which this FMU never enters (its steps are synchronous)".into()
        } else {
            names.join(", ")
        }
    }

    /// The C function's name.
    pub const fn name(self) -> &'static str {
        match self {
            Call::SetDebugLogging => "fmi2SetDebugLogging",
            Call::FreeInstance => "fmi2FreeInstance",
            Call::SetupExperiment => "fmi2SetupExperiment",
            Call::EnterInitializationMode => "fmi2EnterInitializationMode",
            Call::ExitInitializationMode => "fmi2ExitInitializationMode",
            Call::Terminate => "fmi2Terminate",
            Call::Reset => "fmi2Reset",
            Call::GetReal => "fmi2GetReal",
            Call::GetInteger => "fmi2GetInteger",
            Call::GetBoolean => "fmi2GetBoolean",
            Call::GetString => "fmi2GetString",
            Call::SetReal => "fmi2SetReal",
            Call::SetInteger => "fmi2SetInteger",
            Call::SetBoolean => "fmi2SetBoolean",
            Call::SetString => "fmi2SetString",
            Call::GetFmuState => "fmi2GetFMUstate",
            Call::SetFmuState => "fmi2SetFMUstate",
            Call::FreeFmuState => "fmi2FreeFMUstate",
            Call::SerializedFmuStateSize => "fmi2SerializedFMUstateSize",
            Call::SerializeFmuState => "fmi2SerializeFMUstate",
            Call::DeSerializeFmuState => "fmi2DeSerializeFMUstate",
            Call::GetDirectionalDerivative => "fmi2GetDirectionalDerivative",
            Call::SetRealInputDerivatives => "fmi2SetRealInputDerivatives",
            Call::GetRealOutputDerivatives => "fmi2GetRealOutputDerivatives",
            Call::DoStep => "fmi2DoStep",
            Call::CancelStep => "fmi2CancelStep",
            Call::GetStatus => "fmi2GetStatus",
            Call::GetRealStatus => "fmi2GetRealStatus",
            Call::GetIntegerStatus => "fmi2GetIntegerStatus",
            Call::GetBooleanStatus => "fmi2GetBooleanStatus",
            Call::GetStringStatus => "fmi2GetStringStatus",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_matches_the_standard_on_key_calls() {
        assert!(Call::DoStep.allowed_in(FmiState::StepComplete));
        assert!(!Call::DoStep.allowed_in(FmiState::InitializationMode));
        assert!(!Call::GetReal.allowed_in(FmiState::Instantiated));
        assert!(Call::SetReal.allowed_in(FmiState::Instantiated));
        assert!(!Call::SetReal.allowed_in(FmiState::Terminated));
        assert!(!Call::CancelStep.allowed_in(FmiState::StepComplete));
        for s in [
            FmiState::Instantiated,
            FmiState::InitializationMode,
            FmiState::StepComplete,
            FmiState::Terminated,
            FmiState::Error,
        ] {
            assert!(Call::FreeInstance.allowed_in(s));
            assert_eq!(FmiState::from_code(s.code()), Some(s));
        }
    }
}
