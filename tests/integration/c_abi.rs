//! The C ABI called in process: the call-sequence table of the FMI 2.0 standard walked in
//! every state, null pointers, and instances stepped from several threads.
//!
//! Log messages reach the test through fmi-sys's C logger shim (which formats the variadic
//! call and forwards it to the `log` crate) and a capturing `log::Log`.

use std::ffi::CString;
use std::ptr::{null, null_mut};
use std::sync::{Mutex, Once};

use aem_electrolyser::fmi2::exports::*;
use aem_electrolyser::model_description::{RealVariable, GUID};
use fmi_sys::fmi2 as sys;

const OK: sys::fmi2Status = sys::fmi2Status_fmi2OK;
const ERROR: sys::fmi2Status = sys::fmi2Status_fmi2Error;

/// (instance name, message) of every log record.
static MESSAGES: Mutex<Vec<(String, String)>> = Mutex::new(Vec::new());

struct Capture;

impl log::Log for Capture {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }
    fn log(&self, record: &log::Record) {
        let mut m = MESSAGES.lock().unwrap_or_else(|e| e.into_inner());
        m.push((record.target().to_string(), record.args().to_string()));
    }
    fn flush(&self) {}
}

static CAPTURE: Capture = Capture;
static INIT: Once = Once::new();

fn messages_of(instance: &str) -> Vec<String> {
    let m = MESSAGES.lock().unwrap_or_else(|e| e.into_inner());
    m.iter()
        .filter(|(name, _)| name == instance)
        .map(|(_, msg)| msg.clone())
        .collect()
}

fn callbacks() -> sys::fmi2CallbackFunctions {
    INIT.call_once(|| {
        let _ = log::set_logger(&CAPTURE);
        log::set_max_level(log::LevelFilter::Trace);
    });
    sys::fmi2CallbackFunctions {
        logger: Some(sys::logger::callback_logger_handler),
        allocateMemory: None,
        freeMemory: None,
        stepFinished: None,
        componentEnvironment: null_mut(),
    }
}

/// One instance with the standard's calls as safe methods.
struct Fmu {
    c: sys::fmi2Component,
    name: String,
    _callbacks: Box<sys::fmi2CallbackFunctions>,
    time: f64,
}

impl Fmu {
    fn new(name: &str) -> Fmu {
        let callbacks = Box::new(callbacks());
        let cname = CString::new(name).unwrap();
        let guid = CString::new(GUID).unwrap();
        // SAFETY: valid strings and callbacks that outlive the instance.
        let c = unsafe {
            fmi2Instantiate(
                cname.as_ptr(),
                sys::fmi2Type_fmi2CoSimulation,
                guid.as_ptr(),
                null(),
                &*callbacks,
                0,
                0,
            )
        };
        assert!(!c.is_null(), "instantiate");
        Fmu {
            c,
            name: name.to_string(),
            _callbacks: callbacks,
            time: 0.0,
        }
    }

    fn initialised(name: &str, setpoint: f64) -> Fmu {
        let mut f = Fmu::new(name);
        assert_eq!(f.setup(), OK);
        assert_eq!(f.set(RealVariable::Setpoint, setpoint), OK);
        assert_eq!(f.enter_init(), OK);
        assert_eq!(f.exit_init(), OK);
        f.time = 0.0;
        f
    }

    fn setup(&mut self) -> sys::fmi2Status {
        unsafe { fmi2SetupExperiment(self.c, 0, 0.0, 0.0, 0, 0.0) }
    }
    fn enter_init(&mut self) -> sys::fmi2Status {
        unsafe { fmi2EnterInitializationMode(self.c) }
    }
    fn exit_init(&mut self) -> sys::fmi2Status {
        unsafe { fmi2ExitInitializationMode(self.c) }
    }
    fn set(&mut self, var: RealVariable, value: f64) -> sys::fmi2Status {
        let vr = [var.value_reference()];
        unsafe { fmi2SetReal(self.c, vr.as_ptr(), 1, &value) }
    }
    fn get(&mut self, var: RealVariable) -> (sys::fmi2Status, f64) {
        let vr = [var.value_reference()];
        let mut v = f64::NAN;
        let s = unsafe { fmi2GetReal(self.c, vr.as_ptr(), 1, &mut v) };
        (s, v)
    }
    fn step(&mut self, h: f64) -> sys::fmi2Status {
        let s = unsafe { fmi2DoStep(self.c, self.time, h, 1) };
        if s == OK {
            self.time += h;
        }
        s
    }
    fn messages(&self) -> Vec<String> {
        messages_of(&self.name)
    }
}

