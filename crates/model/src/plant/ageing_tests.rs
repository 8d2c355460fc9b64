//! Ageing: the drift and its energy against closed forms, the hub's per-module bookkeeping
//! against its totals, step-size independence, and the default bit for bit.

use super::*;

const SECONDS_PER_HOUR: f64 = 3600.0;

/// 3.6 mV per running hour (1 µV/s), 2 mV per start, 0.5 V reversible in 2 h, recovering in 1 h,
/// 0.1 V at the start.
const AGED: AgeingParameters = AgeingParameters {
    drift_per_running_hour: 3.6e-3,
    drift_per_start: 2e-3,
    reversible_drift: 0.5,
    drift_build_up_time: 7200.0,
    drift_recovery_time: 3600.0,
    initial_drift: 0.1,
};

fn plant(settings: PlantSettings, setpoint: f64) -> (Plant, PlantConfig) {
    let config = settings.config().unwrap();
    (
        Plant::new(Parameters::default(), &config, None, setpoint, 0.0).unwrap(),
        config,
    )
}

fn aged(n: i32, dispatch: i32, below: i32) -> PlantSettings {
    PlantSettings {
        n_modules: n,
        dispatch,
        below_minimum: below,
        ageing: AGED,
        ..PlantSettings::default()
    }
}

/// ∫₀ᵀ d dt of a module running from the initial drift, written out:
/// (d0 + A)·T + ρ'·T²/2 − A·τb·(1 − e^(−T/τb)).
fn drift_integral(t: f64) -> f64 {
    let a = &AGED;
    let rho = a.drift_per_running_hour / SECONDS_PER_HOUR;
    let tb = a.drift_build_up_time;
    (a.initial_drift + a.reversible_drift) * t + 0.5 * rho * t * t
        - a.reversible_drift * tb * (1.0 - (-t / tb).exp())
}

/// d(T) of a module running from the initial drift: d0 + ρ'·T + A·(1 − e^(−T/τb)).
fn drift_after(t: f64) -> f64 {
    let a = &AGED;
    a.initial_drift
        + a.drift_per_running_hour / SECONDS_PER_HOUR * t
        + a.reversible_drift * (1.0 - (-t / a.drift_build_up_time).exp())
}

#[test]
fn a_steady_module_and_hub_draw_the_drifts_energy_in_closed_form() {
    let p = Parameters::default();
    let i = p.gain * 80.0;
    let curve = p.voltage_intercept + p.ohmic_resistance * i;
    for (settings, n) in [(aged(1, 1, 0), 1.0), (aged(7, 1, 1), 7.0)] {
        let (mut plant, config) = plant(settings, 80.0);
        assert_eq!(plant.voltage_drift(), 0.1);
        assert!((plant.voltage() - (curve + 0.1)).abs() < 1e-12);
        let t = 36_000.0;
        for _ in 0..360 {
            plant.step(&config, 80.0, 0.0, 0.0, 100.0).unwrap();
        }
        let d = drift_after(t);
        assert!((plant.voltage_drift() - d).abs() < 1e-12, "{n}");
        assert!((plant.max_voltage_drift() - d).abs() < 1e-12);
        assert!((plant.voltage() - (curve + d)).abs() < 1e-12);
        let want = n * (curve * i * t + i * drift_integral(t));
        let got = plant.hub_energy();
        assert!((got - want).abs() < 1e-12 * want, "{n}: {got} vs {want}");
    }
}

#[test]
fn the_reversible_drift_recovers_while_stopped_and_starts_add_up() {
    let settings = PlantSettings {
        ageing: AgeingParameters {
            drift_per_running_hour: 0.0,
            initial_drift: 0.0,
            ..AGED
        },
        ..aged(1, 1, 1)
    };
    let (mut plant, config) = plant(settings, 80.0);
    for _ in 0..72 {
        plant.step(&config, 80.0, 0.0, 0.0, 100.0).unwrap();
    }
    let built = 0.5 * (1.0 - (-1.0f64).exp());
    assert!((plant.voltage_drift() - built).abs() < 1e-14);
    // Stopped for an hour (standby, then idle): the reversible part decays with τr = 1 h.
    for _ in 0..36 {
        plant.step(&config, 0.0, 0.0, 0.0, 100.0).unwrap();
    }
    let rested = built * (-1.0f64).exp();
    assert!((plant.voltage_drift() - rested).abs() < 1e-14);
    // A start adds 2 mV for good; the start itself is no running time, so the recovery
    // goes on through it.
    plant.step(&config, 80.0, 0.0, 0.0, 10.0).unwrap();
    assert_eq!(plant.starts(), 1.0);
    let want = 2e-3 + rested * (-10.0f64 / 3600.0).exp();
    assert!((plant.voltage_drift() - want).abs() < 1e-14);
}

/// A wind-like demand [%] of the hub at second t.
fn gusty(t: f64) -> f64 {
    let x = t / 900.0;
    45.0 + 40.0 * (x.sin() * (0.37 * x).cos()) + 15.0 * (2.3 * x).sin()
}

#[test]
fn every_modules_irreversible_drift_is_its_running_hours_and_starts() {
    // Without a reversible part the mean drift over the modules is the totals' per module.
    let settings = PlantSettings {
        ageing: AgeingParameters {
            reversible_drift: 0.0,
            ..AGED
        },
        ..aged(12, 2, 2)
    };
    let (mut plant, config) = plant(settings, 30.0);
    for k in 0..4 * 3600 {
        plant.step(&config, gusty(k as f64), 0.0, 0.0, 1.0).unwrap();
    }
    assert!(plant.starts() > 12.0, "{}", plant.starts());
    let n = 12.0;
    let want = 0.1 + 3.6e-3 * plant.running_hours() / n + 2e-3 * plant.starts() / n;
    assert!(
        (plant.voltage_drift() - want).abs() < 1e-12,
        "{} vs {want}",
        plant.voltage_drift()
    );
    assert!(plant.max_voltage_drift() > plant.voltage_drift());
}

