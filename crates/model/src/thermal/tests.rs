//! The heat balance against closed forms and conservation: steady states in each regime,
//! the free cool-down, the energy balance along a moving current, and step-size independence.

use super::step::{advance, integrate, CurrentPath, ThermalStep};
use super::*;
use crate::ageing::DriftChange;

/// A current that the test knows in closed form.
struct Path<F: Fn(f64) -> f64>(F, Option<f64>);

impl<F: Fn(f64) -> f64> CurrentPath for Path<F> {
    fn current(&self, tau: f64) -> f64 {
        (self.0)(tau)
    }
    fn constant(&self) -> Option<f64> {
        self.1
    }
}

fn balance(thermal: ThermalParameters, ambient: f64) -> HeatBalance {
    HeatBalance {
        thermal,
        voltage_intercept: 35.75,
        ohmic_resistance: 0.1529,
        ambient,
        heater: 0.0,
    }
}

/// Temperature where heat = loss + cooling at constant current I, from the equation written
/// out (not from the code's α, β): (V0 + kV·ΔT + (R + kR·ΔT)·I − n·1.481)·I = (T − Ta)/Rth + Qc.
fn steady_temperature(b: &HeatBalance, current: f64, cooling: f64) -> f64 {
    let p = &b.thermal;
    let n_e = f64::from(p.n_cells) * 1.481;
    // Linear in ΔT = T − Tn: c0 + c1·ΔT = 0.
    let c0 = (b.voltage_intercept + b.ohmic_resistance * current - n_e) * current
        - (p.nominal_temperature - b.ambient) / p.thermal_resistance
        - cooling;
    let c1 = (p.voltage_temperature_coefficient + p.resistance_temperature_coefficient * current)
        * current
        - 1.0 / p.thermal_resistance;
    p.nominal_temperature - c0 / c1
}

/// Runs `steps` steps of `h` along `current(t)` (absolute time), constant if `constant`.
fn run(
    b: &HeatBalance,
    t0: f64,
    current: impl Fn(f64) -> f64 + Copy,
    constant: bool,
    h: f64,
    steps: usize,
) -> (f64, ThermalStep) {
    let mut temperature = t0;
    let mut sum = ThermalStep::default();
    for k in 0..steps {
        let start = k as f64 * h;
        let path = Path(
            move |tau| current(start + tau),
            constant.then(|| current(start)),
        );
        let s = advance(b, temperature, &path, h).unwrap();
        temperature = s.temperature;
        sum.temperature_integral += s.temperature_integral;
        sum.heat_charge += s.heat_charge;
        sum.heat_squared += s.heat_squared;
        sum.cooling_energy += s.cooling_energy;
        sum.regime_changes += s.regime_changes;
    }
    sum.temperature = temperature;
    (temperature, sum)
}

#[test]
fn below_the_setpoint_the_stack_settles_where_heat_equals_loss() {
    // Setpoint out of reach: no cooling, T_ss from the balance written out.
    let p = ThermalParameters {
        cooling_setpoint: 500.0,
        ..ThermalParameters::default()
    };
    let b = balance(p, 288.15);
    let expected = steady_temperature(&b, 40.0, 0.0);
    assert!(expected > 300.0 && expected < 400.0, "{expected}");
    for constant in [true, false] {
        let (t, _) = run(&b, 288.15, |_| 40.0, constant, 3600.0, 30);
        assert!((t - expected).abs() < 1e-6, "{constant}: {t} vs {expected}");
    }
}

#[test]
fn the_thermostat_holds_the_setpoint_and_cools_the_surplus() {
    let b = balance(ThermalParameters::default(), 288.15);
    let current = 50.0;
    let free = steady_temperature(&b, current, 0.0);
    assert!(free > b.thermal.cooling_setpoint, "needs cooling: {free}");
    let (t, s) = run(&b, 288.15, |_| current, false, 600.0, 60);
    assert_eq!(t, b.thermal.cooling_setpoint, "held exactly");
    assert!(s.regime_changes >= 1);
    // Qc = (V(Ts) − n·1.481)·I − (Ts − Ta)/Rth, written out.
    let v = 35.75 + 0.1529 * current; // Ts = Tn: no temperature term
    let surplus = (v - 23.0 * 1.481) * current - (328.15 - 288.15) / 0.2;
    assert!((b.cooling_power(t, current) - surplus).abs() < 1e-9);
    assert!(surplus > 0.0 && surplus < b.thermal.max_cooling_power);
}

