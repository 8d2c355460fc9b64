//! The 34 fmi2 common and co-simulation functions of the C ABI.
//!
//! Each export is pinned to fmi-sys's `fmi2XxxTYPE`, so its signature cannot drift from the
//! standard's headers. Each runs inside [`guard`], which catches panics, checks the instance
//! pointer and the call against the state table, turns pointers into slices and logs
//! failures; the work itself is one call into [`Instance`].

#![allow(non_snake_case)]
// The safety contract of every export is the FMI 2.0 standard's for that function (valid
// pointers for the stated lengths, a component from fmi2Instantiate); each states it there.
#![allow(clippy::missing_safety_doc)]

use std::ffi::{c_char, c_int, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};

use fmi_sys::fmi2 as sys;
use sys::{
    fmi2Boolean, fmi2Component, fmi2FMUstate, fmi2Real, fmi2Status, fmi2StatusKind, fmi2String,
};

use super::file_location::{file_uri_to_path, Os};
use super::fmu_state::SavedState;
use super::instance::Instance;
use super::logger::{c_string, emit_to, Logger};
use super::state_machine::Call;
use super::status::{error, CallResult, Failure, Status};
use crate::model_description::{
    CAN_GET_AND_SET_FMU_STATE, CAN_INTERPOLATE_INPUTS, CAN_SERIALIZE_FMU_STATE, GUID,
};
use crate::model_description::{CAN_RUN_ASYNCHRONOUSLY, PROVIDES_DIRECTIONAL_DERIVATIVE};

// What the model description promises must match what is implemented below.
const _: () =
    assert!(CAN_GET_AND_SET_FMU_STATE && CAN_SERIALIZE_FMU_STATE && CAN_INTERPOLATE_INPUTS);
const _: () = assert!(!PROVIDES_DIRECTIONAL_DERIVATIVE && !CAN_RUN_ASYNCHRONOUSLY);

const ERROR: fmi2Status = sys::fmi2Status_fmi2Error;

/// Runs `body` on the instance behind `c` if `call` is allowed in its state; catches panics.
fn guard(
    c: fmi2Component,
    call: Call,
    body: impl FnOnce(&mut Instance) -> CallResult,
) -> fmi2Status {
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: a non-null component is a pointer this library returned from fmi2Instantiate.
        let Some(instance) = (unsafe { instance_mut(c) }) else {
            return ERROR;
        };
        if !call.allowed_in(instance.state) {
            let message = format!(
                "{} is not allowed in state {}; it is allowed in: {}",
                call.name(),
                instance.state,
                call.allowed_state_names()
            );
            instance.logger.failure(ERROR, &message);
            return ERROR;
        }
        match body(instance) {
            Ok(status) => status.to_c(),
            Err(Failure { severity, message }) => {
                instance
                    .logger
                    .failure(severity.to_c(), &format!("{}: {message}", call.name()));
                severity.to_c()
            }
        }
    }));
    outcome.unwrap_or_else(|_| {
        // A panic is a bug in this FMU: report it and park the instance in the error state.
        let _ = catch_unwind(AssertUnwindSafe(|| {
            // SAFETY: as above.
            if let Some(instance) = unsafe { instance_mut(c) } {
                instance.state = super::state_machine::FmiState::Error;
                instance.logger.failure(
                    ERROR,
                    &format!(
                        "{}: internal error (panic); instance set to error state",
                        call.name()
                    ),
                );
            }
        }));
        ERROR
    })
}

/// The instance behind a component pointer, if it is non-null and carries the magic.
///
/// # Safety
/// `c` must be null or a pointer returned by [`fmi2Instantiate`] and not yet freed.
unsafe fn instance_mut<'a>(c: fmi2Component) -> Option<&'a mut Instance> {
    let ptr = c as *mut Instance;
    // SAFETY: non-null pointers from the importer point to memory of an instance's size.
    if ptr.is_null() || !unsafe { Instance::has_magic(ptr) } {
        return None;
    }
    // SAFETY: aligned, and the magic says it is a live instance made by fmi2Instantiate.
    unsafe { ptr.as_mut() }
}