impl Drop for Fmu {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) };
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum State {
    Instantiated,
    InitializationMode,
    StepComplete,
    Terminated,
}

fn in_state(name: &str, state: State) -> Fmu {
    let mut f = Fmu::new(name);
    if state == State::Instantiated {
        return f;
    }
    assert_eq!(f.enter_init(), OK);
    if state == State::InitializationMode {
        return f;
    }
    assert_eq!(f.exit_init(), OK);
    if state == State::Terminated {
        assert_eq!(unsafe { fmi2Terminate(f.c) }, OK);
    }
    f
}

/// A call with valid arguments, by name; returns its status.
fn call(f: &mut Fmu, name: &str) -> sys::fmi2Status {
    let c = f.c;
    let vr = [RealVariable::Setpoint.value_reference()];
    let mut real = 0.0;
    let mut state: sys::fmi2FMUstate = null_mut();
    unsafe {
        match name {
            "fmi2SetupExperiment" => fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0),
            "fmi2EnterInitializationMode" => fmi2EnterInitializationMode(c),
            "fmi2ExitInitializationMode" => fmi2ExitInitializationMode(c),
            "fmi2Terminate" => fmi2Terminate(c),
            "fmi2GetReal" => fmi2GetReal(c, vr.as_ptr(), 1, &mut real),
            "fmi2SetReal" => fmi2SetReal(c, vr.as_ptr(), 1, &80.0),
            "fmi2DoStep" => fmi2DoStep(c, f.time, 1.0, 1),
            "fmi2GetFMUstate" => {
                let s = fmi2GetFMUstate(c, &mut state);
                fmi2FreeFMUstate(c, &mut state);
                s
            }
            "fmi2SetDebugLogging" => fmi2SetDebugLogging(c, 0, 0, null()),
            "fmi2GetRealStatus" => {
                fmi2GetRealStatus(c, sys::fmi2StatusKind_fmi2LastSuccessfulTime, &mut real)
            }
            "fmi2Reset" => fmi2Reset(c),
            other => panic!("no such call {other}"),
        }
    }
}

#[test]
fn every_call_in_every_state_follows_the_standards_table() {
    use State::*;
    // FMI 2.0 standard, section 4.2.4 (co-simulation state machine), written out here
    // independently of the FMU's own table.
    let table: &[(&str, &[State])] = &[
        ("fmi2SetupExperiment", &[Instantiated]),
        ("fmi2EnterInitializationMode", &[Instantiated]),
        ("fmi2ExitInitializationMode", &[InitializationMode]),
        ("fmi2Terminate", &[StepComplete]),
        (
            "fmi2GetReal",
            &[InitializationMode, StepComplete, Terminated],
        ),
        (
            "fmi2SetReal",
            &[Instantiated, InitializationMode, StepComplete],
        ),
        ("fmi2DoStep", &[StepComplete]),
        (
            "fmi2GetFMUstate",
            &[Instantiated, InitializationMode, StepComplete, Terminated],
        ),
        (
            "fmi2SetDebugLogging",
            &[Instantiated, InitializationMode, StepComplete, Terminated],
        ),
        ("fmi2GetRealStatus", &[StepComplete, Terminated]),
        (
            "fmi2Reset",
            &[Instantiated, InitializationMode, StepComplete, Terminated],
        ),
    ];
    for (i, (name, allowed)) in table.iter().enumerate() {
        for (j, state) in [Instantiated, InitializationMode, StepComplete, Terminated]
            .into_iter()
            .enumerate()
        {
            let instance = format!("table-{i}-{j}");
            let mut f = in_state(&instance, state);
            let status = call(&mut f, name);
            let refused = f
                .messages()
                .iter()
                .any(|m| m.contains("is not allowed in state"));
            if allowed.contains(&state) {
                assert_eq!(
                    status,
                    OK,
                    "{name} in {state:?} must succeed; log: {:?}",
                    f.messages()
                );
                assert!(!refused);
            } else {
                assert_eq!(status, ERROR, "{name} in {state:?} must be refused");
                assert!(
                    refused && f.messages().iter().any(|m| m.contains(name)),
                    "{name} in {state:?}: {:?}",
                    f.messages()
                );
            }
        }
    }
}

