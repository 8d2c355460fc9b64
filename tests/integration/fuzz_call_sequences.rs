//! Hostile callers: random sequences of fmi2 calls with random arguments (NaN, ±inf, huge and
//! negative step sizes, wrong value references, null pointers, calls in the wrong state,
//! garbage and foreign serialised states, garbage pointers) against the C ABI in process.
//!
//! A reference state machine, written here from the FMI 2.0 standard, predicts for every call
//! whether it is valid. The FMU must never crash, never return fmi2OK/fmi2Warning for an
//! invalid request, return OK for every valid one (it keeps serving), and every Real it
//! reports while initialised must be finite.
//!
//! FUZZ_CASES (default 100 000) sets the number of sequences.

use std::ffi::CString;
use std::ptr::{null, null_mut};

use aem_electrolyser::fmi2::exports::*;
use aem_electrolyser::fmi2::variables::{integer_parameter_mut, real_parameter_mut, start_values};
use aem_electrolyser::model_description::{
    Causality, IntegerVariable, RealVariable, StringVariable, GUID,
};
use aem_model::{Parameters, PlantSettings};
use fmi_sys::fmi2 as sys;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

const OK: sys::fmi2Status = sys::fmi2Status_fmi2OK;
const WARNING: sys::fmi2Status = sys::fmi2Status_fmi2Warning;

/// States of the reference machine (section 4.2.4 of the standard).
#[derive(Clone, Copy, Debug, PartialEq)]
enum State {
    Instantiated,
    Init,
    Step,
    Terminated,
}

/// A value worth trying for a Real input or parameter.
fn real_value() -> impl Strategy<Value = f64> {
    prop_oneof![
        3 => 40.0..120.0f64,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(1e300),
        1 => Just(-1e300),
        1 => Just(0.0),
        1 => Just(-5.0),
    ]
}

/// A value reference: known ones mostly, unknown ones sometimes.
fn value_reference() -> impl Strategy<Value = u32> {
    prop_oneof![
        6 => (0..RealVariable::ALL.len()).prop_map(|i| RealVariable::ALL[i].value_reference()),
        1 => Just(29u32),
        1 => Just(99u32),
        1 => Just(u32::MAX),
    ]
}

/// How a pointer argument is passed.
#[derive(Clone, Copy, Debug)]
enum Ptr {
    Valid,
    Null,
}

fn ptr() -> impl Strategy<Value = Ptr> {
    prop_oneof![8 => Just(Ptr::Valid), 1 => Just(Ptr::Null)]
}

#[derive(Clone, Debug)]
enum Op {
    Setup {
        start: f64,
        stop: Option<f64>,
    },
    Enter,
    Exit,
    Terminate,
    Reset,
    SetReal {
        vrs: Vec<u32>,
        values: Vec<f64>,
        vr_ptr: Ptr,
        value_ptr: Ptr,
    },
    GetReal {
        vrs: Vec<u32>,
        vr_ptr: Ptr,
        value_ptr: Ptr,
    },
    /// Step from the FMU's time plus `offset` by `h`.
    DoStep {
        offset: f64,
        h: f64,
    },
    GetState,
    SetState {
        which: usize,
    },
    FreeState {
        which: usize,
    },
    Serialize {
        which: usize,
        short_by: usize,
    },
    Deserialize {
        source: usize,
        flip: Option<(usize, u8)>,
        truncate: Option<usize>,
    },
    DebugLogging {
        on: bool,
        categories: Vec<&'static str>,
    },
    NullComponent,
    GarbageComponent,
    GarbageState,
    IntegerCall {
        vr: u32,
    },
    /// A hub setting: an Integer parameter, or powerInput.
    SetSetting {
        vr: u32,
        value: i32,
    },
    /// moduleParameterFile: a null pointer, empty, or a file that does not exist.
    SetFile {
        path: Option<&'static str>,
    },
    Unsupported {
        which: u8,
    },
    InputDerivative {
        vr: u32,
        order: i32,
        value: f64,
    },
    Status {
        kind: u32,
    },
}