/// A slice from a C array; null is only accepted for an empty array.
///
/// # Safety
/// A non-null `ptr` must point to `n` readable values.
unsafe fn slice<'a, T>(ptr: *const T, n: usize, what: &str) -> Result<&'a [T], Failure> {
    if n == 0 {
        return Ok(&[]);
    }
    check_array(ptr, n, what)?;
    Ok(unsafe { std::slice::from_raw_parts(ptr, n) })
}

/// A mutable slice from a C array; null is only accepted for an empty array.
///
/// # Safety
/// A non-null `ptr` must point to `n` writable values.
unsafe fn slice_mut<'a, T>(ptr: *mut T, n: usize, what: &str) -> Result<&'a mut [T], Failure> {
    if n == 0 {
        return Ok(&mut []);
    }
    check_array(ptr, n, what)?;
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, n) })
}

/// The preconditions of a slice that can be checked: non-null, aligned, a length whose byte
/// size fits in isize.
fn check_array<T>(ptr: *const T, n: usize, what: &str) -> Result<(), Failure> {
    if ptr.is_null() {
        return Err(error(format!("{what} is a null pointer for {n} values")));
    }
    if !ptr.is_aligned() {
        return Err(error(format!("{what} is not aligned for its type")));
    }
    if n > isize::MAX as usize / std::mem::size_of::<T>().max(1) {
        return Err(error(format!(
            "{what}: {n} values is more than any array can hold"
        )));
    }
    Ok(())
}

/// A writable single value.
///
/// # Safety
/// A non-null `ptr` must be writable.
unsafe fn out<'a, T>(ptr: *mut T, what: &str) -> Result<&'a mut T, Failure> {
    unsafe { ptr.as_mut() }.ok_or_else(|| error(format!("{what} is a null pointer")))
}

/// The standard's name of a status kind.
fn kind_name(kind: fmi2StatusKind) -> String {
    match kind {
        sys::fmi2StatusKind_fmi2DoStepStatus => "fmi2DoStepStatus".into(),
        sys::fmi2StatusKind_fmi2PendingStatus => "fmi2PendingStatus".into(),
        sys::fmi2StatusKind_fmi2LastSuccessfulTime => "fmi2LastSuccessfulTime".into(),
        sys::fmi2StatusKind_fmi2Terminated => "fmi2Terminated".into(),
        other => format!("unknown status kind {other}"),
    }
}

fn not_supported(what: &str) -> CallResult {
    Err(error(format!(
        "{what} is not supported by this FMU (see its model description)"
    )))
}

// ---------------------------------------------------------------- inquiry, no instance

/// FMI 2.0: "default".
#[no_mangle]
pub unsafe extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}
const _: sys::fmi2GetTypesPlatformTYPE = Some(fmi2GetTypesPlatform);

/// FMI 2.0: "2.0".
#[no_mangle]
pub unsafe extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}
const _: sys::fmi2GetVersionTYPE = Some(fmi2GetVersion);

// ---------------------------------------------------------------- life cycle

/// Creates an instance; null on any error (reported through the given logger).
#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instanceName: fmi2String,
    fmuType: sys::fmi2Type,
    fmuGUID: fmi2String,
    fmuResourceLocation: fmi2String,
    functions: *const sys::fmi2CallbackFunctions,
    _visible: fmi2Boolean,
    loggingOn: fmi2Boolean,
) -> fmi2Component {
    let made = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: the importer passes a valid callback struct or null.
        let Some(functions) = (unsafe { functions.as_ref() }) else {
            return std::ptr::null_mut();
        };
        // SAFETY: the importer passes NUL-terminated strings or null.
        let text = |p: fmi2String| {
            (!p.is_null()).then(|| unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned())
        };
        let name = text(instanceName).unwrap_or_default();
        let fail = |message: String| {
            // SAFETY: the importer's own logger and environment, from its callback struct.
            unsafe {
                emit_to(
                    functions.logger,
                    functions.componentEnvironment,
                    &c_string(&name),
                    ERROR,
                    "logStatusError",
                    &message,
                )
            };
            std::ptr::null_mut()
        };
        if name.is_empty() {
            return fail("fmi2Instantiate: instanceName must be a non-empty string".into());
        }
        if fmuType != sys::fmi2Type_fmi2CoSimulation {
            return fail(format!(
                "fmi2Instantiate: fmuType {fmuType} refused: this FMU supports co-simulation only"
            ));
        }
        match text(fmuGUID) {
            Some(guid) if guid == GUID => {}
            other => {
                let given = other.map_or("NULL".to_string(), |g| format!("\"{g}\""));
                return fail(format!(
                    "fmi2Instantiate: GUID {given} does not match the model description's {GUID}"
                ));
            }
        }
        let logger = Logger::new(
            functions.logger,
            functions.componentEnvironment,
            c_string(&name),
            loggingOn != 0,
        );
        // A location that is not a local file URI only means that a relative
        // moduleParameterFile is looked up in the working directory alone.
        let resources =
            text(fmuResourceLocation).and_then(|uri| file_uri_to_path(&uri, Os::HERE).ok());
        Box::into_raw(Box::new(Instance::new(logger, resources))) as fmi2Component
    }));
    made.unwrap_or(std::ptr::null_mut())
}
const _: sys::fmi2InstantiateTYPE = Some(fmi2Instantiate);