#[test]
fn beyond_the_cooling_the_stack_settles_above_the_setpoint() {
    let p = ThermalParameters {
        max_cooling_power: 100.0,
        ..ThermalParameters::default()
    };
    let b = balance(p, 288.15);
    let expected = steady_temperature(&b, 53.4, 100.0);
    assert!(expected > p.cooling_setpoint, "{expected}");
    let (t, _) = run(&b, 288.15, |_| 53.4, true, 3600.0, 40);
    assert!((t - expected).abs() < 1e-6, "{t} vs {expected}");
    assert_eq!(b.cooling_power(t, 53.4), 100.0);
}

#[test]
fn a_stopped_stack_cools_exponentially_toward_ambient() {
    let b = balance(ThermalParameters::default(), 278.15);
    let tau: f64 = 0.2 * 25_000.0;
    for (constant, h, steps) in [(true, 7200.0, 1), (false, 60.0, 120)] {
        let (t, s) = run(&b, 328.15, |_| 0.0, constant, h, steps);
        let expected = 278.15 + 50.0 * (-7200.0 / tau).exp();
        assert!((t - expected).abs() < 1e-7, "{t} vs {expected}");
        // ∫(T − Tn) dt = ∫(T − Ta) dt − (Tn − Ta)·t, ∫(T − Ta) dt = 50·τ·(1 − e^(−t/τ)).
        let integral = 50.0 * tau * (1.0 - (-7200.0 / tau).exp()) - 50.0 * 7200.0;
        assert!(
            (s.temperature_integral - integral).abs() < 1e-4,
            "{}",
            s.temperature_integral
        );
    }
}

/// A current that moves through the day: ramps and sines between 32 and 53 A.
fn moving(t: f64) -> f64 {
    42.5 + 10.5 * (t / 900.0).sin() * (t / 4000.0).cos()
}

/// ∫I dt and ∫I² dt of [`moving`] over [0, t] by composite Simpson on a fine grid (the
/// integrand is smooth: the error is far below the tolerances used).
fn moving_integrals(t: f64) -> (f64, f64) {
    let n = 200_000;
    let h = t / n as f64;
    let (mut q, mut q2) = (0.0, 0.0);
    for k in 0..=n {
        let w = if k == 0 || k == n {
            1.0
        } else if k % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let i = moving(k as f64 * h);
        q += w * i;
        q2 += w * i * i;
    }
    (q * h / 3.0, q2 * h / 3.0)
}

#[test]
fn the_heat_balance_is_conserved_over_a_day_with_switching() {
    // Cold ambient: at low current the surplus goes negative, at high it exceeds the cooling,
    // so all three regimes occur.
    let p = ThermalParameters {
        max_cooling_power: 150.0,
        ..ThermalParameters::default()
    };
    let b = balance(p, 268.15);
    let day = 86_400.0;
    let (t, s) = run(&b, 328.15, moving, false, 300.0, 288);
    assert!(s.regime_changes >= 4, "{}", s.regime_changes);
    let (q, q2) = moving_integrals(day);
    let n_e = 23.0 * 1.481;
    let heat = (35.75 - n_e) * q
        + 0.1529 * q2
        + p.voltage_temperature_coefficient * s.heat_charge
        + p.resistance_temperature_coefficient * s.heat_squared;
    let loss = (s.temperature_integral + (p.nominal_temperature - 268.15) * day) / 0.2;
    let stored = p.heat_capacity * (t - 328.15);
    let residual = heat - loss - s.cooling_energy - stored;
    assert!(
        residual.abs() < 1e-6 * heat.abs(),
        "heat {heat} J, loss {loss} J, cooling {} J, stored {stored} J: residual {residual} J",
        s.cooling_energy
    );
}

#[test]
fn results_at_common_times_do_not_depend_on_the_step_size() {
    // The default stack (5 000 s time constant) and a small one (20 s) that follows the
    // current closely and switches regime often.
    for heat_capacity in [25_000.0, 100.0] {
        step_size_independence(heat_capacity);
    }
}

