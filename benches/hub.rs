//! Benchmark: one day at 1 s of a 25 000-module hub (a 60 MW class plant of 2.4 kW modules)
//! following a seeded wind-like power reference, driven through the pure model and through
//! the FMU's C interface (fmi2SetReal of the reference, fmi2DoStep, fmi2GetReal of the hub's
//! power every second, as a master does).
//!
//! cargo bench --bench hub
//!
//! Cases: `equal` (one group), `sequential` (a few groups), the sequential hub with every
//! module's stack temperature modelled (its time as a ratio to the sequential's, same run),
//! and 25 000 individual parameter sets (±3 % seeded spread around Table I, equal dispatch: 25 000 groups of one, stepped four
//! at a time in lanes and on every core). `cargo bench --bench hub -- NAME` runs the cases
//! whose name contains NAME.
//! Prints wall seconds per simulated day and the hardware. Targets from issue 4:
//! ≤ 0.5 s, ≤ 1 s, ≤ 15 s.

use std::time::Instant;

use aem_electrolyser::fmi2::exports::*;
use aem_electrolyser::model_description::{BooleanVariable, IntegerVariable, RealVariable, GUID};
use aem_model::dispatch::power_at_setpoint;
use aem_model::spread::spread_parameters;
use aem_model::{
    AgeingParameters, BelowMinimum, Demand, DispatchPolicy, Hub, HubConfig, OperationParameters,
    Parameters, ThermalParameters,
};
use fmi_sys::fmi2 as sys;

const DAY: usize = 86_400;
const MODULES: u32 = 25_000;

/// Seeded wind-like hub power reference [W]: a mean-reverting random walk at 1 s between
/// 5 % and 100 % of the hub's rated power, with gusts.
fn wind_reference(n: usize, rated: f64, seed: u64) -> Vec<f64> {
    let mut state = seed.max(1);
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut x: f64 = 0.6;
    (0..n)
        .map(|_| {
            x += 0.001 * (0.6 - x) + 0.01 * (uniform() - 0.5);
            x = x.clamp(0.05, 1.0);
            x * rated
        })
        .collect()
}

fn hardware() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    format!(
        "{cpu}, {cores} logical cores; equal and sequential run on one, individual parameters on {} (rayon; RAYON_NUM_THREADS)",
        rayon::current_num_threads()
    )
}

/// Runs the day; the wall seconds it took (None if a step failed).
fn run(name: &str, mut hub: Hub, reference: &[f64], target: f64) -> Option<f64> {
    let start = Instant::now();
    let mut max_groups = 0;
    for &p in reference {
        if let Err(e) = hub.step(Demand::Power(p), 1.0) {
            eprintln!("{name}: step failed: {e}");
            return None;
        }
        max_groups = max_groups.max(hub.groups().len());
    }
    let secs = start.elapsed().as_secs_f64();
    let t = hub.totals();
    println!(
        "{name:<28} {secs:8.3} s/day (target <= {target} s)  groups max {max_groups:>6}  energy {:.1} MWh  H2 {:.0} kg  starts {}",
        t.energy / 3.6e9,
        t.h2_produced * aem_model::hub::H2_KG_PER_NL,
        t.starts
    );
    Some(secs)
}

/// The hub through the C interface for the whole reference (one day).
fn run_c_abi(name: &str, dispatch: i32, spread: f64, reference: &[f64], target: f64) {
    let callbacks = sys::fmi2CallbackFunctions {
        logger: None,
        allocateMemory: None,
        freeMemory: None,
        stepFinished: None,
        componentEnvironment: std::ptr::null_mut(),
    };
    let guid = std::ffi::CString::new(GUID).unwrap_or_default();
    let ints = [
        IntegerVariable::NModules,
        IntegerVariable::Dispatch,
        IntegerVariable::BelowMinimum,
    ]
    .map(|v| v.value_reference());
    let int_values = [MODULES as i32, dispatch, 1];
    let power_input = [BooleanVariable::PowerInput.value_reference()];
    let reference_vr = [RealVariable::PowerReference.value_reference()];
    let spread_vr = [RealVariable::ParameterSpread.value_reference()];
    let out = [RealVariable::HubPower.value_reference()];
    let energy_vr = [RealVariable::HubEnergy.value_reference()];
    let (mut power, mut energy) = (0.0, 0.0);
    let start = Instant::now();
    // SAFETY: the calls follow the FMI 2.0 sequence with valid pointers; hubPower is read
    // every step, as a master does.
    let ok = unsafe {
        let c = fmi2Instantiate(
            c"bench".as_ptr(),
            sys::fmi2Type_fmi2CoSimulation,
            guid.as_ptr(),
            std::ptr::null(),
            &callbacks,
            0,
            0,
        );
        let mut ok = !c.is_null()
            && fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0) == 0
            && fmi2SetInteger(c, ints.as_ptr(), ints.len(), int_values.as_ptr()) == 0
            && fmi2SetBoolean(c, power_input.as_ptr(), 1, &1) == 0
            && fmi2SetReal(c, spread_vr.as_ptr(), 1, &spread) == 0
            && fmi2SetReal(c, reference_vr.as_ptr(), 1, &reference[0]) == 0
            && fmi2EnterInitializationMode(c) == 0
            && fmi2ExitInitializationMode(c) == 0;
        let mut t = 0.0;
        for p in reference {
            if !ok {
                break;
            }
            ok = fmi2SetReal(c, reference_vr.as_ptr(), 1, p) == 0
                && fmi2DoStep(c, t, 1.0, 1) == 0
                && fmi2GetReal(c, out.as_ptr(), 1, &mut power) == 0;
            t += 1.0;
        }
        ok = ok && fmi2GetReal(c, energy_vr.as_ptr(), 1, &mut energy) == 0;
        if !c.is_null() {
            fmi2FreeInstance(c);
        }
        ok
    };
    let secs = start.elapsed().as_secs_f64();
    if !ok {
        eprintln!("{name}: a call failed");
        return;
    }
    println!("{name:<28} {secs:8.3} s/day (target <= {target} s)  energy {:.1} MWh  power at the end {:.1} MW", energy / 3.6e9, power / 1e6);
}