/// Frees an instance and everything it owns.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: fmi2Component) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: c is null or a live instance from fmi2Instantiate.
        if let Some(instance) = unsafe { instance_mut(c) } {
            instance.invalidate();
            // SAFETY: the pointer came from Box::into_raw in fmi2Instantiate.
            drop(unsafe { Box::from_raw(c as *mut Instance) });
        }
    }));
}
const _: sys::fmi2FreeInstanceTYPE = Some(fmi2FreeInstance);

/// Switches debug logging for the given categories (all if none).
#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: fmi2Component,
    loggingOn: fmi2Boolean,
    nCategories: usize,
    categories: *const fmi2String,
) -> fmi2Status {
    guard(c, Call::SetDebugLogging, |inst| {
        // SAFETY: the importer passes nCategories string pointers.
        let pointers = unsafe { slice(categories, nCategories, "categories") }?;
        let mut names = Vec::with_capacity(pointers.len());
        for p in pointers {
            if p.is_null() {
                return Err(error("a category name is a null pointer"));
            }
            // SAFETY: non-null, NUL-terminated.
            names.push(unsafe { CStr::from_ptr(*p) }.to_string_lossy().into_owned());
        }
        inst.logger
            .set_debug_logging(loggingOn != 0, &names)
            .map_err(error)?;
        Ok(Status::Ok)
    })
}
const _: sys::fmi2SetDebugLoggingTYPE = Some(fmi2SetDebugLogging);

/// Sets the start time and the stop time past which steps are refused (the tolerance is not
/// needed by the exact integration).
#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: fmi2Component,
    _toleranceDefined: fmi2Boolean,
    _tolerance: fmi2Real,
    startTime: fmi2Real,
    stopTimeDefined: fmi2Boolean,
    stopTime: fmi2Real,
) -> fmi2Status {
    guard(c, Call::SetupExperiment, |inst| {
        inst.setup_experiment(startTime, (stopTimeDefined != 0).then_some(stopTime))
    })
}
const _: sys::fmi2SetupExperimentTYPE = Some(fmi2SetupExperiment);

/// Enters initialization mode.
#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: fmi2Component) -> fmi2Status {
    guard(
        c,
        Call::EnterInitializationMode,
        Instance::enter_initialization_mode,
    )
}
const _: sys::fmi2EnterInitializationModeTYPE = Some(fmi2EnterInitializationMode);

/// Validates the parameters and starts the module in steady state.
#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: fmi2Component) -> fmi2Status {
    guard(
        c,
        Call::ExitInitializationMode,
        Instance::exit_initialization_mode,
    )
}
const _: sys::fmi2ExitInitializationModeTYPE = Some(fmi2ExitInitializationMode);

/// Ends the simulation; values stay readable.
#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: fmi2Component) -> fmi2Status {
    guard(c, Call::Terminate, Instance::terminate)
}
const _: sys::fmi2TerminateTYPE = Some(fmi2Terminate);

