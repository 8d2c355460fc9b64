use super::*;
use crate::dispatch::{power_at_setpoint, setpoint_for_power};
use crate::reserve::{FrequencyResponse, ReserveSettings};

fn hub_settings(n: i32, dispatch: i32, below: i32) -> PlantSettings {
    PlantSettings {
        n_modules: n,
        dispatch,
        below_minimum: below,
        ..PlantSettings::default()
    }
}

fn plant(settings: PlantSettings, setpoint: f64, power: f64) -> (Plant, PlantConfig) {
    let config = settings.config().unwrap();
    (
        Plant::new(Parameters::default(), &config, None, setpoint, power).unwrap(),
        config,
    )
}

#[test]
fn default_settings_are_the_paper_module() {
    let (p, config) = plant(PlantSettings::default(), 80.0, 0.0);
    assert!(config.is_single_module());
    assert!(matches!(p, Plant::Module(_)));
    assert!(p.takes_setpoint_slope());
    assert_eq!(p.current(), 0.534 * 80.0);
    assert_eq!(p.state(), OperatingState::Steady);
    assert_eq!(p.count_in(OperatingState::Steady), 1);
}

#[test]
fn a_one_module_hub_above_its_minimum_matches_the_module() {
    let (mut hub, hc) = plant(hub_settings(1, 1, 1), 80.0, 0.0);
    let (mut module, mc) = plant(PlantSettings::default(), 80.0, 0.0);
    assert!(matches!(hub, Plant::Hub(..)));
    for (u, n) in [(95.0, 400), (62.0, 300), (100.0, 500)] {
        for _ in 0..n {
            hub.step(&hc, u, 0.0, 0.0, 1.0).unwrap();
            module.step(&mc, u, 0.0, 0.0, 1.0).unwrap();
        }
        assert!((hub.current() - module.current()).abs() <= 1e-12 * module.current());
        assert!((hub.voltage() - module.voltage()).abs() <= 1e-12 * module.voltage());
        assert!((hub.energy() - module.energy()).abs() <= 1e-12 * module.energy());
        assert!(
            (hub.running_hours() - module.running_hours()).abs() <= 1e-12 * module.running_hours()
        );
    }
    assert_eq!(hub.starts(), 0.0);
}

#[test]
fn a_hub_refuses_a_setpoint_slope_and_stays_unchanged() {
    let (mut hub, config) = plant(hub_settings(4, 1, 1), 80.0, 0.0);
    let before = hub.snapshot();
    assert_eq!(
        hub.step(&config, 80.0, 0.5, 0.0, 1.0),
        Err(StepError::SlopeNotSupported(0.5))
    );
    assert_eq!(hub.snapshot(), before);
    assert!(!hub.takes_setpoint_slope());
}

#[test]
fn bad_settings_are_refused_by_name() {
    for (settings, name) in [
        (hub_settings(0, 1, 0), "nModules"),
        (hub_settings(2, 7, 1), "dispatch"),
        (hub_settings(2, 1, 5), "belowMinimum"),
        (hub_settings(2, 2, 0), "belowMinimum"),
        (
            PlantSettings {
                parameter_spread: 0.6,
                ..PlantSettings::default()
            },
            "parameterSpread",
        ),
        (
            PlantSettings {
                parameter_spread: f64::NAN,
                ..PlantSettings::default()
            },
            "parameterSpread",
        ),
        (
            PlantSettings {
                n_modules: MAX_INDIVIDUAL_MODULES + 1,
                parameter_spread: 0.01,
                ..PlantSettings::default()
            },
            "nModules",
        ),
        (
            PlantSettings {
                cold_start_time: -1.0,
                ..PlantSettings::default()
            },
            "coldStartTime",
        ),
        (
            PlantSettings {
                hysteresis: f64::INFINITY,
                ..PlantSettings::default()
            },
            "hysteresis",
        ),
    ] {
        assert_eq!(settings.config().unwrap_err().name, name, "{settings:?}");
    }
}

