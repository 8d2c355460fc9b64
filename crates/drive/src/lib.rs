//! The stepping loop of a co-simulation in native code, for a master written in Python.
//!
//! A Python master pays a few microseconds of interpreter per FMI call; the hub FMU steps in
//! less than that, so a test signal of 10⁴…10⁵ steps costs the interpreter, not the model.
//! [`aem_drive_series`] runs the loop of such a master with the FMU's own entry points (the
//! master loads the FMU, instantiates and initialises it, and passes the three function
//! pointers): at every sample k it sets one real input to `input[k]`, reads `n_outputs` reals
//! into row k of `outputs`, and steps from `t[k]` to `t[k+1]`. The FMU sees the same calls, in
//! the same order, with the same arguments as from the Python loop, so the results are the same
//! bit for bit.

use std::os::raw::c_int;
use std::panic::{catch_unwind, AssertUnwindSafe};

use fmi_sys::fmi2::{
    fmi2Component, fmi2DoStepTYPE, fmi2GetRealTYPE, fmi2SetRealTYPE, fmi2Status,
    fmi2Status_fmi2Error, fmi2Status_fmi2OK, fmi2Status_fmi2Warning, fmi2ValueReference,
};

/// The FMU's three entry points the loop calls.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct Entries {
    pub set_real: fmi2SetRealTYPE,
    pub get_real: fmi2GetRealTYPE,
    pub do_step: fmi2DoStepTYPE,
}

/// Drives `component` through `n` samples: for k = 0 … n−1, fmi2SetReal(input_vr ← input[k]),
/// fmi2GetReal(output_vrs → outputs[k·n_outputs …]), and, but for the last sample,
/// fmi2DoStep(t[k], t[k+1] − t[k], fmi2True).
///
/// Returns fmi2OK or fmi2Warning when every sample ran. When a sample's calls return worse than
/// fmi2Warning (their statuses OR-ed, as a Python master's `status |= …` does), stops after that
/// sample's step, writes its index to `*failed_at`, and returns that status. Returns fmi2Error
/// without calling anything for a null pointer, a missing entry point or n = 0 or n_outputs = 0
/// (then `*failed_at`, if given, is n).
///
/// # Safety
/// `t` and `input` must point to `n` values, `outputs` to `n · n_outputs` writable values,
/// `output_vrs` to `n_outputs` value references, `component` must be an instance of the FMU whose
/// entry points `entries` holds, in its step mode; `failed_at` may be null.
#[no_mangle]
pub unsafe extern "C" fn aem_drive_series(
    entries: *const Entries,
    component: fmi2Component,
    n: usize,
    t: *const f64,
    input_vr: fmi2ValueReference,
    input: *const f64,
    n_outputs: usize,
    output_vrs: *const fmi2ValueReference,
    outputs: *mut f64,
    failed_at: *mut usize,
) -> fmi2Status {
    let report = |k: usize| {
        if !failed_at.is_null() {
            // SAFETY: the caller passes a writable usize or null.
            unsafe { *failed_at = k };
        }
    };
    if entries.is_null()
        || component.is_null()
        || t.is_null()
        || input.is_null()
        || output_vrs.is_null()
        || outputs.is_null()
        || n == 0
        || n_outputs == 0
    {
        report(n);
        return fmi2Status_fmi2Error;
    }
    // SAFETY: the caller's contract (see above) makes every slice below valid.
    let entries = unsafe { *entries };
    let (Some(set_real), Some(get_real), Some(do_step)) =
        (entries.set_real, entries.get_real, entries.do_step)
    else {
        report(n);
        return fmi2Status_fmi2Error;
    };
    let (t, input) = unsafe {
        (
            std::slice::from_raw_parts(t, n),
            std::slice::from_raw_parts(input, n),
        )
    };
    let output_vrs = unsafe { std::slice::from_raw_parts(output_vrs, n_outputs) };
    let outputs = unsafe { std::slice::from_raw_parts_mut(outputs, n * n_outputs) };
    // Nothing below panics (indices stay within the slices); the guard keeps a panic, should one
    // ever appear, from unwinding into the caller.
    let run = AssertUnwindSafe(|| {
        let mut worst = fmi2Status_fmi2OK;
        for k in 0..n {
            let row = &mut outputs[k * n_outputs..(k + 1) * n_outputs];
            // SAFETY: one value in, n_outputs values out, as the FMI 2.0 calls expect.
            let mut status = unsafe {
                set_real(component, &input_vr, 1, &input[k])
                    | get_real(component, output_vrs.as_ptr(), n_outputs, row.as_mut_ptr())
            };
            if k + 1 < n {
                status |= unsafe { do_step(component, t[k], t[k + 1] - t[k], FMI2_TRUE) };
            }
            if status > fmi2Status_fmi2Warning {
                return (status, Some(k));
            }
            worst = worst.max(status);
        }
        (worst, None)
    });
    match catch_unwind(run) {
        Ok((status, failed)) => {
            if let Some(k) = failed {
                report(k);
            }
            status
        }
        Err(_) => {
            report(n);
            fmi2Status_fmi2Error
        }
    }
}

/// fmi2True as the fmi2Boolean argument of fmi2DoStep (noSetFMUStatePriorToCurrentPoint).
const FMI2_TRUE: c_int = fmi_sys::fmi2::fmi2True as c_int;

#[cfg(test)]
mod tests;