/// Back to the state after fmi2Instantiate.
#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: fmi2Component) -> fmi2Status {
    guard(c, Call::Reset, Instance::reset)
}
const _: sys::fmi2ResetTYPE = Some(fmi2Reset);

// ---------------------------------------------------------------- values

/// Reads Real variables.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(
    c: fmi2Component,
    vr: *const sys::fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2Real,
) -> fmi2Status {
    guard(c, Call::GetReal, |inst| {
        // SAFETY: the importer passes nvr value references and room for nvr values.
        let (vrs, values) = unsafe { (slice(vr, nvr, "vr")?, slice_mut(value, nvr, "value")?) };
        inst.get_real(vrs, values)
    })
}
const _: sys::fmi2GetRealTYPE = Some(fmi2GetReal);

/// Writes Real inputs and (before initialisation ends) parameters; all or nothing.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(
    c: fmi2Component,
    vr: *const sys::fmi2ValueReference,
    nvr: usize,
    value: *const fmi2Real,
) -> fmi2Status {
    guard(c, Call::SetReal, |inst| {
        // SAFETY: the importer passes nvr value references and nvr values.
        let (vrs, values) = unsafe { (slice(vr, nvr, "vr")?, slice(value, nvr, "value")?) };
        inst.set_real(vrs, values)
    })
}
const _: sys::fmi2SetRealTYPE = Some(fmi2SetReal);

/// Reads Integer variables (hub settings, operating state, module counts).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetInteger(
    c: fmi2Component,
    vr: *const sys::fmi2ValueReference,
    nvr: usize,
    value: *mut sys::fmi2Integer,
) -> fmi2Status {
    guard(c, Call::GetInteger, |inst| {
        // SAFETY: the importer passes nvr value references and room for nvr values.
        let (vrs, values) = unsafe { (slice(vr, nvr, "vr")?, slice_mut(value, nvr, "value")?) };
        inst.get_integer(vrs, values)
    })
}
const _: sys::fmi2GetIntegerTYPE = Some(fmi2GetInteger);

/// Reads Boolean variables (fmi2True = 1, fmi2False = 0).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: fmi2Component,
    vr: *const sys::fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2Boolean,
) -> fmi2Status {
    guard(c, Call::GetBoolean, |inst| {
        // SAFETY: the importer passes nvr value references and room for nvr values.
        let (vrs, values) = unsafe { (slice(vr, nvr, "vr")?, slice_mut(value, nvr, "value")?) };
        let mut flags = vec![false; vrs.len()];
        let status = inst.get_boolean(vrs, &mut flags)?;
        for (out, flag) in values.iter_mut().zip(flags) {
            *out = flag as fmi2Boolean;
        }
        Ok(status)
    })
}
const _: sys::fmi2GetBooleanTYPE = Some(fmi2GetBoolean);

/// Reads String variables; the strings stay valid until the next fmi2GetString.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(
    c: fmi2Component,
    vr: *const sys::fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2String,
) -> fmi2Status {
    guard(c, Call::GetString, |inst| {
        // SAFETY: the importer passes nvr value references and room for nvr string pointers.
        let (vrs, values) = unsafe { (slice(vr, nvr, "vr")?, slice_mut(value, nvr, "value")?) };
        inst.get_string(vrs, values)
    })
}
const _: sys::fmi2GetStringTYPE = Some(fmi2GetString);

/// Writes Integer parameters (before initialisation ends); all or nothing.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(
    c: fmi2Component,
    vr: *const sys::fmi2ValueReference,
    nvr: usize,
    value: *const sys::fmi2Integer,
) -> fmi2Status {
    guard(c, Call::SetInteger, |inst| {
        // SAFETY: the importer passes nvr value references and nvr values.
        let (vrs, values) = unsafe { (slice(vr, nvr, "vr")?, slice(value, nvr, "value")?) };
        inst.set_integer(vrs, values)
    })
}
const _: sys::fmi2SetIntegerTYPE = Some(fmi2SetInteger);