#[test]
fn per_module_means_of_a_spread_hub_follow_each_modules_gain() {
    let settings = PlantSettings {
        n_modules: 50,
        parameter_spread: 0.05,
        spread_seed: 7,
        ..PlantSettings::default()
    };
    let (p, config) = plant(settings, 90.0, 0.0);
    let sets = spread_parameters(&Parameters::default(), 50, 0.05, 7);
    // Steady state at t = 0: I_k = K_k·u, so the mean current is mean(K_k)·u.
    let mean_gain = sets.iter().map(|s| s.gain).sum::<f64>() / 50.0;
    assert!((p.current() - mean_gain * 90.0).abs() <= 1e-12 * p.current());
    let power: f64 = sets
        .iter()
        .map(|s| (s.voltage_intercept + s.ohmic_resistance * s.gain * 90.0) * s.gain * 90.0)
        .sum();
    assert!((p.hub_power() - power).abs() <= 1e-9 * power);
    assert!((p.power() - power / 50.0).abs() <= 1e-9 * power);
    assert!(!config.is_single_module());
}

#[test]
fn a_power_reference_is_drawn_in_steady_state() {
    let settings = PlantSettings {
        n_modules: 25_000,
        power_input: true,
        ..PlantSettings::default()
    };
    let (mut p, config) = plant(settings, 0.0, 50e6);
    // Steady at t = 0: each module at the setpoint whose steady power is P/N.
    assert!((p.hub_power() - 50e6).abs() <= 1e-9 * 50e6);
    for _ in 0..3000 {
        p.step(&config, 0.0, 0.0, 45e6, 1.0).unwrap();
    }
    assert!(
        (p.hub_power() - 45e6).abs() <= 1e-6 * 45e6,
        "{}",
        p.hub_power()
    );
    let u = setpoint_for_power(&Parameters::default(), 45e6 / 25_000.0);
    assert!((p.current() - 0.534 * u).abs() <= 1e-6 * p.current());
    assert_eq!(p.count_in(OperatingState::Steady), 25_000);
}

#[test]
fn snapshots_restore_exactly_and_only_into_their_kind() {
    let (mut hub, config) = plant(hub_settings(100, 2, 1), 100.0, 0.0);
    for k in 0..500 {
        hub.step(&config, if k < 200 { 30.0 } else { 75.0 }, 0.0, 0.0, 1.0)
            .unwrap();
    }
    let saved = hub.snapshot();
    let (power, starts) = (hub.hub_power(), hub.starts());
    for _ in 0..100 {
        hub.step(&config, 45.0, 0.0, 0.0, 1.0).unwrap();
    }
    hub.restore(saved.clone()).unwrap();
    assert_eq!((hub.hub_power(), hub.starts()), (power, starts));
    assert_eq!(hub.snapshot(), saved);
    let (mut module, _) = plant(PlantSettings::default(), 80.0, 0.0);
    assert!(module.restore(saved).is_err());
    let mut broken = hub.snapshot();
    if let PlantSnapshot::Hub(h) = &mut broken {
        h.groups[0].count += 1;
    }
    assert!(hub.restore(broken).is_err());
    assert_eq!(hub.hub_power(), power);
}

#[test]
fn module_sets_are_shared_round_robin() {
    let a = Parameters {
        gain: 0.5,
        ..Parameters::default()
    };
    let b = Parameters {
        gain: 0.6,
        ..Parameters::default()
    };
    let config = PlantSettings {
        n_modules: 5,
        ..PlantSettings::default()
    }
    .config()
    .unwrap();
    let p = Plant::new(Parameters::default(), &config, Some(&[a, b]), 80.0, 0.0).unwrap();
    // Modules 0, 2, 4 have set a; 1 and 3 set b.
    assert!((p.current() - (3.0 * 0.5 + 2.0 * 0.6) / 5.0 * 80.0).abs() <= 1e-12);
    // Even one module with a set from a file is a hub (of one), with that set.
    let one = Plant::new(
        Parameters::default(),
        &PlantSettings::default().config().unwrap(),
        Some(&[b]),
        80.0,
        0.0,
    )
    .unwrap();
    assert!(matches!(one, Plant::Hub(..)));
    assert!((one.current() - 0.6 * 80.0).abs() <= 1e-12);
    let spread = PlantSettings {
        n_modules: 5,
        parameter_spread: 0.1,
        ..PlantSettings::default()
    }
    .config()
    .unwrap();
    assert_eq!(
        Plant::new(Parameters::default(), &spread, Some(&[a]), 80.0, 0.0)
            .unwrap_err()
            .name,
        "parameterSpread"
    );
    assert_eq!(
        Plant::new(Parameters::default(), &config, Some(&[]), 80.0, 0.0)
            .unwrap_err()
            .name,
        "moduleParameterFile"
    );
}