fn op() -> impl Strategy<Value = Op> {
    let offsets =
        prop_oneof![6 => Just(0.0), 1 => Just(1.0), 1 => Just(-1e-3), 1 => Just(f64::NAN)];
    let steps = prop_oneof![
        6 => 1e-3..120.0f64,
        1 => Just(0.0),
        1 => Just(-1.0),
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(1e300),
    ];
    let categories = prop::collection::vec(
        prop_oneof![
            Just("logEvents"),
            Just("logAll"),
            Just("logStatusError"),
            Just("nope")
        ],
        0..3,
    );
    prop_oneof![
        2 => (real_value(), prop::option::of(real_value())).prop_map(|(start, stop)| Op::Setup { start, stop }),
        3 => Just(Op::Enter),
        3 => Just(Op::Exit),
        1 => Just(Op::Terminate),
        1 => Just(Op::Reset),
        6 => (prop::collection::vec((value_reference(), real_value()), 0..4), ptr(), ptr()).prop_map(|(pairs, vr_ptr, value_ptr)| {
            let (vrs, values) = pairs.into_iter().unzip();
            Op::SetReal { vrs, values, vr_ptr, value_ptr }
        }),
        4 => (prop::collection::vec(value_reference(), 0..4), ptr(), ptr()).prop_map(|(vrs, vr_ptr, value_ptr)| Op::GetReal { vrs, vr_ptr, value_ptr }),
        8 => (offsets, steps).prop_map(|(offset, h)| Op::DoStep { offset, h }),
        2 => Just(Op::GetState),
        2 => (0usize..4).prop_map(|which| Op::SetState { which }),
        1 => (0usize..4).prop_map(|which| Op::FreeState { which }),
        1 => (0usize..4, 0usize..3).prop_map(|(which, short_by)| Op::Serialize { which, short_by }),
        2 => (0usize..4, prop::option::of((0usize..400, 1u8..=255)), prop::option::of(0usize..400))
            .prop_map(|(source, flip, truncate)| Op::Deserialize { source, flip, truncate }),
        1 => (any::<bool>(), categories).prop_map(|(on, categories)| Op::DebugLogging { on, categories }),
        1 => Just(Op::NullComponent),
        1 => Just(Op::GarbageComponent),
        1 => Just(Op::GarbageState),
        1 => prop_oneof![Just(0u32), Just(5u32)].prop_map(|vr| Op::IntegerCall { vr }),
        2 => (
            prop_oneof![4 => (0..IntegerVariable::ALL.len()).prop_map(|i| IntegerVariable::ALL[i].value_reference()), 1 => Just(300u32)],
            prop_oneof![6 => -1..6i32, 1 => Just(40i32), 1 => Just(i32::MAX), 1 => Just(i32::MIN)]
        )
            .prop_map(|(vr, value)| Op::SetSetting { vr, value }),
        1 => prop_oneof![Just(None), Just(Some("")), Just(Some("/nonexistent/params.json"))].prop_map(|path| Op::SetFile { path }),
        1 => (1u8..4).prop_map(|which| Op::Unsupported { which }),
        3 => (value_reference(), prop_oneof![4 => Just(1i32), 1 => Just(0i32), 1 => Just(2i32)], prop_oneof![4 => -3.0..3.0f64, 1 => Just(f64::NAN)])
            .prop_map(|(vr, order, value)| Op::InputDerivative { vr, order, value }),
        1 => (0u32..5).prop_map(|kind| Op::Status { kind }),
    ]
}

/// The reference machine's view of the instance: everything a saved state restores.
#[derive(Clone, Debug)]
struct View {
    state: State,
    time: f64,
    stop: Option<f64>,
    params: Parameters,
    settings: PlantSettings,
    file: String,
}

impl View {
    fn fresh() -> View {
        let (params, settings, _) = start_values();
        View {
            state: State::Instantiated,
            time: 0.0,
            stop: None,
            params,
            settings,
            file: String::new(),
        }
    }