/// Energy, mean drift and largest drift after `hours` of the gusty demand at step `h` [s].
fn run(settings: PlantSettings, h: f64, hours: f64) -> [f64; 3] {
    let (mut plant, config) = plant(settings, 30.0);
    let steps = (hours * 3600.0 / h).round() as usize;
    for k in 0..steps {
        // The demand changes every 600 s, so that every step size sees the same inputs.
        let t = (k as f64 * h / 600.0).floor() * 600.0;
        plant.step(&config, gusty(t), 0.0, 0.0, h).unwrap();
    }
    [
        plant.hub_energy(),
        plant.voltage_drift(),
        plant.max_voltage_drift(),
    ]
}

#[test]
fn a_drifting_hub_does_not_depend_on_the_step_size() {
    // Exact without the thermal model; with it the energy's kV and kR terms carry the
    // temperature integrator's tolerance (1e-8 of the energy here, as without ageing).
    for (settings, energy_tolerance) in [
        (aged(10, 2, 1), 1e-12),
        (
            PlantSettings {
                thermal_model: true,
                ..aged(6, 3, 2)
            },
            1e-7,
        ),
    ] {
        let whole = run(settings, 600.0, 6.0);
        for h in [1.0, 30.0] {
            let cut = run(settings, h, 6.0);
            let e = whole[0];
            assert!(
                (e - cut[0]).abs() <= energy_tolerance * e,
                "h = {h}: {e} vs {}",
                cut[0]
            );
            for (a, b) in whole[1..].iter().zip(&cut[1..]) {
                assert!((a - b).abs() <= 1e-12, "h = {h}: {a} V vs {b} V");
            }
        }
    }
}

#[test]
fn a_single_module_with_an_interpolated_input_does_not_depend_on_the_step_size() {
    let settings = PlantSettings {
        ageing: AGED,
        ..PlantSettings::default()
    };
    let outcome = |h: f64| {
        let (mut plant, config) = plant(settings, 60.0);
        let steps = (3600.0 / h).round() as usize;
        for k in 0..steps {
            let t = k as f64 * h;
            // 60 → 100 % over the first 20 min, then back down to 70 % by the hour.
            let (u, slope) = if t < 1200.0 {
                (60.0 + t / 30.0, 1.0 / 30.0)
            } else {
                (100.0 - (t - 1200.0) / 80.0, -1.0 / 80.0)
            };
            plant.step(&config, u, slope, 0.0, h).unwrap();
        }
        (plant.hub_energy(), plant.voltage_drift())
    };
    let (e, d) = outcome(600.0);
    for h in [1.0, 12.5] {
        let (e2, d2) = outcome(h);
        assert!((e - e2).abs() <= 1e-10 * e, "{h}: {e} vs {e2}");
        assert!((d - d2).abs() <= 1e-12, "{h}: {d} vs {d2}");
    }
}

#[test]
fn without_ageing_nothing_drifts_and_a_zero_drift_is_the_paper_bit_for_bit() {
    let zero = AgeingParameters {
        drift_build_up_time: 123.0,
        drift_recovery_time: 456.0,
        ..AgeingParameters::default()
    };
    for base in [PlantSettings::default(), aged(9, 2, 1)] {
        let plain = PlantSettings {
            ageing: AgeingParameters::default(),
            ..base
        };
        let timed = PlantSettings {
            ageing: zero,
            ..base
        };
        let (mut a, ca) = plant(plain, 40.0);
        let (mut b, cb) = plant(timed, 40.0);
        for k in 0..3000 {
            let u = gusty(k as f64 * 3.0);
            a.step(&ca, u, 0.0, 0.0, 3.0).unwrap();
            b.step(&cb, u, 0.0, 0.0, 3.0).unwrap();
            assert_eq!(a.hub_energy().to_bits(), b.hub_energy().to_bits());
            assert_eq!(a.voltage().to_bits(), b.voltage().to_bits());
        }
        assert_eq!(a.voltage_drift(), 0.0);
        assert_eq!(a.max_voltage_drift(), 0.0);
    }
}

#[test]
fn bad_ageing_parameters_are_refused_by_name() {
    let settings = PlantSettings {
        ageing: AgeingParameters {
            drift_recovery_time: -1.0,
            ..AGED
        },
        ..PlantSettings::default()
    };
    assert_eq!(settings.config().unwrap_err().name, "driftRecoveryTime");
}

#[test]
fn a_restored_drifting_hub_continues_bit_for_bit() {
    let (mut a, config) = plant(aged(8, 3, 1), 50.0);
    for k in 0..2000 {
        a.step(&config, gusty(k as f64 * 5.0), 0.0, 0.0, 5.0)
            .unwrap();
    }
    let (mut b, _) = plant(aged(8, 3, 1), 50.0);
    b.restore(a.snapshot()).unwrap();
    for k in 2000..4000 {
        let u = gusty(k as f64 * 5.0);
        a.step(&config, u, 0.0, 0.0, 5.0).unwrap();
        b.step(&config, u, 0.0, 0.0, 5.0).unwrap();
    }
    assert_eq!(a.hub_energy().to_bits(), b.hub_energy().to_bits());
    assert_eq!(a.voltage_drift().to_bits(), b.voltage_drift().to_bits());
}