/// An equal hub of `n` modules offering `reserve`, driven by a power reference.
fn reserve_hub(
    n: i32,
    reserve: ReserveSettings,
    power: f64,
    frequency: f64,
) -> (Plant, PlantConfig, FrequencyResponse) {
    let settings = PlantSettings {
        n_modules: n,
        power_input: true,
        reserve,
        ..PlantSettings::default()
    };
    let config = settings.config().unwrap();
    let request = reserve.proportional(frequency);
    let plant =
        Plant::with_request(Parameters::default(), &config, None, 0.0, power, request).unwrap();
    (plant, config, FrequencyResponse::new(reserve))
}

#[test]
fn a_frequency_below_49_5_hz_takes_exactly_the_fcr_d_capacity_off_the_draw() {
    let p = Parameters::default();
    let (n, c) = (10, 3000.0);
    let baseline = 10.0 * power_at_setpoint(&p, 85.0);
    let reserve = ReserveSettings {
        fcr_d_up: c,
        ..ReserveSettings::default()
    };
    let (mut plant, config, mut response) = reserve_hub(n, reserve, baseline, 50.0);
    assert!(!config.is_single_module() && !plant.takes_setpoint_slope());
    assert!((plant.hub_power() - baseline).abs() < 1e-9 * baseline);
    let mut t = 0.0;
    for _ in 0..2000 {
        let step = plant
            .step_with_reserves(&config, &mut response, 0.0, 0.0, baseline, 49.2, t, 1.0)
            .unwrap();
        assert_eq!((step.request, step.shortfall), (-c, 0.0));
        t += 1.0;
    }
    // After 2000 s (17 slow time constants) the hub is in steady state at baseline − C.
    assert!(
        (plant.hub_power() - (baseline - c)).abs() < 1e-6 * baseline,
        "{}",
        plant.hub_power()
    );
    // Setpoint mode: the setpoint stands for N·P(u); the reserve comes off that power.
    let settings = PlantSettings {
        n_modules: n,
        reserve,
        ..PlantSettings::default()
    };
    let config = settings.config().unwrap();
    let plant =
        Plant::with_request(p, &config, None, 85.0, 0.0, reserve.proportional(49.0)).unwrap();
    assert!((plant.hub_power() - (baseline - c)).abs() < 1e-9 * baseline);
}

#[test]
fn nothing_offered_or_a_nominal_frequency_is_the_plain_step_bit_for_bit() {
    let (mut plain, config) = plant(hub_settings(7, 2, 1), 70.0, 0.0);
    let (mut offered, _) = plant(hub_settings(7, 2, 1), 70.0, 0.0);
    let reserve = ReserveSettings {
        fcr_n: 500.0,
        ffr: 900.0,
        ..ReserveSettings::default()
    };
    let settings = PlantSettings {
        reserve,
        ..hub_settings(7, 2, 1)
    };
    let offering = settings.config().unwrap();
    let mut response = FrequencyResponse::new(reserve);
    for (k, u) in [70.0, 35.0, 90.0, 10.0].iter().enumerate() {
        for j in 0..300 {
            let t = (k * 300 + j) as f64;
            plain.step(&config, *u, 0.0, 0.0, 1.0).unwrap();
            offered
                .step_with_reserves(&offering, &mut response, *u, 0.0, 0.0, 50.0, t, 1.0)
                .unwrap();
            assert_eq!(plain.snapshot(), offered.snapshot());
        }
    }
}