    /// Whether fmi2ExitInitializationMode succeeds: valid parameters and settings, a power
    /// reference needs a polarisation curve that draws power, and the reserve control's zero
    /// lies between the module's poles.
    fn initialisable(&self) -> bool {
        let p = &self.params;
        let power_without_curve =
            self.settings.power_input && p.voltage_intercept == 0.0 && p.ohmic_resistance == 0.0;
        let (lo, hi) = p.filter_zero_range();
        let zero = self.settings.reserve.filter_zero;
        let zero_between_poles = !(zero > 0.0) || (lo..=hi).contains(&zero);
        zero_between_poles
            && p.validate().is_ok()
            && self.file.is_empty()
            && self
                .settings
                .config()
                .is_ok_and(|c| c.is_single_module() || !power_without_curve)
    }

    /// Whether a single module, which integrates a setpoint slope, is simulated (also while
    /// the settings are invalid: the FMU then cannot know better).
    fn single_module(&self) -> bool {
        self.file.is_empty()
            && !self.settings.power_input
            && self
                .settings
                .config()
                .map_or(true, |c| c.is_single_module())
    }
}

/// The instance under test, the reference view of it, and what it has handed out.
struct Harness {
    c: sys::fmi2Component,
    _callbacks: Box<sys::fmi2CallbackFunctions>,
    view: View,
    states: Vec<(sys::fmi2FMUstate, View)>,
    serialized: Vec<(Vec<u8>, View)>,
}

/// Parameters of physically sensible magnitude, for which every valid step must succeed.
fn moderate(p: &Parameters, s: &PlantSettings) -> bool {
    let values = [
        p.gain,
        p.tau_zero,
        p.tau_pole1,
        p.tau_pole2,
        p.ramp_up_limit,
        p.voltage_intercept,
        p.ohmic_resistance,
        p.h2_coefficient,
        p.nominal_current,
        p.min_setpoint,
        p.max_setpoint,
        s.hysteresis,
        s.cold_start_time,
        s.warm_start_time,
        s.start_power,
        s.standby_power,
        s.standby_duration,
        s.stop_duration,
    ];
    values.iter().all(|v| v.abs() <= 1e6) && s.n_modules <= 1000
}

fn is_ok(status: sys::fmi2Status) -> bool {
    status == OK || status == WARNING
}

impl Harness {
    fn new() -> Harness {
        let callbacks = Box::new(sys::fmi2CallbackFunctions {
            logger: None,
            allocateMemory: None,
            freeMemory: None,
            stepFinished: None,
            componentEnvironment: null_mut(),
        });
        let guid = CString::new(GUID).unwrap();
        // SAFETY: valid strings and callbacks that outlive the instance.
        let c = unsafe {
            fmi2Instantiate(
                c"fuzz".as_ptr(),
                sys::fmi2Type_fmi2CoSimulation,
                guid.as_ptr(),
                null(),
                &*callbacks,
                0,
                0,
            )
        };
        assert!(!c.is_null());
        Harness {
            c,
            _callbacks: callbacks,
            view: View::fresh(),
            states: Vec::new(),
            serialized: Vec::new(),
        }
    }

    fn allowed(&self, allowed: &[State]) -> bool {
        allowed.contains(&self.view.state)
    }