fn main() {
    // `cargo bench --bench hub -- NAME` runs only the cases whose name contains NAME.
    let filter = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with('-'))
        .unwrap_or_default();
    let wanted = |name: &str| name.contains(filter.as_str());
    println!("hardware: {}", hardware());
    let base = Parameters::default();
    let rated = MODULES as f64 * power_at_setpoint(&base, base.max_setpoint);
    let reference = wind_reference(DAY, rated, 42);
    let op = OperationParameters {
        below_minimum: BelowMinimum::Standby,
        ..Default::default()
    };
    let config = |policy| HubConfig {
        n_modules: MODULES,
        policy,
        hysteresis: 5.0,
        operation: op,
        ..HubConfig::default()
    };
    let first = Demand::Power(reference[0]);
    let equal = Hub::new(base, config(DispatchPolicy::Equal), first);
    let sequential = Hub::new(base, config(DispatchPolicy::Sequential), first);
    // The same sequential hub with every module's stack temperature modelled (defaults).
    let thermal = Hub::new(
        base,
        HubConfig {
            thermal: Some(ThermalParameters::default()),
            ..config(DispatchPolicy::Sequential)
        },
        first,
    );
    // The same with ageing (a drift of 1 mV per running hour, 2 mV per start and 0.3 V
    // reversible), without and with the stack temperature.
    let ageing = AgeingParameters {
        drift_per_running_hour: 1e-3,
        drift_per_start: 2e-3,
        reversible_drift: 0.3,
        ..AgeingParameters::default()
    };
    let aged = |thermal: Option<ThermalParameters>| {
        Hub::new(
            base,
            HubConfig {
                thermal,
                operation: OperationParameters { ageing, ..op },
                ..config(DispatchPolicy::Sequential)
            },
            first,
        )
    };
    let (aged_plain, aged_thermal) = (aged(None), aged(Some(ThermalParameters::default())));
    // Seed 1: the FMU's default spreadSeed, so that both runs simulate the same hub.
    let sets = spread_parameters(&base, MODULES as usize, 0.03, 1);
    let individual = Hub::with_parameter_sets(sets, config(DispatchPolicy::Equal), first);
    match (
        equal,
        sequential,
        individual,
        thermal,
        aged_plain,
        aged_thermal,
    ) {
        (Ok(e), Ok(s), Ok(i), Ok(th), Ok(ap), Ok(at)) => {
            println!("one day at 1 s, {MODULES} modules, rated {:.1} MW, wind-like power reference (seed 42)", rated / 1e6);
            if wanted("equal") {
                run("equal", e, &reference, 0.5);
            }
            let plain = wanted("sequential")
                .then(|| run("sequential", s, &reference, 1.0))
                .flatten();
            let warm = wanted("sequential, stack temperature")
                .then(|| run("sequential, stack temperature", th, &reference, 2.0))
                .flatten();
            if let (Some(plain), Some(warm)) = (plain, warm) {
                println!(
                    "  the stack temperature costs {:.2}x the sequential hub's time (target <= 2x, same run)",
                    warm / plain
                );
            }
            let drifting = wanted("sequential, ageing")
                .then(|| run("sequential, ageing", ap, &reference, 2.0))
                .flatten();
            let both = wanted("sequential, temperature and ageing")
                .then(|| run("sequential, temperature and ageing", at, &reference, 2.0))
                .flatten();
            for (what, time) in [
                ("ageing", drifting),
                ("the stack temperature and ageing", both),
            ] {
                if let (Some(plain), Some(time)) = (plain, time) {
                    println!(
                        "  {what} costs {:.2}x the sequential hub's time (target <= 2x, same run)",
                        time / plain
                    );
                }
            }
            if wanted("individual parameters (eq)") {
                run("individual parameters (eq)", i, &reference, 15.0);
            }
            println!("the same through the FMU's C interface:");
            if wanted("C ABI equal") {
                run_c_abi("C ABI equal", 1, 0.0, &reference, 0.5);
            }
            if wanted("C ABI sequential") {
                run_c_abi("C ABI sequential", 2, 0.0, &reference, 1.0);
            }
            if wanted("C ABI individual parameters") {
                run_c_abi("C ABI individual parameters", 1, 0.03, &reference, 15.0);
            }
        }
        (e, s, i, th, ap, at) => eprintln!(
            "cannot build the hubs: {:?} {:?} {:?} {:?} {:?} {:?}",
            e.err(),
            s.err(),
            i.err(),
            th.err(),
            ap.err(),
            at.err()
        ),
    }
}