#[test]
fn ffr_ends_inside_a_step_and_results_do_not_depend_on_the_step_size() {
    let p = Parameters::default();
    let baseline = 4.0 * power_at_setpoint(&p, 90.0);
    let reserve = ReserveSettings {
        ffr: 1500.0,
        ffr_trigger: 49.6,
        ffr_duration: 30.0,
        fcr_n: 400.0,
        ..ReserveSettings::default()
    };
    // Frequency: 49.55 Hz until 120 s, then 49.95 Hz (changes on every step grid): FFR from
    // 0 to 30 s, which is inside a step for h = 4 and 60.
    let frequency = |t: f64| if t < 120.0 { 49.55 } else { 49.95 };
    let run = |h: f64| {
        let (mut plant, config, mut response) = reserve_hub(4, reserve, baseline, 50.0);
        let mut out = Vec::new();
        for k in 0..(300.0 / h) as usize {
            let t = k as f64 * h;
            plant
                .step_with_reserves(
                    &config,
                    &mut response,
                    0.0,
                    0.0,
                    baseline,
                    frequency(t),
                    t,
                    h,
                )
                .unwrap();
            if ((t + h) % 60.0).abs() < 1e-9 {
                out.push((plant.hub_power(), plant.hub_energy()));
            }
        }
        out
    };
    let reference = run(1.0);
    assert_eq!(reference.len(), 5);
    for h in [0.5, 4.0, 60.0] {
        for (got, want) in run(h).iter().zip(&reference) {
            assert!(
                (got.0 - want.0).abs() < 1e-9 * want.0 && (got.1 - want.1).abs() < 1e-9 * want.1,
                "h={h}: {got:?} vs {want:?}"
            );
        }
    }
    // The steps of 60 s cut at FFR's end (43 s): the request then is FCR-N's alone.
    let (mut plant, config, mut response) = reserve_hub(4, reserve, baseline, 50.0);
    let step = plant
        .step_with_reserves(
            &config,
            &mut response,
            0.0,
            0.0,
            baseline,
            49.55,
            13.0,
            60.0,
        )
        .unwrap();
    assert_eq!(step.request, -400.0);
    assert_eq!(response.fast, crate::FastReserve::Spent);
}

#[test]
fn the_window_keeps_a_hub_from_delivering_and_says_how_much() {
    let p = Parameters::default();
    let n = 10;
    let at_min = n as f64 * power_at_setpoint(&p, 60.0);
    let baseline = n as f64 * power_at_setpoint(&p, 65.0);
    let reserve = ReserveSettings {
        fcr_d_up: 5000.0,
        ..ReserveSettings::default()
    };
    let (plant, config, _) = reserve_hub(n, reserve, baseline, 50.0);
    let step = plant.reserve_step(&config, 0.0, baseline, -5000.0);
    assert!(
        (step.shortfall - (-5000.0 + (baseline - at_min))).abs() < 1e-9 * baseline,
        "{step:?}"
    );
    assert_eq!(
        plant.reserve_step(&config, 0.0, baseline, -100.0).shortfall,
        0.0
    );
}

#[test]
fn compensation_makes_an_equal_hub_follow_the_fast_pole_inside_the_window() {
    let p = Parameters::default();
    let n = 5;
    let baseline = n as f64 * power_at_setpoint(&p, 90.0);
    let c = baseline - n as f64 * power_at_setpoint(&p, 70.0);
    let reserve = ReserveSettings {
        fcr_d_up: c,
        compensation: true,
        ..ReserveSettings::default()
    };
    let (mut plant, config, mut response) = reserve_hub(n, reserve, baseline, 50.0);
    assert!((plant.current() - p.gain * 90.0).abs() < 1e-9);
    let mut t = 0.0;
    while t < 60.0 {
        plant
            .step_with_reserves(&config, &mut response, 0.0, 0.0, baseline, 49.5, t, 0.5)
            .unwrap();
        t += 0.5;
        let want = p.gain * (70.0 + 20.0 * (-t / p.tau_pole1).exp());
        assert!(
            (plant.current() - want).abs() < 1e-9,
            "t={t}: {} vs {want}",
            plant.current()
        );
    }
    // Back up at 50 Hz: the current rises no faster than the ramp limit, never above K·90.
    let start = plant.current();
    while t < 400.0 {
        plant
            .step_with_reserves(&config, &mut response, 0.0, 0.0, baseline, 50.0, t, 0.5)
            .unwrap();
        t += 0.5;
        assert!(plant.current() <= start + p.ramp_up_limit * (t - 60.0) + 1e-9);
        assert!(plant.current() <= p.gain * 90.0 + 1e-9);
    }
    assert!((plant.current() - p.gain * 90.0).abs() < 1e-6);
}