    /// Applies `op`, checking the FMU's answer against the reference machine.
    fn apply(&mut self, op: &Op) -> Result<(), TestCaseError> {
        use State::*;
        let c = self.c;
        unsafe {
            match op {
                Op::Setup { start, stop } => {
                    let s = fmi2SetupExperiment(
                        c,
                        0,
                        0.0,
                        *start,
                        stop.is_some() as i32,
                        stop.unwrap_or(0.0),
                    );
                    let valid = self.allowed(&[Instantiated])
                        && start.is_finite()
                        && stop.is_none_or(|stop| stop >= *start);
                    prop_assert_eq!(is_ok(s), valid, "setup {:?} in {:?}", op, self.view.state);
                    if valid {
                        self.view.time = *start;
                        self.view.stop = *stop;
                    }
                }
                Op::Enter => {
                    let s = fmi2EnterInitializationMode(c);
                    prop_assert_eq!(is_ok(s), self.allowed(&[Instantiated]));
                    if is_ok(s) {
                        self.view.state = Init;
                    }
                }
                Op::Exit => {
                    let s = fmi2ExitInitializationMode(c);
                    let valid = self.allowed(&[Init]) && self.view.initialisable();
                    prop_assert_eq!(
                        is_ok(s),
                        valid,
                        "exit in {:?} with {:?} {:?}",
                        self.view.state,
                        self.view.params,
                        self.view.settings
                    );
                    if valid {
                        self.view.state = Step;
                    }
                }
                Op::Terminate => {
                    let s = fmi2Terminate(c);
                    prop_assert_eq!(is_ok(s), self.allowed(&[Step]));
                    if is_ok(s) {
                        self.view.state = Terminated;
                    }
                }
                Op::Reset => {
                    prop_assert!(is_ok(fmi2Reset(c)), "reset is allowed in every state");
                    self.view = View::fresh();
                }
                Op::SetReal {
                    vrs,
                    values,
                    vr_ptr,
                    value_ptr,
                } => {
                    let n = vrs.len();
                    let vp = if matches!(vr_ptr, Ptr::Null) {
                        null()
                    } else {
                        vrs.as_ptr()
                    };
                    let xp = if matches!(value_ptr, Ptr::Null) {
                        null()
                    } else {
                        values.as_ptr()
                    };
                    let s = fmi2SetReal(c, vp, n, xp);
                    let pointers_ok =
                        n == 0 || (matches!(vr_ptr, Ptr::Valid) && matches!(value_ptr, Ptr::Valid));
                    let mut valid = self.allowed(&[Instantiated, Init, Step]) && pointers_ok;
                    for (vr, x) in vrs.iter().zip(values) {
                        let Some(var) = RealVariable::from_value_reference(*vr) else {
                            valid = false;
                            continue;
                        };
                        match var.causality() {
                            Causality::Output => valid = false,
                            Causality::Parameter if self.view.state == Step => valid = false,
                            _ => {}
                        }
                        // A temperature in kelvin is positive.
                        if !x.is_finite() || (var == RealVariable::AmbientTemperature && *x <= 0.0)
                        {
                            valid = false;
                        }
                    }
                    prop_assert_eq!(is_ok(s), valid, "setReal {:?} in {:?}", op, self.view.state);
                    if valid {
                        for (vr, x) in vrs.iter().zip(values) {
                            let var = RealVariable::from_value_reference(*vr).unwrap();
                            if let Some(field) = real_parameter_mut(
                                &mut self.view.params,
                                &mut self.view.settings,
                                var,
                            ) {
                                *field = *x;
                            }
                        }
                    }
                }
                Op::GetReal {
                    vrs,
                    vr_ptr,
                    value_ptr,
                } => {
                    let n = vrs.len();
                    let mut out = vec![f64::NAN; n];
                    let vp = if matches!(vr_ptr, Ptr::Null) {
                        null()
                    } else {
                        vrs.as_ptr()
                    };
                    let xp = if matches!(value_ptr, Ptr::Null) {
                        null_mut()
                    } else {
                        out.as_mut_ptr()
                    };
                    let s = fmi2GetReal(c, vp, n, xp);
                    let pointers_ok =
                        n == 0 || (matches!(vr_ptr, Ptr::Valid) && matches!(value_ptr, Ptr::Valid));
                    let known = vrs
                        .iter()
                        .all(|vr| RealVariable::from_value_reference(*vr).is_some());
                    let allowed = self.allowed(&[Init, Step, Terminated]);
                    let outputs = vrs.iter().any(|vr| {
                        RealVariable::from_value_reference(*vr)
                            .is_some_and(|v| v.causality() == Causality::Output)
                    });
                    // In initialization mode outputs follow from the parameters, if valid.
                    let computable =
                        self.view.state != Init || !outputs || self.view.initialisable();
                    if !(allowed && pointers_ok && known && computable) {
                        prop_assert!(
                            !is_ok(s),
                            "getReal {:?} in {:?} must fail",
                            op,
                            self.view.state
                        );
                    } else {
                        prop_assert!(
                            is_ok(s),
                            "getReal {:?} in {:?} must succeed",
                            op,
                            self.view.state
                        );
                        for x in &out {
                            prop_assert!(
                                x.is_finite(),
                                "getReal returned {} in {:?}",
                                x,
                                self.view.state
                            );
                        }
                    }
                }
                Op::DoStep { offset, h } => {
                    let point = self.view.time + offset;
                    let s = fmi2DoStep(c, point, *h, 1);
                    // The documented contract: the point may differ from the FMU's time by 1e-9
                    // relative (masters sum their steps differently); the FMU keeps its own time.
                    let on_time =
                        (point - self.view.time).abs() <= 1e-9 * self.view.time.abs().max(1.0);
                    // Steps past a defined stopTime are refused (FMI 2.0, section 2.1.6).
                    let before_stop = self
                        .view
                        .stop
                        .is_none_or(|stop| self.view.time + h <= stop + 1e-9 * stop.abs().max(1.0));
                    let valid = self.allowed(&[Step])
                        && on_time
                        && h.is_finite()
                        && *h > 0.0
                        && before_stop;
                    if !valid {
                        prop_assert!(
                            !is_ok(s),
                            "doStep {:?} in {:?} must fail",
                            op,
                            self.view.state
                        );
                    } else if *h < 1e6 && moderate(&self.view.params, &self.view.settings) {
                        // (Huge steps or parameters may overflow the energy total: refusing
                        // those is correct; accepting them with non-finite outputs is not.)
                        prop_assert!(is_ok(s), "doStep {:?} must succeed", op);
                    }
                    if is_ok(s) {
                        // The FMU resynchronises to the master's clock.
                        self.view.time = point + h;
                        // Time stays what the master expects.
                        let mut t = f64::NAN;
                        prop_assert!(is_ok(fmi2GetRealStatus(
                            c,
                            sys::fmi2StatusKind_fmi2LastSuccessfulTime,
                            &mut t
                        )));
                        prop_assert_eq!(t.to_bits(), self.view.time.to_bits());
                    }
                }
                Op::GetState => {
                    let mut st: sys::fmi2FMUstate = null_mut();
                    let s = fmi2GetFMUstate(c, &mut st);
                    prop_assert!(
                        is_ok(s) && !st.is_null(),
                        "getFMUstate is allowed in every state"
                    );
                    self.states.push((st, self.view.clone()));
                }
                Op::SetState { which } => {
                    if let Some((st, view)) = self.states.get(*which) {
                        let s = fmi2SetFMUstate(c, *st);
                        prop_assert!(is_ok(s));
                        self.view = view.clone();
                    } else {
                        prop_assert!(!is_ok(fmi2SetFMUstate(c, null_mut())));
                    }
                }
                Op::FreeState { which } => {
                    if *which < self.states.len() {
                        let (mut st, _) = self.states.remove(*which);
                        prop_assert!(is_ok(fmi2FreeFMUstate(c, &mut st)));
                        prop_assert!(st.is_null());
                    } else {
                        let mut st: sys::fmi2FMUstate = null_mut();
                        prop_assert!(
                            is_ok(fmi2FreeFMUstate(c, &mut st)),
                            "freeing a null state is a no-op"
                        );
                    }
                }
                Op::Serialize { which, short_by } => {
                    if let Some((st, view)) = self.states.get(*which) {
                        let mut size = 0usize;
                        prop_assert!(is_ok(fmi2SerializedFMUstateSize(c, *st, &mut size)));
                        let mut buf = vec![0u8; size];
                        let s = fmi2SerializeFMUstate(
                            c,
                            *st,
                            buf.as_mut_ptr() as *mut sys::fmi2Byte,
                            size - short_by,
                        );
                        prop_assert_eq!(is_ok(s), *short_by == 0);
                        if is_ok(s) {
                            self.serialized.push((buf, view.clone()));
                        }
                    }
                }
                Op::Deserialize {
                    source,
                    flip,
                    truncate,
                } => {
                    if let Some((bytes, view)) = self.serialized.get(*source).cloned() {
                        let mut b = bytes.clone();
                        if let Some((i, x)) = flip {
                            let i = i % b.len();
                            b[i] ^= x;
                        }
                        if let Some(n) = truncate {
                            b.truncate(*n);
                        }
                        let mut st: sys::fmi2FMUstate = null_mut();
                        let s = fmi2DeSerializeFMUstate(
                            c,
                            b.as_ptr() as *const sys::fmi2Byte,
                            b.len(),
                            &mut st,
                        );
                        prop_assert_eq!(is_ok(s), b == bytes, "only intact bytes may deserialise");
                        if is_ok(s) {
                            self.states.push((st, view));
                        }
                    }
                }
                Op::DebugLogging { on, categories } => {
                    let names: Vec<CString> = categories
                        .iter()
                        .map(|n| CString::new(*n).unwrap())
                        .collect();
                    let ptrs: Vec<sys::fmi2String> = names.iter().map(|n| n.as_ptr()).collect();
                    let s = fmi2SetDebugLogging(c, *on as i32, ptrs.len(), ptrs.as_ptr());
                    prop_assert_eq!(is_ok(s), !categories.contains(&"nope"));
                }
                Op::NullComponent => {
                    prop_assert!(!is_ok(fmi2DoStep(null_mut(), 0.0, 1.0, 1)));
                    prop_assert!(!is_ok(fmi2EnterInitializationMode(null_mut())));
                    fmi2FreeInstance(null_mut());
                }
                Op::GarbageComponent => {
                    // Readable memory that is not an instance: refused by its magic.
                    let mut garbage = [0x5a5a_5a5a_5a5a_5a5au64; 512];
                    let g = garbage.as_mut_ptr() as sys::fmi2Component;
                    prop_assert!(!is_ok(fmi2DoStep(g, 0.0, 1.0, 1)));
                    prop_assert!(!is_ok(fmi2Reset(g)));
                }
                Op::GarbageState => {
                    let mut garbage = [0xa5a5_a5a5_a5a5_a5a5u64; 512];
                    prop_assert!(!is_ok(fmi2SetFMUstate(
                        c,
                        garbage.as_mut_ptr() as sys::fmi2FMUstate
                    )));
                    let mut p = garbage.as_mut_ptr() as sys::fmi2FMUstate;
                    prop_assert!(!is_ok(fmi2FreeFMUstate(c, &mut p)));
                }
                Op::IntegerCall { vr } => {
                    let vrs = [*vr];
                    let mut v = 0;
                    prop_assert!(!is_ok(fmi2GetInteger(c, vrs.as_ptr(), 1, &mut v)));
                    prop_assert!(!is_ok(fmi2SetBoolean(c, vrs.as_ptr(), 1, &v)));
                }
                Op::SetSetting { vr, value } => {
                    let vrs = [*vr];
                    let s = if *vr == 300 {
                        fmi2SetBoolean(c, vrs.as_ptr(), 1, value)
                    } else {
                        fmi2SetInteger(c, vrs.as_ptr(), 1, value)
                    };
                    let parameter = *vr == 300
                        || IntegerVariable::from_value_reference(*vr)
                            .is_some_and(|v| v.causality() == Causality::Parameter);
                    let valid = self.allowed(&[Instantiated, Init]) && parameter;
                    prop_assert_eq!(is_ok(s), valid, "{:?} in {:?}", op, self.view.state);
                    if valid {
                        if *vr == 300 {
                            self.view.settings.power_input = *value != 0;
                        } else if let Some(field) = IntegerVariable::from_value_reference(*vr)
                            .and_then(|v| integer_parameter_mut(&mut self.view.settings, v))
                        {
                            *field = *value;
                        }
                    }
                    // Every Integer reads back (outputs once computable).
                    let mut back = 0;
                    let s = fmi2GetInteger(c, vrs.as_ptr(), 1, &mut back);
                    if *vr != 300
                        && self.allowed(&[Init, Step, Terminated])
                        && (self.view.state != Init || self.view.initialisable())
                    {
                        prop_assert!(is_ok(s), "getInteger {} in {:?}", vr, self.view.state);
                    }
                }
                Op::SetFile { path } => {
                    let vrs = [StringVariable::ModuleParameterFile.value_reference()];
                    let text = path.map(|p| CString::new(p).unwrap());
                    let values = [text.as_ref().map_or(null(), |t| t.as_ptr())];
                    let s = fmi2SetString(c, vrs.as_ptr(), 1, values.as_ptr());
                    let valid = self.allowed(&[Instantiated, Init]) && path.is_some();
                    prop_assert_eq!(is_ok(s), valid, "{:?} in {:?}", op, self.view.state);
                    if valid {
                        self.view.file = path.unwrap_or_default().to_string();
                    }
                }
                Op::Unsupported { which } => {
                    let vrs = [0u32];
                    let order = [1i32];
                    let mut x = 0.0;
                    let s = match which {
                        1 => {
                            fmi2GetRealOutputDerivatives(c, vrs.as_ptr(), 1, order.as_ptr(), &mut x)
                        }
                        2 => fmi2GetDirectionalDerivative(
                            c,
                            vrs.as_ptr(),
                            1,
                            vrs.as_ptr(),
                            1,
                            &1.0,
                            &mut x,
                        ),
                        _ => fmi2CancelStep(c),
                    };
                    prop_assert!(!is_ok(s));
                }
                Op::InputDerivative { vr, order, value } => {
                    let vrs = [*vr];
                    let orders = [*order];
                    let s = fmi2SetRealInputDerivatives(c, vrs.as_ptr(), 1, orders.as_ptr(), value);
                    // Orders above 1 are accepted (with a warning) and ignored; 0 is not an order.
                    // A hub holds its inputs over a step: it refuses a non-zero first derivative
                    // of the input that drives it.
                    let input = RealVariable::from_value_reference(*vr)
                        .filter(|v| v.causality() == Causality::Input);
                    // The frequency drives the reserves, if any are offered, the ambient
                    // temperature the thermal model, if on; both are always held.
                    let held = matches!(
                        input,
                        Some(RealVariable::Frequency | RealVariable::AmbientTemperature)
                    );
                    let drives = input.is_some_and(|v| match v {
                        RealVariable::Frequency => self.view.settings.reserve.offered(),
                        RealVariable::AmbientTemperature => self.view.settings.thermal_model,
                        _ => (v == RealVariable::PowerReference) == self.view.settings.power_input,
                    });
                    let hub_refuses = *order == 1
                        && *value != 0.0
                        && drives
                        && (held || !self.view.single_module());
                    let valid = self.allowed(&[Instantiated, Init, Step])
                        && input.is_some()
                        && *order >= 1
                        && value.is_finite()
                        && !hub_refuses;
                    prop_assert_eq!(is_ok(s), valid, "{:?} in {:?}", op, self.view.state);
                }
                Op::Status { kind } => {
                    let mut s_out = OK;
                    let mut b = 0;
                    let s = fmi2GetStatus(c, *kind, &mut s_out);
                    prop_assert!(!is_ok(s), "no status kind is available from fmi2GetStatus");
                    let s = fmi2GetBooleanStatus(c, *kind, &mut b);
                    let valid = self.allowed(&[Step, Terminated])
                        && *kind == sys::fmi2StatusKind_fmi2Terminated;
                    prop_assert_eq!(is_ok(s), valid);
                }
            }
        }
        Ok(())
    }
}