/// Writes Boolean parameters (before initialisation ends; any non-zero value is true).
#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: fmi2Component,
    vr: *const sys::fmi2ValueReference,
    nvr: usize,
    value: *const fmi2Boolean,
) -> fmi2Status {
    guard(c, Call::SetBoolean, |inst| {
        // SAFETY: the importer passes nvr value references and nvr values.
        let (vrs, values) = unsafe { (slice(vr, nvr, "vr")?, slice(value, nvr, "value")?) };
        let flags: Vec<bool> = values.iter().map(|v| *v != 0).collect();
        inst.set_boolean(vrs, &flags)
    })
}
const _: sys::fmi2SetBooleanTYPE = Some(fmi2SetBoolean);

/// Writes String parameters (before initialisation ends); all or nothing. Each value must
/// be a non-null, NUL-terminated UTF-8 string.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(
    c: fmi2Component,
    vr: *const sys::fmi2ValueReference,
    nvr: usize,
    value: *const fmi2String,
) -> fmi2Status {
    guard(c, Call::SetString, |inst| {
        // SAFETY: the importer passes nvr value references and nvr string pointers.
        let (vrs, pointers) = unsafe { (slice(vr, nvr, "vr")?, slice(value, nvr, "value")?) };
        let mut values = Vec::with_capacity(pointers.len());
        for p in pointers {
            if p.is_null() {
                return Err(error("a String value is a null pointer"));
            }
            // SAFETY: a non-null fmi2String is a NUL-terminated string (FMI 2.0, section 2.1.2).
            let text = unsafe { CStr::from_ptr(*p) }
                .to_str()
                .map_err(|_| error("a String value is not UTF-8"))?;
            values.push(text.to_string());
        }
        inst.set_string(vrs, &values)
    })
}
const _: sys::fmi2SetStringTYPE = Some(fmi2SetString);

// ---------------------------------------------------------------- FMU state

/// The saved state behind an FMUstate pointer, if it carries the magic.
///
/// # Safety
/// `s` must be null or a pointer made by this library and not yet freed.
unsafe fn saved<'a>(s: fmi2FMUstate) -> Result<&'a mut SavedState, Failure> {
    let ptr = s as *mut SavedState;
    if ptr.is_null() {
        return Err(error("FMUstate is a null pointer"));
    }
    // SAFETY: non-null pointers from the importer point to memory of a state's size.
    if !unsafe { SavedState::has_magic(ptr) } {
        return Err(error("FMUstate was not made by this FMU"));
    }
    // SAFETY: aligned, and the magic says it is a state made by this library.
    Ok(unsafe { &mut *ptr })
}

/// Stores `state` where `slot` points: over an existing state of ours, or in a new one.
///
/// # Safety
/// `slot` must be writable; `*slot` must be null or a state of this library.
unsafe fn store(slot: *mut fmi2FMUstate, state: SavedState) -> CallResult {
    let slot = unsafe { out(slot, "FMUstate") }?;
    if slot.is_null() {
        *slot = Box::into_raw(Box::new(state)) as fmi2FMUstate;
    } else {
        *unsafe { saved(*slot) }? = state;
    }
    Ok(Status::Ok)
}

/// Copies the instance's complete state.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(
    c: fmi2Component,
    FMUstate: *mut fmi2FMUstate,
) -> fmi2Status {
    // SAFETY: FMUstate points to a slot holding null or a state of ours.
    guard(c, Call::GetFmuState, |inst| unsafe {
        store(FMUstate, inst.save())
    })
}
const _: sys::fmi2GetFMUstateTYPE = Some(fmi2GetFMUstate);

/// Restores a copied state.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: fmi2Component, FMUstate: fmi2FMUstate) -> fmi2Status {
    guard(c, Call::SetFmuState, |inst| {
        // SAFETY: FMUstate is a state of ours (checked by its magic).
        let state = unsafe { saved(FMUstate) }?.clone();
        inst.restore(&state)
    })
}
const _: sys::fmi2SetFMUstateTYPE = Some(fmi2SetFMUstate);