#[test]
fn null_pointers_are_refused_without_touching_the_instance() {
    let mut f = Fmu::initialised("nulls", 70.0);
    let vr = [RealVariable::Current.value_reference()];
    let mut v = 0.0;
    let mut twin = Fmu::initialised("nulls-twin", 70.0);
    unsafe {
        assert_eq!(fmi2GetReal(f.c, null(), 1, &mut v), ERROR);
        assert_eq!(fmi2GetReal(f.c, vr.as_ptr(), 1, null_mut()), ERROR);
        assert_eq!(fmi2SetReal(f.c, null(), 1, &1.0), ERROR);
        assert_eq!(fmi2SetReal(f.c, vr.as_ptr(), 1, null()), ERROR);
        assert_eq!(
            fmi2GetReal(f.c, null(), 0, null_mut()),
            OK,
            "an empty request may pass nulls"
        );
        assert_eq!(fmi2DoStep(null_mut(), 0.0, 1.0, 1), ERROR);
        assert_eq!(fmi2GetFMUstate(f.c, null_mut()), ERROR);
        assert_eq!(fmi2SetFMUstate(f.c, null_mut()), ERROR);
        assert_eq!(fmi2FreeFMUstate(f.c, null_mut()), ERROR);
        assert_eq!(
            fmi2SerializedFMUstateSize(f.c, null_mut(), null_mut()),
            ERROR
        );
        assert_eq!(fmi2DeSerializeFMUstate(f.c, null(), 10, null_mut()), ERROR);
        assert_eq!(fmi2SetDebugLogging(f.c, 1, 1, null()), ERROR);
        let nulls: [sys::fmi2String; 1] = [null()];
        assert_eq!(fmi2SetDebugLogging(f.c, 1, 1, nulls.as_ptr()), ERROR);
        assert_eq!(
            fmi2GetRealStatus(f.c, sys::fmi2StatusKind_fmi2LastSuccessfulTime, null_mut()),
            ERROR
        );
        fmi2FreeInstance(null_mut());
    }
    assert!(f.messages().iter().any(|m| m.contains("null pointer")));
    for _ in 0..100 {
        f.set(RealVariable::Setpoint, 95.0);
        twin.set(RealVariable::Setpoint, 95.0);
        assert_eq!(f.step(0.5), OK);
        assert_eq!(twin.step(0.5), OK);
        assert_eq!(
            f.get(RealVariable::Current).1.to_bits(),
            twin.get(RealVariable::Current).1.to_bits()
        );
    }
}

#[test]
fn instantiate_refuses_bad_arguments() {
    let cb = callbacks();
    let guid = CString::new(GUID).unwrap();
    unsafe {
        assert!(fmi2Instantiate(
            c"x".as_ptr(),
            sys::fmi2Type_fmi2CoSimulation,
            guid.as_ptr(),
            null(),
            null(),
            0,
            0
        )
        .is_null());
        assert!(fmi2Instantiate(
            null(),
            sys::fmi2Type_fmi2CoSimulation,
            guid.as_ptr(),
            null(),
            &cb,
            0,
            0
        )
        .is_null());
        assert!(fmi2Instantiate(
            c"me".as_ptr(),
            sys::fmi2Type_fmi2ModelExchange,
            guid.as_ptr(),
            null(),
            &cb,
            0,
            0
        )
        .is_null());
        assert!(fmi2Instantiate(
            c"guid".as_ptr(),
            sys::fmi2Type_fmi2CoSimulation,
            c"{wrong}".as_ptr(),
            null(),
            &cb,
            0,
            0
        )
        .is_null());
        assert!(fmi2Instantiate(
            c"noguid".as_ptr(),
            sys::fmi2Type_fmi2CoSimulation,
            null(),
            null(),
            &cb,
            0,
            0
        )
        .is_null());
    }
    assert!(messages_of("me")
        .iter()
        .any(|m| m.contains("co-simulation only")));
    assert!(messages_of("guid").iter().any(|m| m.contains("GUID")));
    assert!(messages_of("noguid").iter().any(|m| m.contains("GUID")));
}

