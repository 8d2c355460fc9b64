//! The loop against a fake FMU whose component is a Rust struct: an integrator x' = u with
//! x(t) read back, every call recorded.

use super::*;
use fmi_sys::fmi2::fmi2Status_fmi2Discard;
use std::os::raw::c_void;

#[derive(Debug, PartialEq, Clone, Copy)]
enum Call {
    Set(fmi2ValueReference, f64),
    Get(usize),
    Step(f64, f64, c_int),
}

/// x' = u over each step (held input): exact x(t + h) = x + u·h. Outputs: vr 0 → x, vr 1 → u.
#[derive(Default)]
struct Fake {
    x: f64,
    u: f64,
    calls: Vec<Call>,
    /// (call number, status): the status the `call number`-th call (from 0) returns.
    status_at: Option<(usize, fmi2Status)>,
}

impl Fake {
    fn status(&mut self, call: Call) -> fmi2Status {
        self.calls.push(call);
        match self.status_at {
            Some((n, s)) if n + 1 == self.calls.len() => s,
            _ => fmi2Status_fmi2OK,
        }
    }
}

unsafe fn fake<'a>(c: fmi2Component) -> &'a mut Fake {
    unsafe { &mut *(c as *mut Fake) }
}

unsafe extern "C" fn set_real(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    v: *const f64,
) -> fmi2Status {
    let f = unsafe { fake(c) };
    assert_eq!(nvr, 1);
    let (vr, v) = unsafe { (*vr, *v) };
    f.u = v;
    f.status(Call::Set(vr, v))
}

unsafe extern "C" fn get_real(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    v: *mut f64,
) -> fmi2Status {
    let f = unsafe { fake(c) };
    for i in 0..nvr {
        unsafe { *v.add(i) = if *vr.add(i) == 0 { f.x } else { f.u } };
    }
    f.status(Call::Get(nvr))
}

unsafe extern "C" fn do_step(c: fmi2Component, t: f64, h: f64, no_set: c_int) -> fmi2Status {
    let f = unsafe { fake(c) };
    f.x += f.u * h;
    f.status(Call::Step(t, h, no_set))
}

const ENTRIES: Entries = Entries {
    set_real: Some(set_real),
    get_real: Some(get_real),
    do_step: Some(do_step),
};

/// Runs the loop on `fake` over (t, u); returns (status, failed_at, outputs).
fn drive(fake: &mut Fake, t: &[f64], u: &[f64]) -> (fmi2Status, usize, Vec<f64>) {
    let vrs = [0, 1];
    let mut out = vec![f64::NAN; 2 * t.len()];
    let mut failed_at = usize::MAX;
    let status = unsafe {
        aem_drive_series(
            &ENTRIES,
            fake as *mut Fake as *mut c_void,
            t.len(),
            t.as_ptr(),
            7,
            u.as_ptr(),
            2,
            vrs.as_ptr(),
            out.as_mut_ptr(),
            &mut failed_at,
        )
    };
    (status, failed_at, out)
}

#[test]
fn each_sample_sets_reads_then_steps_to_the_next_and_the_held_input_integrates_exactly() {
    let t = [0.0, 0.5, 1.5, 1.75];
    let u = [2.0, -4.0, 8.0, 1.0];
    let mut f = Fake::default();
    let (status, failed_at, out) = drive(&mut f, &t, &u);
    assert_eq!(status, fmi2Status_fmi2OK);
    assert_eq!(failed_at, usize::MAX); // untouched when every sample ran
    let mut expected_calls = vec![];
    for k in 0..t.len() {
        expected_calls.push(Call::Set(7, u[k]));
        expected_calls.push(Call::Get(2));
        if k + 1 < t.len() {
            expected_calls.push(Call::Step(t[k], t[k + 1] - t[k], 1));
        }
    }
    assert_eq!(f.calls, expected_calls);
    // x(t_k) = Σ_{j<k} u_j (t_{j+1} − t_j), read before the step; u as set at t_k.
    let x = [0.0, 1.0, 1.0 - 4.0, 1.0 - 4.0 + 2.0];
    for k in 0..t.len() {
        assert_eq!(out[2 * k], x[k], "x at sample {k}");
        assert_eq!(out[2 * k + 1], u[k], "u at sample {k}");
    }
}

