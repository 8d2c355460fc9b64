use super::*;
use crate::dispatch::power_at_setpoint;
use crate::Module;

pub(super) fn config(n: u32, policy: DispatchPolicy, below: BelowMinimum) -> HubConfig {
    HubConfig {
        n_modules: n,
        policy,
        operation: OperationParameters {
            below_minimum: below,
            ..Default::default()
        },
        ..Default::default()
    }
}

fn run(hub: &mut Hub, demand: Demand, duration: f64, h: f64) {
    for _ in 0..(duration / h).round() as usize {
        hub.step(demand, h).unwrap();
    }
}

#[test]
fn one_module_hub_in_minimum_mode_is_the_paper_module() {
    let p = Parameters::default();
    let mut hub = Hub::new(p, HubConfig::default(), Demand::Setpoint(75.0)).unwrap();
    let mut m = Module::new(p, 75.0).unwrap();
    for (k, u) in [90.0, 20.0, 100.0, 65.0].iter().enumerate() {
        for _ in 0..300 {
            hub.step(Demand::Setpoint(*u), 1.0).unwrap();
            m.step(*u, 1.0).unwrap();
        }
        assert_eq!(hub.state(), OperatingState::Steady);
        assert_eq!(hub.h2_flow(), m.h2_flow(), "segment {k}");
        assert_eq!(hub.power(), m.power(), "segment {k}");
        assert!((hub.totals().energy - m.energy()).abs() <= 1e-12 * m.energy());
        assert!((hub.totals().h2_produced - m.h2_produced()).abs() <= 1e-12 * m.h2_produced());
    }
}

#[test]
fn equal_hub_of_n_is_n_times_one_module() {
    let p = Parameters::default();
    let schedule = [
        (80.0, 600.0),
        (30.0, 900.0),
        (90.0, 800.0),
        (10.0, 4000.0),
        (70.0, 700.0),
    ];
    let n = 25_000;
    let cfg = config(n, DispatchPolicy::Equal, BelowMinimum::Standby);
    let mut hub = Hub::new(p, cfg, Demand::Setpoint(80.0)).unwrap();
    let mut one = Hub::new(
        p,
        HubConfig {
            n_modules: 1,
            ..cfg
        },
        Demand::Setpoint(80.0),
    )
    .unwrap();
    for &(u, d) in &schedule {
        run(&mut hub, Demand::Setpoint(u), d, 1.0);
        run(&mut one, Demand::Setpoint(u), d, 1.0);
        assert_eq!(hub.groups().len(), 1, "an equal hub is one group");
        assert_eq!(hub.state(), one.state());
        assert_eq!(hub.power(), n as f64 * one.power());
        assert_eq!(hub.h2_flow(), n as f64 * one.h2_flow());
        let (a, b) = (hub.totals(), one.totals());
        assert!((a.energy - n as f64 * b.energy).abs() <= 1e-12 * a.energy);
        assert!((a.h2_produced - n as f64 * b.h2_produced).abs() <= 1e-12 * a.h2_produced);
        assert_eq!(a.starts, n as u64 * b.starts);
        assert!((a.running - n as f64 * b.running).abs() <= 1e-9 * a.running.max(1.0));
    }
    assert_eq!(hub.totals().starts, 2 * n as u64);
}

#[test]
fn a_hub_told_a_constant_power_draws_it_in_steady_state() {
    let p = Parameters::default();
    for policy in [
        DispatchPolicy::Equal,
        DispatchPolicy::Sequential,
        DispatchPolicy::Rotation,
    ] {
        for below in [BelowMinimum::Standby, BelowMinimum::Off] {
            let mut hub = Hub::new(p, config(10, policy, below), Demand::Power(0.0)).unwrap();
            assert_eq!(hub.count_in(OperatingState::Idle), 10);
            // Equal reaches 10 × [P(60 %), P(100 %)] ≈ 13.9…23.5 kW only; the others go lower.
            let low = if policy == DispatchPolicy::Equal {
                14_500.0
            } else {
                4_000.0
            };
            for target in [17_000.0, low, 23_000.0] {
                run(&mut hub, Demand::Power(target), 4.0 * 3600.0, 10.0);
                let got = hub.power();
                assert!(
                    (got - target).abs() < 1e-3 * target,
                    "{policy:?} {below:?}: {got} W vs {target} W"
                );
            }
        }
    }
}