impl Drop for Harness {
    fn drop(&mut self) {
        if self.c.is_null() {
            return;
        }
        unsafe {
            for (mut st, _) in self.states.drain(..) {
                fmi2FreeFMUstate(self.c, &mut st);
            }
            fmi2FreeInstance(self.c);
        }
    }
}

#[test]
fn random_call_sequences_never_crash_and_never_accept_invalid_requests() {
    let cases: u32 = std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100_000);
    // A fixed seed by default, so that CI is reproducible; FUZZ_SEED=<u64> picks another and
    // FUZZ_SEED=random a fresh one (printed, to replay a failure).
    let seed: u64 = match std::env::var("FUZZ_SEED").ok().as_deref() {
        Some("random") => std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(1, |d| d.as_nanos() as u64),
        Some(text) => text.parse().expect("FUZZ_SEED: a u64 or `random`"),
        None => 0x00AE_E1EC_7201_15E2,
    };
    eprintln!("fuzz: seed {seed}");
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed.to_le_bytes());
    let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &key);
    let mut runner = TestRunner::new_with_rng(
        Config {
            cases,
            failure_persistence: None,
            ..Config::default()
        },
        rng,
    );
    let started = std::time::Instant::now();
    let result = runner.run(&prop::collection::vec(op(), 1..40), |ops| {
        let mut h = Harness::new();
        for op in &ops {
            h.apply(op)?;
        }
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    eprintln!(
        "fuzz: {cases} random call sequences in {:.1} s",
        started.elapsed().as_secs_f64()
    );
}
