use super::*;
use crate::dispatch::setpoint_for_power;

fn hub_settings(n: i32, dispatch: i32, below: i32) -> PlantSettings {
    PlantSettings { n_modules: n, dispatch, below_minimum: below, ..PlantSettings::default() }
}

fn plant(settings: PlantSettings, setpoint: f64, power: f64) -> (Plant, PlantConfig) {
    let config = settings.config().unwrap();
    (Plant::new(Parameters::default(), &config, None, setpoint, power).unwrap(), config)
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
        assert!((hub.running_hours() - module.running_hours()).abs() <= 1e-12 * module.running_hours());
    }
    assert_eq!(hub.starts(), 0.0);
}

#[test]
fn a_hub_refuses_a_setpoint_slope_and_stays_unchanged() {
    let (mut hub, config) = plant(hub_settings(4, 1, 1), 80.0, 0.0);
    let before = hub.snapshot();
    assert_eq!(hub.step(&config, 80.0, 0.5, 0.0, 1.0), Err(StepError::SlopeNotSupported(0.5)));
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
        (PlantSettings { parameter_spread: 0.6, ..PlantSettings::default() }, "parameterSpread"),
        (PlantSettings { parameter_spread: f64::NAN, ..PlantSettings::default() }, "parameterSpread"),
        (PlantSettings { n_modules: MAX_INDIVIDUAL_MODULES + 1, parameter_spread: 0.01, ..PlantSettings::default() }, "nModules"),
        (PlantSettings { cold_start_time: -1.0, ..PlantSettings::default() }, "coldStartTime"),
        (PlantSettings { hysteresis: f64::INFINITY, ..PlantSettings::default() }, "hysteresis"),
    ] {
        assert_eq!(settings.config().unwrap_err().name, name, "{settings:?}");
    }
}

#[test]
fn per_module_means_of_a_spread_hub_follow_each_modules_gain() {
    let settings = PlantSettings { n_modules: 50, parameter_spread: 0.05, spread_seed: 7, ..PlantSettings::default() };
    let (p, config) = plant(settings, 90.0, 0.0);
    let sets = spread_parameters(&Parameters::default(), 50, 0.05, 7);
    // Steady state at t = 0: I_k = K_k·u, so the mean current is mean(K_k)·u.
    let mean_gain = sets.iter().map(|s| s.gain).sum::<f64>() / 50.0;
    assert!((p.current() - mean_gain * 90.0).abs() <= 1e-12 * p.current());
    let power: f64 = sets.iter().map(|s| (s.voltage_intercept + s.ohmic_resistance * s.gain * 90.0) * s.gain * 90.0).sum();
    assert!((p.hub_power() - power).abs() <= 1e-9 * power);
    assert!((p.power() - power / 50.0).abs() <= 1e-9 * power);
    assert!(!config.is_single_module());
}

#[test]
fn a_power_reference_is_drawn_in_steady_state() {
    let settings = PlantSettings { n_modules: 25_000, power_input: true, ..PlantSettings::default() };
    let (mut p, config) = plant(settings, 0.0, 50e6);
    // Steady at t = 0: each module at the setpoint whose steady power is P/N.
    assert!((p.hub_power() - 50e6).abs() <= 1e-9 * 50e6);
    for _ in 0..3000 {
        p.step(&config, 0.0, 0.0, 45e6, 1.0).unwrap();
    }
    assert!((p.hub_power() - 45e6).abs() <= 1e-6 * 45e6, "{}", p.hub_power());
    let u = setpoint_for_power(&Parameters::default(), 45e6 / 25_000.0);
    assert!((p.current() - 0.534 * u).abs() <= 1e-6 * p.current());
    assert_eq!(p.count_in(OperatingState::Steady), 25_000);
}

#[test]
fn snapshots_restore_exactly_and_only_into_their_kind() {
    let (mut hub, config) = plant(hub_settings(100, 2, 1), 100.0, 0.0);
    for k in 0..500 {
        hub.step(&config, if k < 200 { 30.0 } else { 75.0 }, 0.0, 0.0, 1.0).unwrap();
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
    let a = Parameters { gain: 0.5, ..Parameters::default() };
    let b = Parameters { gain: 0.6, ..Parameters::default() };
    let config = PlantSettings { n_modules: 5, ..PlantSettings::default() }.config().unwrap();
    let p = Plant::new(Parameters::default(), &config, Some(&[a, b]), 80.0, 0.0).unwrap();
    // Modules 0, 2, 4 have set a; 1 and 3 set b.
    assert!((p.current() - (3.0 * 0.5 + 2.0 * 0.6) / 5.0 * 80.0).abs() <= 1e-12);
    // Even one module with a set from a file is a hub (of one), with that set.
    let one = Plant::new(Parameters::default(), &PlantSettings::default().config().unwrap(), Some(&[b]), 80.0, 0.0).unwrap();
    assert!(matches!(one, Plant::Hub(..)));
    assert!((one.current() - 0.6 * 80.0).abs() <= 1e-12);
    let spread = PlantSettings { n_modules: 5, parameter_spread: 0.1, ..PlantSettings::default() }.config().unwrap();
    assert_eq!(Plant::new(Parameters::default(), &spread, Some(&[a]), 80.0, 0.0).unwrap_err().name, "parameterSpread");
    assert_eq!(Plant::new(Parameters::default(), &config, Some(&[]), 80.0, 0.0).unwrap_err().name, "moduleParameterFile");
}