fn step_size_independence(heat_capacity: f64) {
    let p = ThermalParameters {
        max_cooling_power: 150.0,
        heat_capacity,
        ..ThermalParameters::default()
    };
    let b = balance(p, 268.15);
    // Every 600 s over four hours, from 300 K: warming, held, above and below the setpoint.
    let trajectory = |h: f64| {
        let per = (600.0 / h).round() as usize;
        let mut t = 300.0;
        let mut out = vec![];
        for k in 0..24 {
            let start = k as f64 * 600.0;
            let (end, _) = run(&b, t, move |x| moving(start + x), false, h, per);
            t = end;
            out.push(t);
        }
        out
    };
    let reference = trajectory(600.0);
    assert!(reference.iter().any(|t| *t < 328.15 - 1.0));
    assert!(reference.iter().any(|t| *t > 328.15));
    assert!(reference.contains(&328.15));
    for h in [0.5, 7.5, 60.0] {
        for (k, (t, r)) in trajectory(h).iter().zip(&reference).enumerate() {
            assert!(
                (t - r).abs() < 1e-6,
                "C = {heat_capacity} J/K, h = {h} s, t = {} s: {t} K vs {r} K",
                600 * (k + 1)
            );
        }
    }
}

#[test]
fn bad_parameters_are_refused_with_their_name() {
    let cases: [(&str, fn(&mut ThermalParameters)); 6] = [
        ("heatCapacity", |p| p.heat_capacity = -1.0),
        ("thermalResistance", |p| p.thermal_resistance = 0.0),
        ("initialTemperature", |p| p.initial_temperature = f64::NAN),
        ("maxCoolingPower", |p| p.max_cooling_power = f64::INFINITY),
        ("nCells", |p| p.n_cells = 0),
        ("heatCapacity", |p| p.heat_capacity = 1e-3),
    ];
    for (name, spoil) in cases {
        let mut p = ThermalParameters::default();
        spoil(&mut p);
        assert_eq!(p.validate().unwrap_err().name, name);
    }
    assert!(ThermalParameters::default().validate().is_ok());
}

/// `HeldSetpoint` without its closed-form envelope: the integrator's path.
struct Integrated<'a>(crate::current_path::HeldSetpoint<'a>);

impl CurrentPath for Integrated<'_> {
    fn current(&self, tau: f64) -> f64 {
        self.0.current(tau)
    }
    fn constant(&self) -> Option<f64> {
        self.0.constant()
    }
}

#[test]
fn a_held_setpoint_along_a_tracking_current_is_the_integrators_result_in_closed_form() {
    use crate::current_path::HeldSetpoint;
    use crate::dynamics::CurrentDynamics;
    use crate::parameters::Parameters;
    let p = Parameters::default();
    let dynamics = CurrentDynamics::new(&p);
    let b = balance(ThermalParameters::default(), 288.15);
    let ts = b.thermal.cooling_setpoint;
    // From steady states at 80 % (a falling, tracking current) and mid-way after a rise.
    let mut rising = dynamics.steady_state(70.0);
    dynamics.advance(&mut rising, 75.0, 200.0, &mut Default::default());
    for (start, u, h) in [
        (dynamics.steady_state(80.0), 65.0, 1.0),
        (dynamics.steady_state(80.0), 65.0, 30.0),
        (rising, 75.0, 5.0),
    ] {
        let path = HeldSetpoint {
            dynamics: &dynamics,
            start,
            setpoint: u,
            drift: DriftChange::NONE,
        };
        assert!(path.envelope(h).is_some(), "the step tracks");
        let closed = advance(&b, ts, &path, h).unwrap();
        let integrated = advance(&b, ts, &Integrated(path), h).unwrap();
        assert_eq!(closed.temperature, ts);
        assert_eq!(closed.regime_changes, 0);
        for (x, y) in [
            (closed.heat_charge, integrated.heat_charge),
            (closed.heat_squared, integrated.heat_squared),
            (closed.cooling_energy, integrated.cooling_energy),
            (closed.temperature_integral, integrated.temperature_integral),
        ] {
            assert!((x - y).abs() <= 1e-9 * y.abs().max(1.0), "{x} vs {y}");
        }
        assert!(closed.cooling_energy > 0.0);
    }
}