#[test]
fn an_infinite_stop_time_bounds_nothing_and_survives_serialisation() {
    // Found by the fuzz test: stopTime = +inf was kept and made every saved state refuse
    // to deserialise (saved states hold only finite numbers).
    let mut f = Fmu::new("infinite-stop");
    assert_eq!(
        unsafe { fmi2SetupExperiment(f.c, 0, 0.0, 40.0, 1, f64::INFINITY) },
        OK
    );
    assert_eq!(f.enter_init(), OK);
    assert_eq!(f.exit_init(), OK);
    f.time = 40.0;
    assert_eq!(f.step(1e9), OK, "no finite stop time to pass");
    unsafe {
        let mut state: sys::fmi2FMUstate = null_mut();
        assert_eq!(fmi2GetFMUstate(f.c, &mut state), OK);
        let mut size = 0usize;
        assert_eq!(fmi2SerializedFMUstateSize(f.c, state, &mut size), OK);
        let mut bytes = vec![0u8; size];
        assert_eq!(
            fmi2SerializeFMUstate(f.c, state, bytes.as_mut_ptr() as *mut sys::fmi2Byte, size),
            OK
        );
        let mut back: sys::fmi2FMUstate = null_mut();
        assert_eq!(
            fmi2DeSerializeFMUstate(f.c, bytes.as_ptr() as *const sys::fmi2Byte, size, &mut back),
            OK
        );
        assert_eq!(fmi2SetFMUstate(f.c, back), OK);
        assert_eq!(fmi2FreeFMUstate(f.c, &mut state), OK);
        assert_eq!(fmi2FreeFMUstate(f.c, &mut back), OK);
    }
    assert_eq!(f.step(1.0), OK);
}

#[test]
fn invalid_parameters_are_refused_at_initialisation_by_name() {
    for (var, value) in [
        (RealVariable::TauPole1, -1.0),
        (RealVariable::MinSetpoint, 120.0),
        (RealVariable::Gain, 0.0),
        (RealVariable::RampUpLimit, -0.2),
    ] {
        let name = format!("param-{}", var.name());
        let mut f = Fmu::new(&name);
        assert_eq!(
            f.set(var, value),
            OK,
            "parameters are checked as a set at initialisation"
        );
        assert_eq!(f.enter_init(), OK);
        assert_eq!(f.exit_init(), ERROR);
        assert!(
            f.messages().iter().any(|m| m.contains(var.name())),
            "{:?}",
            f.messages()
        );
        // Still in initialization mode: a corrected value lets initialisation finish.
        let good = var.start().unwrap();
        assert_eq!(f.set(var, good), OK);
        assert_eq!(f.exit_init(), OK);
    }
}

#[test]
fn instances_stepped_from_threads_match_instances_stepped_alone() {
    fn run(name: String, seed: u64) -> Vec<u64> {
        let mut f = Fmu::initialised(&name, 80.0);
        let mut x = seed;
        let mut out = Vec::new();
        for _ in 0..2000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let sp = 55.0 + (x % 500) as f64 / 10.0;
            assert!(f.set(RealVariable::Setpoint, sp) <= sys::fmi2Status_fmi2Warning);
            assert_eq!(f.step(1.0), OK);
            out.push(
                f.get(RealVariable::Energy).1.to_bits() ^ f.get(RealVariable::Current).1.to_bits(),
            );
        }
        out
    }
    let alone: Vec<Vec<u64>> = (0..4).map(|i| run(format!("alone-{i}"), i + 1)).collect();
    let threads: Vec<_> = (0..4u64)
        .map(|i| std::thread::spawn(move || run(format!("thread-{i}"), i + 1)))
        .collect();
    for (i, t) in threads.into_iter().enumerate() {
        assert_eq!(t.join().unwrap(), alone[i], "thread {i}");
    }
}