#[test]
fn sequential_reaches_loads_an_equal_hub_cannot() {
    let p = Parameters::default();
    let nominal_flow = 10.0 * p.h2_coefficient * p.gain * 100.0;
    for (policy, want) in [
        (DispatchPolicy::Sequential, 0.2),
        (DispatchPolicy::Equal, 0.0),
    ] {
        let mut hub = Hub::new(
            p,
            config(10, policy, BelowMinimum::Standby),
            Demand::Setpoint(20.0),
        )
        .unwrap();
        run(&mut hub, Demand::Setpoint(20.0), 3600.0, 1.0);
        let share = hub.h2_flow() / nominal_flow;
        assert!((share - want).abs() < 1e-12, "{policy:?}: {share}");
    }
    // 7 % of a 10-module hub = 70 % of one module: one module runs.
    let mut hub = Hub::new(
        p,
        config(10, DispatchPolicy::Sequential, BelowMinimum::Off),
        Demand::Setpoint(7.0),
    )
    .unwrap();
    run(&mut hub, Demand::Setpoint(7.0), 600.0, 1.0);
    assert_eq!(hub.count_in(OperatingState::Steady), 1);
    assert!((hub.h2_flow() - 0.07 * nominal_flow).abs() < 1e-9 * nominal_flow);
}

#[test]
fn starts_and_running_hours_are_counted() {
    let p = Parameters::default();
    let mut hub = Hub::new(
        p,
        config(10, DispatchPolicy::Sequential, BelowMinimum::Off),
        Demand::Setpoint(0.0),
    )
    .unwrap();
    run(&mut hub, Demand::Setpoint(25.0), 3600.0, 1.0);
    let t = hub.totals();
    assert_eq!(t.starts, 3);
    assert_eq!(hub.count_in(OperatingState::Steady), 3);
    // Cold start 300 s, then running for the rest of the hour.
    assert!((t.running - 3.0 * 3300.0).abs() < 1e-6, "{}", t.running);
}

#[test]
fn rotation_starts_the_module_with_fewest_hours() {
    let p = Parameters::default();
    let mut hub = Hub::new(
        p,
        config(3, DispatchPolicy::Rotation, BelowMinimum::Off),
        Demand::Setpoint(0.0),
    )
    .unwrap();
    for _ in 0..3 {
        run(&mut hub, Demand::Setpoint(30.0), 1000.0, 1.0); // one module at 90 %
        run(&mut hub, Demand::Setpoint(0.0), 1000.0, 1.0);
    }
    let mut hours: Vec<f64> = hub
        .groups()
        .iter()
        .flat_map(|g| std::iter::repeat_n(g.running, g.count as usize))
        .collect();
    hours.sort_by(f64::total_cmp);
    assert_eq!(hours, vec![700.0, 700.0, 700.0], "each module ran once");
    // Sequential (no rotation) keeps reusing the same module.
    let mut hub = Hub::new(
        p,
        config(3, DispatchPolicy::Sequential, BelowMinimum::Off),
        Demand::Setpoint(0.0),
    )
    .unwrap();
    for _ in 0..3 {
        run(&mut hub, Demand::Setpoint(30.0), 1000.0, 1.0);
        run(&mut hub, Demand::Setpoint(0.0), 1000.0, 1.0);
    }
    assert_eq!(hub.totals().starts, 3);
}

#[test]
fn hysteresis_stops_chattering() {
    let p = Parameters::default();
    let mut hub = Hub::new(
        p,
        config(10, DispatchPolicy::Sequential, BelowMinimum::Standby),
        Demand::Setpoint(25.0),
    )
    .unwrap();
    // 25 % ↔ 19.8 % of the hub: 250 ↔ 198 module-%, within the 5 % band of 200: no stop.
    for k in 0..100 {
        run(
            &mut hub,
            Demand::Setpoint(if k % 2 == 0 { 19.8 } else { 25.0 }),
            60.0,
            1.0,
        );
    }
    assert_eq!(hub.totals().starts, 0);
    assert_eq!(hub.count_in(OperatingState::Steady), 3);
}