#[test]
fn a_current_that_leaves_the_held_range_is_integrated_with_its_event() {
    use crate::current_path::HeldSetpoint;
    use crate::dynamics::CurrentDynamics;
    use crate::parameters::Parameters;
    let p = Parameters::default();
    let dynamics = CurrentDynamics::new(&p);
    // At 0 °C ambient the loss at Ts is 275 W: at 100 % the surplus is positive (held),
    // falling to 60 % it turns negative (the stack cools below Ts) within the step.
    let b = balance(ThermalParameters::default(), 273.15);
    let (hi, lo) = (p.gain * 100.0, p.gain * 60.0);
    assert!(b.surplus(hi) > 0.0 && b.surplus(lo) < 0.0);
    let path = HeldSetpoint {
        dynamics: &dynamics,
        start: dynamics.steady_state(100.0),
        setpoint: 60.0,
        drift: DriftChange::NONE,
    };
    let step = advance(&b, b.thermal.cooling_setpoint, &path, 600.0).unwrap();
    assert!(step.regime_changes >= 1);
    assert!(step.temperature < b.thermal.cooling_setpoint);
}

#[test]
fn collocation_along_a_moving_current_is_the_integrators_result() {
    use crate::current_path::HeldSetpoint;
    use crate::dynamics::CurrentDynamics;
    use crate::parameters::Parameters;
    let p = Parameters::default();
    let dynamics = CurrentDynamics::new(&p);
    let b = balance(ThermalParameters::default(), 278.15);
    let mut rising = dynamics.steady_state(60.0);
    dynamics.advance(&mut rising, 100.0, 30.0, &mut Default::default());
    // Warming from 20 °C (below) and cooling from 70 °C (above), along tracking and
    // rate-limited currents, over steps of 1 s and 10 s.
    for (t0, start, u) in [
        (293.15, dynamics.steady_state(80.0), 65.0),
        (293.15, rising, 100.0),
        (343.15, dynamics.steady_state(100.0), 60.0),
        (343.15, dynamics.steady_state(60.0), 100.0),
    ] {
        for h in [1.0, 10.0] {
            let path = HeldSetpoint {
                dynamics: &dynamics,
                start,
                setpoint: u,
                drift: DriftChange::NONE,
            };
            let regime = b.regime(t0, path.current(0.0));
            let fast = super::collocation::step(&b, &path, regime, t0, h)
                .expect("the collocation step applies");
            assert_eq!(fast, advance(&b, t0, &path, h).unwrap());
            let slow = integrate(&b, t0, &path, h).unwrap();
            assert!(
                (fast.temperature - slow.temperature).abs() < 1e-9,
                "{t0} {h}"
            );
            for (x, y) in [
                (fast.heat_charge, slow.heat_charge),
                (fast.heat_squared, slow.heat_squared),
                (fast.temperature_integral, slow.temperature_integral),
                (fast.cooling_energy, slow.cooling_energy),
            ] {
                assert!(
                    (x - y).abs() <= 1e-9 * y.abs().max(1.0),
                    "{t0} {h}: {x} vs {y}"
                );
            }
        }
    }
}

/// A held setpoint whose voltage drifts, seen without its closed forms (the integrator's path).
struct DriftIntegrated<'a>(crate::current_path::HeldSetpoint<'a>);

impl CurrentPath for DriftIntegrated<'_> {
    fn current(&self, tau: f64) -> f64 {
        self.0.current(tau)
    }
    fn constant(&self) -> Option<f64> {
        self.0.constant()
    }
    fn drift(&self, tau: f64) -> f64 {
        self.0.drift(tau)
    }
}

