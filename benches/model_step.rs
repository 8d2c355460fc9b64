//! Benchmark of the pure model and of the C ABI in process (printed figures, not a test).
//!
//! cargo bench --bench model_step [-- --json target/bench/rust.json]
//!
//! Prints ns per module step (steady and wind-like setpoint, fixed and variable step size),
//! the wall time of one day at 1 s, and ns per fmi2SetReal + fmi2DoStep + fmi2GetReal
//! through the exported C functions, which is the FMU's own share of a master's call.

use std::hint::black_box;
use std::time::Instant;

use aem_electrolyser::fmi2::exports::*;
use aem_electrolyser::model_description::{RealVariable, GUID};
use aem_model::{Module, Parameters};
use fmi_sys::fmi2 as sys;

const DAY: usize = 86_400;
const REPEATS: usize = 7;

/// Deterministic wind-like setpoint [%]: a mean-reverting random walk at 1 s, 45…105 %
/// (so it crosses the clamp limits and triggers the rate limit often).
pub fn wind_like_setpoints(n: usize, seed: u64) -> Vec<f64> {
    let mut state = seed.max(1);
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut x = 80.0;
    (0..n)
        .map(|_| {
            x += 0.02 * (80.0 - x) + 3.0 * (uniform() - 0.5);
            x.clamp(45.0, 105.0)
        })
        .collect()
}

/// Best of REPEATS runs of `run` (which performs `steps` steps), in ns per step.
fn ns_per_step(steps: usize, mut run: impl FnMut() -> f64) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..REPEATS {
        let start = Instant::now();
        black_box(run());
        best = best.min(start.elapsed().as_secs_f64() * 1e9 / steps as f64);
    }
    best
}

fn model_run(setpoints: &[f64], steps: &[f64]) -> f64 {
    let mut m = Module::new(Parameters::default(), 80.0).unwrap_or_else(|e| panic!("{e}"));
    for (u, h) in setpoints.iter().zip(steps) {
        let _ = m.step(black_box(*u), black_box(*h));
    }
    m.current() + m.energy()
}

fn c_abi_run(setpoints: &[f64]) -> f64 {
    let callbacks = sys::fmi2CallbackFunctions {
        logger: None,
        allocateMemory: None,
        freeMemory: None,
        stepFinished: None,
        componentEnvironment: std::ptr::null_mut(),
    };
    let guid = std::ffi::CString::new(GUID).unwrap_or_default();
    let sp = [RealVariable::Setpoint.value_reference()];
    let outs = [
        RealVariable::Current.value_reference(),
        RealVariable::Voltage.value_reference(),
        RealVariable::Power.value_reference(),
        RealVariable::H2Flow.value_reference(),
    ];
    let mut values = [0.0; 4];
    let mut sum = 0.0;
    // SAFETY: the calls follow the FMI 2.0 sequence with valid pointers.
    unsafe {
        let c = fmi2Instantiate(
            c"bench".as_ptr(),
            sys::fmi2Type_fmi2CoSimulation,
            guid.as_ptr(),
            std::ptr::null(),
            &callbacks,
            0,
            0,
        );
        assert!(!c.is_null());
        fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
        fmi2EnterInitializationMode(c);
        fmi2ExitInitializationMode(c);
        let mut t = 0.0;
        for u in setpoints {
            fmi2SetReal(c, sp.as_ptr(), 1, u);
            fmi2DoStep(c, t, 1.0, 1);
            fmi2GetReal(c, outs.as_ptr(), outs.len(), values.as_mut_ptr());
            sum += values[0];
            t += 1.0;
        }
        fmi2FreeInstance(c);
    }
    sum
}

fn main() {
    let json_path = std::env::args().skip_while(|a| a != "--json").nth(1);
    let wind = wind_like_setpoints(DAY, 42);
    let steady = vec![80.0; DAY];
    let fixed = vec![1.0; DAY];
    let variable: Vec<f64> = wind_like_setpoints(DAY, 7)
        .iter()
        .map(|x| 0.5 + (x - 45.0) / 60.0)
        .collect();

    let steady_ns = ns_per_step(DAY, || model_run(&steady, &fixed));
    let wind_ns = ns_per_step(DAY, || model_run(&wind, &fixed));
    let variable_ns = ns_per_step(DAY, || model_run(&wind, &variable));
    let c_abi_ns = ns_per_step(DAY, || c_abi_run(&wind));
    let day_s = wind_ns * DAY as f64 * 1e-9;

    println!(
        "pure model, steady setpoint, fixed 1 s step:    {steady_ns:8.1} ns/step  ({:.1e} steps/s)",
        1e9 / steady_ns
    );
    println!(
        "pure model, wind-like setpoint, fixed 1 s step: {wind_ns:8.1} ns/step  ({:.1e} steps/s)",
        1e9 / wind_ns
    );
    println!("pure model, wind-like setpoint, variable step:  {variable_ns:8.1} ns/step  ({:.1e} steps/s)", 1e9 / variable_ns);
    println!(
        "pure model, one day at 1 s (wind-like):         {:8.4} s",
        day_s
    );
    println!("C ABI in process, setReal+doStep+getReal(4):    {c_abi_ns:8.1} ns/step");
    if let Some(path) = json_path {
        let json = format!(
            "{{\"steady_ns\": {steady_ns}, \"wind_ns\": {wind_ns}, \"variable_ns\": {variable_ns}, \"day_s\": {day_s}, \"c_abi_ns\": {c_abi_ns}}}\n"
        );
        if let Some(dir) = std::path::Path::new(&path).parent() {
            let _ = std::fs::create_dir_all(dir);
        }
        std::fs::write(&path, json).unwrap_or_else(|e| panic!("cannot write {path}: {e}"));
    }
}