#[test]
fn results_do_not_depend_on_the_step_size() {
    let p = Parameters::default();
    let schedule = [
        Demand::Power(9_000.0),
        Demand::Power(21_000.0),
        Demand::Power(1_000.0),
        Demand::Power(15_500.0),
        Demand::Power(0.0),
        Demand::Power(12_000.0),
    ];
    for policy in [
        DispatchPolicy::Sequential,
        DispatchPolicy::Rotation,
        DispatchPolicy::Equal,
    ] {
        let sim = |h: f64| {
            let mut hub = Hub::new(
                p,
                config(10, policy, BelowMinimum::Standby),
                Demand::Power(3_000.0),
            )
            .unwrap();
            let mut out = Vec::new();
            for d in schedule {
                run(&mut hub, d, 900.0, h);
                out.push((hub.power(), hub.h2_flow(), *hub.totals()));
            }
            out
        };
        let reference = sim(30.0);
        for h in [0.5, 1.0, 7.5] {
            for (i, (a, b)) in sim(h).iter().zip(&reference).enumerate() {
                let c = p.h2_coefficient;
                assert!(
                    (a.1 - b.1).abs() < 1e-9 * c,
                    "{policy:?} h={h} piece {i}: flow {} vs {}",
                    a.1,
                    b.1
                );
                assert!(
                    (a.2.energy - b.2.energy).abs() < 1e-9 * b.2.energy.max(1.0),
                    "{policy:?} h={h} piece {i}"
                );
                assert_eq!(a.2.starts, b.2.starts);
                assert!((a.2.running - b.2.running).abs() < 1e-6);
            }
        }
    }
}

#[test]
fn individual_parameter_sets_share_a_power_reference() {
    let base = Parameters::default();
    let sets = crate::spread::spread_parameters(&base, 50, 0.03, 7);
    let mut hub = Hub::with_parameter_sets(
        sets,
        config(50, DispatchPolicy::Equal, BelowMinimum::Off),
        Demand::Power(0.0),
    )
    .unwrap();
    // 1800 W per module: inside every spread module's window, so each inverts its own curve.
    run(&mut hub, Demand::Power(90_000.0), 4.0 * 3600.0, 5.0);
    assert!(
        (hub.power() - 90_000.0).abs() < 1e-3 * 90_000.0,
        "{}",
        hub.power()
    );
    assert_eq!(hub.groups().len(), 50);
}

#[test]
fn bad_combinations_are_refused_with_the_value() {
    let p = Parameters::default();
    let e = Hub::new(
        p,
        config(4, DispatchPolicy::Sequential, BelowMinimum::Minimum),
        Demand::Setpoint(50.0),
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("belowMinimum = 0") && e.to_string().contains("dispatch = 2"),
        "{e}"
    );
    let e = Hub::new(
        p,
        config(0, DispatchPolicy::Equal, BelowMinimum::Minimum),
        Demand::Setpoint(50.0),
    )
    .unwrap_err();
    assert!(e.to_string().contains("nModules = 0"), "{e}");
    let e = Hub::new(
        p,
        HubConfig {
            hysteresis: -1.0,
            ..Default::default()
        },
        Demand::Setpoint(50.0),
    )
    .unwrap_err();
    assert!(e.to_string().contains("hysteresis = -1"), "{e}");
    let e = Hub::with_parameter_sets(
        vec![p; 3],
        config(4, DispatchPolicy::Equal, BelowMinimum::Off),
        Demand::Setpoint(50.0),
    )
    .unwrap_err();
    assert!(e.to_string().contains("nModules = 4"), "{e}");
    let flat = Parameters {
        voltage_intercept: 0.0,
        ohmic_resistance: 0.0,
        ..p
    };
    assert!(Hub::new(flat, HubConfig::default(), Demand::Power(1e3)).is_err());
    let mut hub = Hub::new(p, HubConfig::default(), Demand::Setpoint(70.0)).unwrap();
    let before = *hub.totals();
    assert!(hub.step(Demand::Power(f64::NAN), 1.0).is_err());
    assert!(hub.step(Demand::Setpoint(70.0), 0.0).is_err());
    assert!(hub.step(Demand::Setpoint(70.0), 1e308).is_err());
    assert_eq!(*hub.totals(), before);
}