#[test]
fn a_drifting_voltage_heats_the_stack_and_the_energy_still_balances() {
    use crate::ageing::AgeingParameters;
    use crate::current_path::HeldSetpoint;
    use crate::dynamics::CurrentDynamics;
    use crate::parameters::Parameters;
    let p = Parameters::default();
    let dynamics = CurrentDynamics::new(&p);
    // A large, fast drift, so that it matters: 2 V building up in 10 min, 36 mV/h.
    let ageing = AgeingParameters {
        drift_per_running_hour: 0.036,
        reversible_drift: 2.0,
        drift_build_up_time: 600.0,
        ..AgeingParameters::default()
    };
    let thermal = ThermalParameters {
        max_cooling_power: 400.0,
        ..ThermalParameters::default()
    };
    let b = balance(thermal, 278.15);
    let n_e = 23.0 * 1.481;
    let (mut state, mut drift) = (dynamics.steady_state(60.0), ageing.initial());
    let mut temperature = 318.15;
    let (mut electric, mut loss, mut cooling, mut held) = (0.0, 0.0, 0.0, 0);
    // Up to full load (through the setpoint: below, held, above), then down, 600 s steps.
    for (k, u) in [100.0, 100.0, 100.0, 100.0, 70.0, 70.0, 100.0, 100.0]
        .iter()
        .enumerate()
    {
        let change = ageing.change_while_running(drift);
        let path = HeldSetpoint {
            dynamics: &dynamics,
            start: state,
            setpoint: *u,
            drift: change,
        };
        let h = 600.0;
        let s = advance(&b.drifted(drift.total()), temperature, &path, h).unwrap();
        let ints = dynamics.advance_with_moments(&mut state, *u, h, ageing.build_up_rate());
        electric += 35.75 * ints.charge
            + 0.1529 * ints.current_squared
            + thermal.voltage_temperature_coefficient * s.heat_charge
            + thermal.resistance_temperature_coefficient * s.heat_squared
            + ageing.energy(drift, &ints);
        loss += (s.temperature_integral + (thermal.nominal_temperature - 278.15) * h) / 0.2;
        cooling += s.cooling_energy;
        held += usize::from(s.temperature == thermal.cooling_setpoint);
        electric -= n_e * ints.charge;
        temperature = s.temperature;
        drift = ageing.after_running(drift, h);
        assert!(k < 7 || drift.total() > 2.0);
    }
    assert!(held >= 1, "the thermostat held the setpoint");
    let stored = thermal.heat_capacity * (temperature - 318.15);
    let residual = electric - loss - cooling - stored;
    assert!(
        residual.abs() < 1e-6 * electric.abs(),
        "heat {electric} J, loss {loss} J, cooling {cooling} J, stored {stored} J: residual {residual} J"
    );
}

#[test]
fn a_held_setpoint_with_a_drifting_voltage_is_the_integrators_result_in_closed_form() {
    use crate::ageing::AgeingParameters;
    use crate::current_path::HeldSetpoint;
    use crate::dynamics::CurrentDynamics;
    use crate::parameters::Parameters;
    let p = Parameters::default();
    let dynamics = CurrentDynamics::new(&p);
    let b = balance(ThermalParameters::default(), 288.15);
    let ts = b.thermal.cooling_setpoint;
    let ageing = AgeingParameters {
        drift_per_running_hour: 0.01,
        reversible_drift: 0.5,
        drift_build_up_time: 300.0,
        ..AgeingParameters::default()
    };
    for (u, h, reversible) in [(65.0, 30.0, 0.0), (65.0, 120.0, 0.9), (70.0, 60.0, 0.2)] {
        let drift = crate::ageing::Drift {
            irreversible: 0.1,
            reversible,
        };
        let path = HeldSetpoint {
            dynamics: &dynamics,
            start: dynamics.steady_state(80.0),
            setpoint: u,
            drift: ageing.change_while_running(drift),
        };
        assert!(path.envelope(h).is_some(), "the step tracks");
        let drifted = b.drifted(drift.total());
        let closed = advance(&drifted, ts, &path, h).unwrap();
        assert_eq!((closed.temperature, closed.regime_changes), (ts, 0));
        let integrated = integrate(&drifted, ts, &DriftIntegrated(path), h).unwrap();
        for (x, y) in [
            (closed.heat_charge, integrated.heat_charge),
            (closed.cooling_energy, integrated.cooling_energy),
        ] {
            assert!((x - y).abs() <= 1e-9 * y.abs().max(1.0), "{x} vs {y}");
        }
    }
}