/// Frees a copied state and nulls the caller's pointer.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(
    c: fmi2Component,
    FMUstate: *mut fmi2FMUstate,
) -> fmi2Status {
    guard(c, Call::FreeFmuState, |_| {
        // SAFETY: FMUstate points to a slot holding null or a state of ours.
        let slot = unsafe { out(FMUstate, "FMUstate") }?;
        if slot.is_null() {
            return Ok(Status::Ok);
        }
        // SAFETY: as above; checked by its magic.
        unsafe { saved(*slot) }?.invalidate();
        // SAFETY: the state came from Box::into_raw in `store` or fmi2DeSerializeFMUstate.
        drop(unsafe { Box::from_raw(*slot as *mut SavedState) });
        *slot = std::ptr::null_mut();
        Ok(Status::Ok)
    })
}
const _: sys::fmi2FreeFMUstateTYPE = Some(fmi2FreeFMUstate);

/// Size in bytes of a serialised state.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: fmi2Component,
    FMUstate: fmi2FMUstate,
    size: *mut usize,
) -> fmi2Status {
    guard(c, Call::SerializedFmuStateSize, |_| {
        // SAFETY: FMUstate is a state of ours; size is writable.
        let len = unsafe { saved(FMUstate) }?.serialize().len();
        *unsafe { out(size, "size") }? = len;
        Ok(Status::Ok)
    })
}
const _: sys::fmi2SerializedFMUstateSizeTYPE = Some(fmi2SerializedFMUstateSize);

/// Writes a serialised state into the caller's buffer of `size` bytes.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: fmi2Component,
    FMUstate: fmi2FMUstate,
    serializedState: *mut sys::fmi2Byte,
    size: usize,
) -> fmi2Status {
    guard(c, Call::SerializeFmuState, |_| {
        // SAFETY: FMUstate is a state of ours.
        let bytes = unsafe { saved(FMUstate) }?.serialize();
        if size < bytes.len() {
            return Err(error(format!(
                "buffer of {size} bytes is too small: the state needs {}",
                bytes.len()
            )));
        }
        // SAFETY: the caller provides `size` writable bytes.
        let buffer =
            unsafe { slice_mut(serializedState as *mut u8, bytes.len(), "serializedState") }?;
        buffer.copy_from_slice(&bytes);
        Ok(Status::Ok)
    })
}
const _: sys::fmi2SerializeFMUstateTYPE = Some(fmi2SerializeFMUstate);

/// Reads a serialised state into a new (or the given) FMUstate.
#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: fmi2Component,
    serializedState: *const sys::fmi2Byte,
    size: usize,
    FMUstate: *mut fmi2FMUstate,
) -> fmi2Status {
    guard(c, Call::DeSerializeFmuState, |_| {
        // SAFETY: the caller provides `size` readable bytes.
        let bytes = unsafe { slice(serializedState as *const u8, size, "serializedState") }?;
        let state = SavedState::deserialize(bytes).map_err(error)?;
        // SAFETY: FMUstate points to a slot holding null or a state of ours.
        unsafe { store(FMUstate, state) }
    })
}
const _: sys::fmi2DeSerializeFMUstateTYPE = Some(fmi2DeSerializeFMUstate);

/// Not provided (providesDirectionalDerivative = false).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: fmi2Component,
    _vUnknown_ref: *const sys::fmi2ValueReference,
    _nUnknown: usize,
    _vKnown_ref: *const sys::fmi2ValueReference,
    _nKnown: usize,
    _dvKnown: *const fmi2Real,
    _dvUnknown: *mut fmi2Real,
) -> fmi2Status {
    guard(c, Call::GetDirectionalDerivative, |_| {
        not_supported("fmi2GetDirectionalDerivative")
    })
}
const _: sys::fmi2GetDirectionalDerivativeTYPE = Some(fmi2GetDirectionalDerivative);

// ---------------------------------------------------------------- co-simulation

/// First time derivatives of Real inputs at the current communication point
/// (canInterpolateInputs): the next fmi2DoStep integrates the linearly changing input exactly.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: fmi2Component,
    vr: *const sys::fmi2ValueReference,
    nvr: usize,
    order: *const sys::fmi2Integer,
    value: *const fmi2Real,
) -> fmi2Status {
    guard(c, Call::SetRealInputDerivatives, |inst| {
        // SAFETY: the importer passes nvr value references, orders and values.
        let (vrs, orders, values) = unsafe {
            (
                slice(vr, nvr, "vr")?,
                slice(order, nvr, "order")?,
                slice(value, nvr, "value")?,
            )
        };
        inst.set_input_derivatives(vrs, orders, values)
    })
}
const _: sys::fmi2SetRealInputDerivativesTYPE = Some(fmi2SetRealInputDerivatives);

