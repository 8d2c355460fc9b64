//! The grid side: supply losses and auxiliaries, against closed forms and the integral of
//! the grid power.

use super::*;
use crate::dispatch::power_at_setpoint;

const LOSSY: GridParameters = crate::grid::TEST_LOSSES;

fn plant(settings: PlantSettings, setpoint: f64, power: f64) -> (Plant, PlantConfig) {
    let config = settings.config().unwrap();
    (
        Plant::new(Parameters::default(), &config, None, setpoint, power).unwrap(),
        config,
    )
}

/// A running module's grid power at setpoint `u` [%] in steady state, from the equations.
fn steady_ac_power(u: f64) -> f64 {
    let p = Parameters::default();
    let i = p.gain * u;
    (p.voltage_intercept + p.ohmic_resistance * i) * i + 40.0 + 0.8 * i + 0.002 * i * i + 150.0
}

#[test]
fn without_losses_the_grid_sees_the_electric_power_bit_for_bit() {
    let settings = PlantSettings {
        n_modules: 40,
        dispatch: 2,
        below_minimum: 1,
        ..PlantSettings::default()
    };
    let (mut p, config) = plant(settings, 30.0, 0.0);
    for k in 0..600 {
        let u = 20.0 + (k % 90) as f64;
        p.step(&config, u, 0.0, 0.0, 7.0).unwrap();
        assert_eq!(p.hub_ac_power().to_bits(), p.hub_power().to_bits());
        assert_eq!(p.hub_ac_energy().to_bits(), p.hub_energy().to_bits());
    }
    let (m, _) = plant(PlantSettings::default(), 80.0, 0.0);
    assert_eq!(m.hub_ac_power().to_bits(), m.hub_power().to_bits());
}

#[test]
fn a_steady_module_and_hub_draw_the_closed_form_grid_power_and_energy() {
    let single = PlantSettings {
        grid: LOSSY,
        ..PlantSettings::default()
    };
    let hub = PlantSettings {
        n_modules: 12,
        below_minimum: 1,
        ..single
    };
    for (settings, n) in [(single, 1.0), (hub, 12.0)] {
        let (mut p, config) = plant(settings, 80.0, 0.0);
        let want = n * steady_ac_power(80.0);
        assert!((p.hub_ac_power() - want).abs() <= 1e-12 * want);
        assert!((p.ac_power() - want / n).abs() <= 1e-12 * want);
        for _ in 0..36 {
            p.step(&config, 80.0, 0.0, 0.0, 100.0).unwrap();
        }
        let energy = want * 3600.0;
        assert!((p.hub_ac_energy() - energy).abs() <= 1e-9 * energy);
    }
}

#[test]
fn the_grid_energy_is_the_integral_of_the_grid_power_through_starts_and_stops() {
    let settings = PlantSettings {
        n_modules: 6,
        dispatch: 2,
        below_minimum: 1,
        grid: LOSSY,
        ..PlantSettings::default()
    };
    let (mut p, config) = plant(settings, 0.0, 0.0);
    // Simpson's rule on a fine grid: the grid power is smooth between the events, which
    // fall on the grid (starts of 300 s and 30 s, a standby of 3600 s).
    let h = 0.05;
    let demand = |t: f64| match t {
        t if t < 100.0 => 0.0,
        t if t < 1500.0 => 250.0 + 150.0 * (t / 200.0).sin(),
        t if t < 1800.0 => 10.0,
        _ => 420.0,
    };
    let steps = (2400.0 / h) as usize;
    let (mut integral, mut previous) = (0.0, p.hub_ac_power());
    for k in 0..steps {
        let t = k as f64 * h;
        let e0 = p.hub_ac_energy();
        p.step(&config, demand(t), 0.0, 0.0, h).unwrap();
        let now = p.hub_ac_power();
        // The power jumps at a start's end; the trapezoid is exact for the linear parts
        // and its error over one 0.05 s step is bounded by the jump.
        let step_energy = p.hub_ac_energy() - e0;
        assert!(step_energy >= 0.0);
        integral += 0.5 * h * (previous + now);
        previous = now;
    }
    assert!(p.starts() >= 6.0, "{}", p.starts());
    let exact = p.hub_ac_energy();
    let extra = exact - p.hub_energy();
    // Running and starting modules drew auxiliaries and losses: a sizeable part of the total.
    assert!(extra > 0.05 * exact, "{extra} of {exact}");
    assert!(
        (integral - exact).abs() <= 2e-4 * exact,
        "trapezoid {integral} vs exact {exact}"
    );
}