#[test]
fn running_modules_carry_the_demand_while_others_start() {
    let p = Parameters::default();
    let module_max = power_at_setpoint(&p, 100.0);
    let mut cfg = config(10, DispatchPolicy::Sequential, BelowMinimum::Standby);
    cfg.operation.cold_start_time = 10_000.0;
    let mut hub = Hub::new(p, cfg, Demand::Power(2.5 * module_max)).unwrap();
    assert_eq!(hub.count_in(OperatingState::Steady), 3);
    // Five modules' worth: two more start (10 000 s), the three running go to their maximum.
    run(&mut hub, Demand::Power(4.6 * module_max), 3000.0, 1.0);
    assert_eq!(
        (
            hub.count_in(OperatingState::Steady),
            hub.count_in(OperatingState::Curve)
        ),
        (3, 2)
    );
    let expected = 3.0 * module_max + 2.0 * cfg.operation.start_power;
    assert!(
        (hub.power() - expected).abs() <= 1e-6 * expected,
        "{} vs {expected}",
        hub.power()
    );
    // Once the starts complete (exactly at 10 000 s), all five share the demand.
    run(&mut hub, Demand::Power(4.6 * module_max), 7000.0, 7.0);
    assert_eq!(hub.count_in(OperatingState::Steady), 5);
    run(&mut hub, Demand::Power(4.6 * module_max), 3000.0, 10.0);
    assert!((hub.power() - 4.6 * module_max).abs() <= 1e-6 * module_max);
}

/// A wind-like demand in [0, 1] of the hub at second `t` that dips below every module's
/// minimum now and then (stops, standby, restarts) and rises fast enough to hit the ramp limit.
fn gusty(t: usize) -> f64 {
    let x = t as f64;
    (0.55 + 0.3 * (x / 97.0).sin() + 0.2 * (x / 13.0).sin() * (x / 411.0).cos()).clamp(0.0, 1.0)
}

/// Steps `hub` and a copy of it stepped by the scalar path only, with `demand(t)` for
/// `seconds` steps of `h`, and requires the same bits everywhere after every step.
fn assert_lanes_match_scalar(hub: Hub, demand: impl Fn(usize) -> Demand, seconds: usize, h: f64) {
    let mut lanes = hub;
    let mut scalar = lanes.clone();
    scalar.lanes_enabled = false;
    for t in 0..seconds {
        lanes.step(demand(t), h).unwrap();
        scalar.step(demand(t), h).unwrap();
        assert_eq!(lanes.snapshot(), scalar.snapshot(), "t = {t}");
        assert_eq!(lanes.readings(), scalar.readings(), "t = {t}");
        let (a, b) = (lanes.totals(), scalar.totals());
        assert_eq!(
            (
                a.energy.to_bits(),
                a.h2_produced.to_bits(),
                a.running.to_bits()
            ),
            (
                b.energy.to_bits(),
                b.h2_produced.to_bits(),
                b.running.to_bits()
            ),
            "t = {t}"
        );
    }
    assert!(
        lanes.lanes.is_some() && scalar.lanes.is_none(),
        "the lanes were not used"
    );
}

#[test]
fn lanes_step_individual_modules_as_the_scalar_path_does_bit_for_bit() {
    let base = Parameters::default();
    let n = 37; // not a multiple of four lanes or of a chunk
    let rated = n as f64 * crate::dispatch::power_at_setpoint(&base, 100.0);
    for (policy, below) in [
        (DispatchPolicy::Equal, BelowMinimum::Standby),
        (DispatchPolicy::Sequential, BelowMinimum::Off),
        (DispatchPolicy::Rotation, BelowMinimum::Standby),
    ] {
        let sets = crate::spread::spread_parameters(&base, n, 0.03, 11);
        let hub = Hub::with_parameter_sets(
            sets.clone(),
            config(n as u32, policy, below),
            Demand::Power(0.6 * rated),
        )
        .unwrap();
        assert_lanes_match_scalar(hub, |t| Demand::Power(gusty(t) * rated), 1500, 1.0);
        let hub = Hub::with_parameter_sets(
            sets,
            config(n as u32, policy, below),
            Demand::Setpoint(80.0),
        )
        .unwrap();
        assert_lanes_match_scalar(hub, |t| Demand::Setpoint(100.0 * gusty(t)), 700, 2.5);
    }
}