/// Not provided (maxOutputDerivativeOrder = 0).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: fmi2Component,
    _vr: *const sys::fmi2ValueReference,
    _nvr: usize,
    _order: *const sys::fmi2Integer,
    _value: *mut fmi2Real,
) -> fmi2Status {
    guard(c, Call::GetRealOutputDerivatives, |_| {
        not_supported("fmi2GetRealOutputDerivatives")
    })
}
const _: sys::fmi2GetRealOutputDerivativesTYPE = Some(fmi2GetRealOutputDerivatives);

/// Advances the model exactly from the current communication point by the step size.
#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(
    c: fmi2Component,
    currentCommunicationPoint: fmi2Real,
    communicationStepSize: fmi2Real,
    _noSetFMUStatePriorToCurrentPoint: fmi2Boolean,
) -> fmi2Status {
    guard(c, Call::DoStep, |inst| {
        inst.do_step(currentCommunicationPoint, communicationStepSize)
    })
}
const _: sys::fmi2DoStepTYPE = Some(fmi2DoStep);

/// Steps never run asynchronously, so there is nothing to cancel.
#[no_mangle]
pub unsafe extern "C" fn fmi2CancelStep(c: fmi2Component) -> fmi2Status {
    guard(c, Call::CancelStep, |_| not_supported("fmi2CancelStep"))
}
const _: sys::fmi2CancelStepTYPE = Some(fmi2CancelStep);

/// fmi2DoStepStatus and fmi2PendingStatus are not available (steps are synchronous).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Status,
) -> fmi2Status {
    guard(c, Call::GetStatus, |_| {
        // SAFETY: value is writable.
        unsafe { out(value, "value") }?;
        Instance::status_not_available(&format!("{} of fmi2GetStatus", kind_name(s)))
    })
}
const _: sys::fmi2GetStatusTYPE = Some(fmi2GetStatus);

/// fmi2LastSuccessfulTime: the FMU's time [s].
#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Real,
) -> fmi2Status {
    guard(c, Call::GetRealStatus, |inst| {
        if s != sys::fmi2StatusKind_fmi2LastSuccessfulTime {
            return Instance::status_not_available(&format!(
                "{} of fmi2GetRealStatus",
                kind_name(s)
            ));
        }
        // SAFETY: value is writable.
        *unsafe { out(value, "value") }? = inst.last_successful_time();
        Ok(Status::Ok)
    })
}
const _: sys::fmi2GetRealStatusTYPE = Some(fmi2GetRealStatus);

/// No integer status kinds exist.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    _value: *mut sys::fmi2Integer,
) -> fmi2Status {
    guard(c, Call::GetIntegerStatus, |_| {
        Instance::status_not_available(&format!("{} of fmi2GetIntegerStatus", kind_name(s)))
    })
}
const _: sys::fmi2GetIntegerStatusTYPE = Some(fmi2GetIntegerStatus);

/// fmi2Terminated: false (the FMU never asks to stop).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Boolean,
) -> fmi2Status {
    guard(c, Call::GetBooleanStatus, |_| {
        if s != sys::fmi2StatusKind_fmi2Terminated {
            return Instance::status_not_available(&format!(
                "{} of fmi2GetBooleanStatus",
                kind_name(s)
            ));
        }
        // SAFETY: value is writable.
        *unsafe { out(value, "value") }? = sys::fmi2False as c_int;
        Ok(Status::Ok)
    })
}
const _: sys::fmi2GetBooleanStatusTYPE = Some(fmi2GetBooleanStatus);

/// fmi2PendingStatus is not available (steps are synchronous).
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    _value: *mut fmi2String,
) -> fmi2Status {
    guard(c, Call::GetStringStatus, |_| {
        Instance::status_not_available(&format!("{} of fmi2GetStringStatus", kind_name(s)))
    })
}
const _: sys::fmi2GetStringStatusTYPE = Some(fmi2GetStringStatus);