#[test]
fn starting_modules_draw_their_auxiliaries_for_the_start_time() {
    let settings = PlantSettings {
        n_modules: 3,
        dispatch: 2,
        below_minimum: 2,
        grid: LOSSY,
        ..PlantSettings::default()
    };
    let (mut p, config) = plant(settings, 0.0, 0.0);
    // 3 × 90 % needs three modules: cold starts of 300 s with startPower 300 W each.
    p.step(&config, 90.0, 0.0, 0.0, 100.0).unwrap();
    assert_eq!(p.count_in(OperatingState::Curve), 3);
    assert!((p.hub_ac_power() - 3.0 * (300.0 + 150.0)).abs() < 1e-9);
    assert!((p.hub_ac_energy() - 3.0 * 450.0 * 100.0).abs() < 1e-6);
}

#[test]
fn a_grid_side_reference_is_what_the_grid_draws() {
    let rated = power_at_setpoint(&Parameters::default(), 100.0);
    for grid_side in [false, true] {
        let settings = PlantSettings {
            n_modules: 20,
            dispatch: 2,
            below_minimum: 1,
            power_input: true,
            grid: GridParameters {
                grid_side_reference: grid_side,
                ..LOSSY
            },
            ..PlantSettings::default()
        };
        let reference = 11.5 * rated;
        let (mut p, config) = plant(settings, 0.0, reference);
        for _ in 0..3000 {
            p.step(&config, 0.0, 0.0, reference, 1.0).unwrap();
        }
        let drawn = if grid_side {
            p.hub_ac_power()
        } else {
            p.hub_power()
        };
        assert!(
            (drawn - reference).abs() <= 1e-6 * reference,
            "grid side {grid_side}: {drawn} vs {reference}"
        );
        if grid_side {
            assert!(p.hub_power() < reference - 12.0 * 150.0);
        }
    }
}

#[test]
fn a_grid_side_reference_counts_the_auxiliaries_of_starting_modules() {
    let rated = power_at_setpoint(&Parameters::default(), 100.0);
    let settings = PlantSettings {
        n_modules: 10,
        dispatch: 2,
        below_minimum: 1,
        power_input: true,
        cold_start_time: 5000.0,
        grid: GridParameters {
            grid_side_reference: true,
            ..LOSSY
        },
        ..PlantSettings::default()
    };
    let (mut p, config) = plant(settings, 0.0, 3.5 * rated);
    // Four run; a reference 200 W above what four can draw from the grid starts a fifth (a
    // long cold start here, so that the four settle), and the four carry what its start
    // power and auxiliaries (450 W) leave.
    assert_eq!(p.count_in(OperatingState::Steady), 4);
    let reference = 4.0 * steady_ac_power(100.0) + 200.0;
    for _ in 0..4000 {
        p.step(&config, 0.0, 0.0, reference, 1.0).unwrap();
    }
    assert_eq!(p.count_in(OperatingState::Curve), 1);
    let drawn = p.hub_ac_power();
    assert!(
        (drawn - reference).abs() <= 1e-6 * reference,
        "{drawn} vs {reference}"
    );
}

#[test]
fn bad_grid_parameters_are_refused_by_name() {
    let settings = PlantSettings {
        grid: GridParameters {
            supply_loss_resistance: -0.1,
            ..LOSSY
        },
        ..PlantSettings::default()
    };
    let e = settings.config().unwrap_err();
    assert_eq!(e.name, "supplyLossResistance");
}