#[test]
fn a_warning_is_returned_and_the_loop_goes_on() {
    let mut f = Fake {
        status_at: Some((4, fmi2Status_fmi2Warning)),
        ..Fake::default()
    };
    let (status, failed_at, out) = drive(&mut f, &[0.0, 1.0, 2.0], &[1.0, 1.0, 1.0]);
    assert_eq!(status, fmi2Status_fmi2Warning);
    assert_eq!(failed_at, usize::MAX);
    assert_eq!(f.calls.len(), 3 + 3 + 2);
    assert_eq!(out[4], 2.0);
}

#[test]
fn an_error_stops_after_the_sample_whose_calls_failed() {
    // Call 4 is sample 1's fmi2GetReal: that sample still steps (its statuses are OR-ed), then
    // the loop stops and names it.
    for (status_at, expected) in [(4, fmi2Status_fmi2Error), (3, fmi2Status_fmi2Discard)] {
        let mut f = Fake {
            status_at: Some((status_at, expected)),
            ..Fake::default()
        };
        let (status, failed_at, out) = drive(&mut f, &[0.0, 1.0, 2.0, 3.0], &[1.0; 4]);
        assert_eq!(status, expected);
        assert_eq!(failed_at, 1);
        assert_eq!(f.calls.len(), 6);
        assert!(matches!(f.calls[5], Call::Step(1.0, 1.0, 1)));
        assert!(
            out[4..].iter().all(|v| v.is_nan()),
            "nothing read after the failed sample"
        );
    }
}

#[test]
fn null_pointers_and_empty_series_call_nothing() {
    let mut f = Fake::default();
    let component = &mut f as *mut Fake as *mut c_void;
    let (t, u, vrs, mut out) = ([0.0], [1.0], [0u32], [0.0]);
    let none = Entries {
        set_real: None,
        ..ENTRIES
    };
    let cases: Vec<(
        &str,
        *const Entries,
        fmi2Component,
        usize,
        *const f64,
        *const f64,
        usize,
        *mut f64,
    )> = vec![
        (
            "no entries",
            std::ptr::null(),
            component,
            1,
            t.as_ptr(),
            u.as_ptr(),
            1,
            out.as_mut_ptr(),
        ),
        (
            "no fmi2SetReal",
            &none,
            component,
            1,
            t.as_ptr(),
            u.as_ptr(),
            1,
            out.as_mut_ptr(),
        ),
        (
            "no component",
            &ENTRIES,
            std::ptr::null_mut(),
            1,
            t.as_ptr(),
            u.as_ptr(),
            1,
            out.as_mut_ptr(),
        ),
        (
            "no times",
            &ENTRIES,
            component,
            1,
            std::ptr::null(),
            u.as_ptr(),
            1,
            out.as_mut_ptr(),
        ),
        (
            "no input",
            &ENTRIES,
            component,
            1,
            t.as_ptr(),
            std::ptr::null(),
            1,
            out.as_mut_ptr(),
        ),
        (
            "no outputs",
            &ENTRIES,
            component,
            1,
            t.as_ptr(),
            u.as_ptr(),
            1,
            std::ptr::null_mut(),
        ),
        (
            "no samples",
            &ENTRIES,
            component,
            0,
            t.as_ptr(),
            u.as_ptr(),
            1,
            out.as_mut_ptr(),
        ),
        (
            "no outputs asked",
            &ENTRIES,
            component,
            1,
            t.as_ptr(),
            u.as_ptr(),
            0,
            out.as_mut_ptr(),
        ),
    ];
    for (what, entries, c, n, t, u, n_outputs, out) in cases {
        let mut failed_at = usize::MAX;
        let status = unsafe {
            aem_drive_series(
                entries,
                c,
                n,
                t,
                0,
                u,
                n_outputs,
                vrs.as_ptr(),
                out,
                &mut failed_at,
            )
        };
        assert_eq!(status, fmi2Status_fmi2Error, "{what}");
        assert_eq!(failed_at, n, "{what}");
    }
    assert!(f.calls.is_empty());
    // failed_at may be null
    let status = unsafe {
        aem_drive_series(
            std::ptr::null(),
            component,
            1,
            t.as_ptr(),
            0,
            u.as_ptr(),
            1,
            vrs.as_ptr(),
            out.as_mut_ptr(),
            std::ptr::null_mut(),
        )
    };
    assert_eq!(status, fmi2Status_fmi2Error);
}