#[test]
fn thousands_of_modules_step_on_every_core_with_the_same_bits() {
    // Above PARALLEL_FROM groups the chunks run on rayon's pool; the sums are still in order.
    let base = Parameters::default();
    let n = PARALLEL_FROM + 321;
    let rated = n as f64 * crate::dispatch::power_at_setpoint(&base, 100.0);
    let sets = crate::spread::spread_parameters(&base, n, 0.03, 5);
    let hub = Hub::with_parameter_sets(
        sets,
        config(n as u32, DispatchPolicy::Equal, BelowMinimum::Standby),
        Demand::Power(0.7 * rated),
    )
    .unwrap();
    assert_lanes_match_scalar(hub, |t| Demand::Power(gusty(40 * t) * rated), 60, 1.0);
}

#[test]
fn kept_survey_and_readings_are_the_ones_summed_afresh() {
    let base = Parameters::default();
    let rated = 40.0 * crate::dispatch::power_at_setpoint(&base, 100.0);
    let sets = crate::spread::spread_parameters(&base, 40, 0.03, 2);
    let mut hub = Hub::with_parameter_sets(
        sets,
        config(40, DispatchPolicy::Sequential, BelowMinimum::Standby),
        Demand::Power(0.5 * rated),
    )
    .unwrap();
    for t in 0..900 {
        hub.step(Demand::Power(gusty(t) * rated), 1.0).unwrap();
        let kept = (
            hub.surveyed.expect("a step keeps its survey"),
            hub.readings(),
        );
        let mut fresh = hub.clone();
        (fresh.surveyed, fresh.read) = (None, None);
        let survey = fresh.survey();
        assert_eq!(
            (
                kept.0.carrying,
                kept.0.others.to_bits(),
                kept.0.next_event.map(f64::to_bits)
            ),
            (
                survey.carrying,
                survey.others.to_bits(),
                survey.next_event.map(f64::to_bits)
            ),
            "t = {t}"
        );
        assert_eq!(kept.1, fresh.readings(), "t = {t}");
    }
}

#[test]
fn a_snapshot_whose_dispatch_target_disagrees_with_its_groups_is_refused() {
    let mut hub = Hub::new(
        Parameters::default(),
        config(10, DispatchPolicy::Sequential, BelowMinimum::Standby),
        Demand::Setpoint(50.0),
    )
    .unwrap();
    let mut snapshot = hub.snapshot();
    snapshot.running_target += 1;
    let before = hub.snapshot();
    let e = hub.restore(snapshot.clone()).unwrap_err();
    assert_eq!(
        e,
        SnapshotError::DispatchMismatch {
            active: u64::from(snapshot.running_target - 1),
            target: snapshot.running_target
        }
    );
    assert!(e.to_string().contains("dispatch target"), "{e}");
    assert_eq!(hub.snapshot(), before);
}

/// Found by fuzzing fmi2DeSerializeFMUstate: a restored state may carry start counts near
/// u64::MAX; the next start must not overflow (a panic in checked builds, a wrap otherwise).
#[test]
fn start_counters_of_a_restored_state_saturate() {
    let mut hub = Hub::new(
        Parameters::default(),
        config(10, DispatchPolicy::Rotation, BelowMinimum::Standby),
        Demand::Setpoint(30.0),
    )
    .unwrap();
    run(&mut hub, Demand::Setpoint(30.0), 100.0, 10.0);
    let mut snapshot = hub.snapshot();
    snapshot.totals.starts = u64::MAX - 1;
    for g in &mut snapshot.groups {
        g.starts = u64::MAX - 1;
    }
    hub.restore(snapshot).unwrap();
    run(&mut hub, Demand::Setpoint(100.0), 100.0, 10.0);
    assert_eq!(hub.totals().starts, u64::MAX);
    assert!(hub
        .snapshot()
        .groups
        .iter()
        .all(|g| g.starts >= u64::MAX - 1));
}

#[test]
fn starts_from_standby_are_warm_and_from_off_cold() {
    let p = Parameters::default();
    for (below, warm) in [(BelowMinimum::Standby, 4), (BelowMinimum::Off, 0)] {
        let mut hub = Hub::new(
            p,
            config(4, DispatchPolicy::Sequential, below),
            Demand::Setpoint(90.0),
        )
        .unwrap();
        run(&mut hub, Demand::Setpoint(0.0), 600.0, 10.0);
        run(&mut hub, Demand::Setpoint(90.0), 600.0, 10.0);
        assert_eq!(hub.count_in(OperatingState::Steady), 4, "{below:?}");
        assert_eq!(
            (hub.totals().starts, hub.totals().warm_starts),
            (4, warm),
            "{below:?}"
        );
    }
}

#[test]
fn target_dispatch_runs_the_modules_nearest_the_target_in_setpoint_and_power_mode() {
    let p = Parameters::default();
    let cfg = HubConfig {
        dispatch_target: 75.0,
        ..config(20, DispatchPolicy::Target, BelowMinimum::Standby)
    };
    // 30 % of 20 modules = 600 module-%: 8 modules at 75 %.
    let mut hub = Hub::new(p, cfg, Demand::Setpoint(30.0)).unwrap();
    run(&mut hub, Demand::Setpoint(30.0), 3600.0, 1.0);
    assert_eq!(hub.count_in(OperatingState::Steady), 8);
    let one = Module::new(p, 75.0).unwrap();
    assert!((hub.h2_flow() - 8.0 * one.h2_flow()).abs() <= 1e-12 * hub.h2_flow());
    // In power mode: the target's power, 12 modules' worth → 12 modules at exactly 75 %.
    let at_target = power_at_setpoint(&p, 75.0);
    let demand = Demand::Power(12.0 * at_target);
    let mut hub = Hub::new(p, cfg, demand).unwrap();
    run(&mut hub, demand, 3600.0, 1.0);
    assert_eq!(hub.count_in(OperatingState::Steady), 12);
    assert!((hub.power() - 12.0 * at_target).abs() <= 1e-9 * hub.power());
    // Sequential runs fewer at the same demand (⌈12·P(75 %)/P(100 %)⌉), equal all 20.
    let seq = HubConfig {
        policy: DispatchPolicy::Sequential,
        ..cfg
    };
    let mut hub = Hub::new(p, seq, demand).unwrap();
    run(&mut hub, demand, 3600.0, 1.0);
    assert!(hub.count_in(OperatingState::Steady) < 12);
}

#[test]
fn a_dispatch_target_outside_the_window_is_refused_by_name() {
    let p = Parameters::default();
    for target in [59.9, 100.1, f64::NAN] {
        let cfg = HubConfig {
            dispatch_target: target,
            ..config(4, DispatchPolicy::Target, BelowMinimum::Off)
        };
        let err = Hub::new(p, cfg, Demand::Setpoint(50.0)).unwrap_err();
        assert_eq!(err.name, "dispatchTargetSetpoint", "{target}");
    }
    // Other policies ignore it.
    let cfg = HubConfig {
        dispatch_target: 10.0,
        ..config(4, DispatchPolicy::Sequential, BelowMinimum::Off)
    };
    assert!(Hub::new(p, cfg, Demand::Setpoint(50.0)).is_ok());
}

#[test]
fn target_dispatch_counts_for_the_base_and_shares_a_request_among_the_running_modules() {
    let p = Parameters::default();
    let cfg = HubConfig {
        dispatch_target: 75.0,
        ..config(20, DispatchPolicy::Target, BelowMinimum::Standby)
    };
    let at_target = power_at_setpoint(&p, 75.0);
    let base = Demand::Power(8.0 * at_target);
    // A request of one module's power less: the 8 running modules share it (each at 7/8 of
    // its power, outside the band around 75 % but inside the window)...
    let asked = Demand::Power(7.0 * at_target);
    let mut hub = Hub::new(p, cfg, base).unwrap();
    for _ in 0..3600 {
        hub.step_with_base(asked, base, 1.0).unwrap();
    }
    assert_eq!(hub.count_in(OperatingState::Steady), 8);
    assert!(
        (hub.power() - 7.0 * at_target).abs() <= 1e-9 * hub.power(),
        "{} {}",
        hub.power(),
        7.0 * at_target
    );
    // ... where counting for the demand itself stops one of them.
    let mut counted = Hub::new(p, cfg, base).unwrap();
    for _ in 0..3600 {
        counted.step(asked, 1.0).unwrap();
    }
    assert_eq!(counted.count_in(OperatingState::Steady), 7);
    // A request the window cannot take with 8 modules changes the count as far as it must:
    // ⌊4·P(75 %)/P(60 %)⌋ modules stay (the hub draws the demand once the others' standby,
    // which the reference pays for, has ended).
    let deep = Demand::Power(4.0 * at_target);
    let most = (4.0 * at_target / power_at_setpoint(&p, 60.0)).floor() as u32;
    for _ in 0..7200 {
        hub.step_with_base(deep, base, 1.0).unwrap();
    }
    assert_eq!(hub.count_in(OperatingState::Steady), most);
    assert!(
        (hub.power() - 4.0 * at_target).abs() <= 1e-6 * hub.power(),
        "{} {} {most} {}",
        hub.power(),
        4.0 * at_target,
        hub.count_in(OperatingState::Standby)
    );
}

#[test]
fn modules_held_in_warm_standby_at_the_start_draw_standby_power_and_start_warm() {
    let p = Parameters::default();
    let op = OperationParameters::default();
    let cfg = HubConfig {
        initial_standby: 3,
        ..config(10, DispatchPolicy::Sequential, BelowMinimum::Standby)
    };
    // 40 % of 10 modules at 100 % each: 4 run, 3 wait warm, 3 are idle.
    let mut hub = Hub::new(p, cfg, Demand::Setpoint(40.0)).unwrap();
    let running = 4.0 * power_at_setpoint(&p, 100.0);
    assert_eq!(
        [
            OperatingState::Steady,
            OperatingState::Standby,
            OperatingState::Idle
        ]
        .map(|s| hub.count_in(s)),
        [4, 3, 3]
    );
    assert!((hub.power() - (running + 3.0 * op.standby_power)).abs() <= 1e-9 * running);
    // Asked for all 10: the warm three run after warmStartTime, the cold three after
    // coldStartTime.
    let warm_started = op.warm_start_time + 1.0;
    run(&mut hub, Demand::Setpoint(100.0), warm_started, 1.0);
    assert_eq!(hub.count_in(OperatingState::Steady), 7);
    assert_eq!(hub.totals().warm_starts, 3);
    run(&mut hub, Demand::Setpoint(100.0), op.cold_start_time, 1.0);
    assert_eq!(hub.count_in(OperatingState::Steady), 10);
    assert_eq!((hub.totals().starts, hub.totals().warm_starts), (6, 3));
    // More than the modules not running: every one of them waits warm.
    let all = HubConfig {
        initial_standby: 10,
        ..cfg
    };
    let hub = Hub::new(p, all, Demand::Setpoint(40.0)).unwrap();
    assert_eq!(hub.count_in(OperatingState::Standby), 6);
    // More than the hub has: refused by name.
    let too_many = HubConfig {
        initial_standby: 11,
        ..cfg
    };
    let err = Hub::new(p, too_many, Demand::Setpoint(40.0)).unwrap_err();
    assert_eq!(err.name, "initialStandby");
}

#[test]
fn a_power_reference_with_modules_held_warm_starts_in_steady_state() {
    let p = Parameters::default();
    let op = OperationParameters::default();
    let cfg = HubConfig {
        initial_standby: 4,
        dispatch_target: 80.0,
        ..config(20, DispatchPolicy::Target, BelowMinimum::Standby)
    };
    let reference = 10.0 * power_at_setpoint(&p, 80.0);
    let demand = Demand::Power(reference);
    let mut hub = Hub::new(p, cfg, demand).unwrap();
    assert_eq!(hub.count_in(OperatingState::Steady), 10);
    assert_eq!(hub.count_in(OperatingState::Standby), 4);
    // The hub draws the reference from the start: the running modules share what the warm
    // ones leave, and stay there.
    assert!((hub.power() - reference).abs() <= 1e-9 * reference);
    let flow = hub.h2_flow();
    let share = (reference - 4.0 * op.standby_power) / 10.0;
    run(&mut hub, demand, 600.0, 1.0);
    assert!((hub.h2_flow() - flow).abs() <= 1e-12 * flow);
    assert!((hub.power() - reference).abs() <= 1e-9 * reference);
    let current = hub.h2_flow() / (10.0 * p.h2_coefficient);
    let drawn = (p.voltage_intercept + p.ohmic_resistance * current) * current;
    assert!((drawn - share).abs() <= 1e-9 * share);
}
