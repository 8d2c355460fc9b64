//! The hub with the stack temperature: N equal modules are N single modules, stopped modules
//! cool in closed form, results do not depend on the step size, equal histories share a group.

use super::*;
use crate::thermal::ThermalParameters;
use crate::Module;

/// The hub tests' configuration with every module's stack temperature modelled.
fn config(
    n: u32,
    policy: DispatchPolicy,
    below: BelowMinimum,
    thermal: ThermalParameters,
) -> HubConfig {
    HubConfig {
        thermal: Some(thermal),
        ..super::tests::config(n, policy, below)
    }
}

#[test]
fn an_equal_hub_is_n_thermal_modules() {
    let (p, t) = (Parameters::default(), ThermalParameters::default());
    let n = 7;
    let mut hub = Hub::new(
        p,
        config(n, DispatchPolicy::Equal, BelowMinimum::Minimum, t),
        Demand::Setpoint(70.0),
    )
    .unwrap();
    let mut one = Module::with_thermal(p, t, crate::thermal::AMBIENT_START, 70.0).unwrap();
    for (k, u) in [95.0, 60.0, 100.0, 75.0, 100.0].iter().enumerate() {
        let h = 300.0 + 17.0 * k as f64;
        hub.step(Demand::Setpoint(*u), h).unwrap();
        one.step(*u, h).unwrap();
        let r = hub.readings();
        assert!(
            (r.temperature - one.temperature()).abs() < 1e-12,
            "{} vs {}",
            r.temperature,
            one.temperature()
        );
        assert!(
            (hub.totals().energy - n as f64 * one.energy()).abs() < 1e-12 * hub.totals().energy
        );
        assert!((r.voltage - one.voltage()).abs() < 1e-12);
        assert!((r.cooling_power - n as f64 * one.cooling_power()).abs() < 1e-9);
    }
    assert_eq!(hub.groups().len(), 1, "equal histories share a group");
}

#[test]
fn a_stopped_stack_cools_in_closed_form() {
    let t = ThermalParameters {
        initial_temperature: 340.0,
        ..ThermalParameters::default()
    };
    let tau = t.thermal_resistance * t.heat_capacity;
    for h in [7200.0, 60.0, 0.5] {
        let mut hub = Hub::new(
            Parameters::default(),
            config(3, DispatchPolicy::Sequential, BelowMinimum::Off, t),
            Demand::Setpoint(0.0),
        )
        .unwrap();
        hub.set_ambient_temperature(270.0);
        for _ in 0..(7200.0 / h) as usize {
            hub.step(Demand::Setpoint(0.0), h).unwrap();
        }
        // Above the setpoint the cooling runs at Qmax until the stack is down to Ts, then the
        // stack loses heat to ambient alone: T = Ta + (Ts − Ta)·e^(−(t − t1)/τ).
        let (ta, ts, qmax) = (270.0, t.cooling_setpoint, t.max_cooling_power);
        // Above Ts: C·dT/dt = −(T − Ta)/Rth − Qmax, an exponential toward Ta − Qmax·Rth.
        let floor = ta - qmax * t.thermal_resistance;
        let t1 = tau * ((340.0 - floor) / (ts - floor)).ln();
        let expected = ta + (ts - ta) * (-(7200.0 - t1) / tau).exp();
        let got = hub.readings().temperature;
        assert!(
            (got - expected).abs() < 1e-9,
            "h = {h}: {got} K vs {expected} K"
        );
        assert_eq!(hub.readings().cooling_power, 0.0);
        assert_eq!(hub.totals().energy, 0.0, "idle modules draw nothing");
    }
}

#[test]
fn a_sequential_thermal_hub_does_not_depend_on_the_step_size() {
    let t = ThermalParameters {
        heat_capacity: 2_000.0, // a 400 s time constant: the starts and stops show
        ..ThermalParameters::default()
    };
    let p = Parameters::default();
    let rated = crate::dispatch::power_at_setpoint(&p, 100.0);
    // A power reference that starts and stops modules: 0.5, 2.7, 1.2, 3.9, 0.2 modules' worth.
    let program = [0.5, 2.7, 1.2, 3.9, 0.2];
    let run = |h: f64| {
        let mut hub = Hub::new(
            p,
            config(4, DispatchPolicy::Sequential, BelowMinimum::Standby, t),
            Demand::Power(0.0),
        )
        .unwrap();
        let mut at = vec![];
        for share in program {
            for _ in 0..(600.0 / h).round() as usize {
                hub.step(Demand::Power(share * rated), h).unwrap();
            }
            let r = hub.readings();
            at.push((r.temperature, hub.totals().energy, r.counts));
        }
        at
    };
    let reference = run(600.0);
    for h in [1.0, 7.5, 60.0] {
        for (k, ((t1, e1, c1), (t0, e0, c0))) in run(h).iter().zip(&reference).enumerate() {
            assert_eq!(c1, c0, "h = {h}, segment {k}: the same states");
            assert!(
                (t1 - t0).abs() < 1e-6,
                "h = {h}, segment {k}: {t1} K vs {t0} K"
            );
            assert!(
                (e1 - e0).abs() < 1e-9 * e0.max(1.0),
                "h = {h}, segment {k}: {e1} J vs {e0} J"
            );
        }
    }
}

#[test]
fn without_the_thermal_model_the_hub_reads_the_curves_temperature() {
    let cfg = HubConfig {
        n_modules: 5,
        ..Default::default()
    };
    let mut hub = Hub::new(Parameters::default(), cfg, Demand::Setpoint(80.0)).unwrap();
    hub.step(Demand::Setpoint(90.0), 100.0).unwrap();
    let r = hub.readings();
    assert_eq!((r.temperature, r.cooling_power), (328.15, 0.0));
}

#[test]
fn a_restored_thermal_hub_continues_bit_for_bit() {
    let t = ThermalParameters::default();
    let cfg = config(6, DispatchPolicy::Sequential, BelowMinimum::Standby, t);
    let p = Parameters::default();
    let rated = crate::dispatch::power_at_setpoint(&p, 100.0);
    let mut hub = Hub::new(p, cfg, Demand::Power(2.5 * rated)).unwrap();
    for k in 0..20 {
        hub.step(Demand::Power((1.0 + (k % 5) as f64) * rated), 90.0)
            .unwrap();
    }
    let saved = hub.snapshot();
    let mut twin = Hub::new(p, cfg, Demand::Power(0.0)).unwrap();
    twin.restore(saved).unwrap();
    for k in 0..10 {
        let d = Demand::Power((0.5 + k as f64) * rated * 0.5);
        hub.step(d, 45.0).unwrap();
        twin.step(d, 45.0).unwrap();
    }
    assert_eq!(hub.snapshot(), twin.snapshot());
    let mut bad = hub.snapshot();
    bad.groups[0].unit.temperature = -1.0;
    assert!(twin.restore(bad).is_err());
}

/// Time until the one module of `hub` is Steady under `demand`, in steps of 1 s (at most 1000).
fn start_time(hub: &mut Hub, demand: Demand) -> u32 {
    (1..=1000)
        .find(|_| {
            hub.step(demand, 1.0).unwrap();
            hub.count_in(OperatingState::Steady) == 1
        })
        .unwrap_or(u32::MAX)
}

#[test]
fn a_warm_stack_starts_warm_and_a_cold_one_cold_whatever_the_state() {
    let p = Parameters::default();
    let op = OperationParameters::default();
    // Off (Idle) but still warm: a warm start.
    let warm = ThermalParameters {
        initial_temperature: 328.15,
        ..ThermalParameters::default()
    };
    let mut hub = Hub::new(
        p,
        config(1, DispatchPolicy::Sequential, BelowMinimum::Off, warm),
        Demand::Setpoint(80.0),
    )
    .unwrap();
    hub.step(Demand::Setpoint(0.0), 120.0).unwrap();
    assert_eq!(hub.count_in(OperatingState::Idle), 1);
    assert!(hub.readings().temperature > warm.warm_start_temperature);
    assert_eq!(
        start_time(&mut hub, Demand::Setpoint(80.0)) as f64,
        op.warm_start_time
    );
    assert_eq!((hub.totals().starts, hub.totals().warm_starts), (1, 1));
    // In Standby but colder than the warm-start temperature: a cold start.
    let cold = ThermalParameters {
        warm_start_temperature: 350.0,
        ..warm
    };
    let mut hub = Hub::new(
        p,
        config(1, DispatchPolicy::Sequential, BelowMinimum::Standby, cold),
        Demand::Setpoint(80.0),
    )
    .unwrap();
    hub.step(Demand::Setpoint(0.0), 10.0).unwrap();
    assert_eq!(hub.count_in(OperatingState::Standby), 1);
    assert_eq!(
        start_time(&mut hub, Demand::Setpoint(80.0)) as f64,
        op.cold_start_time
    );
    assert_eq!(hub.totals().starts, 1);
    assert_eq!(hub.totals().warm_starts, 0);
}

/// One module of a sequential hub that goes to standby (for ten hours) at 5 °C ambient,
/// running at 80 % from `initial` [K] until the first step.
fn standby_hub(heater: f64, initial: f64) -> Hub {
    let thermal = ThermalParameters {
        initial_temperature: initial,
        standby_heater_power: heater,
        ..ThermalParameters::default()
    };
    let mut cfg = config(
        1,
        DispatchPolicy::Sequential,
        BelowMinimum::Standby,
        thermal,
    );
    cfg.operation.standby_duration = 36_000.0;
    let mut hub = Hub::new(Parameters::default(), cfg, Demand::Setpoint(80.0)).unwrap();
    hub.set_ambient_temperature(278.15);
    hub
}

#[test]
fn a_standby_heater_holds_the_setpoint_and_draws_the_loss() {
    let t = ThermalParameters::default();
    let mut hub = standby_hub(400.0, t.cooling_setpoint);
    let hold = (t.cooling_setpoint - 278.15) / t.thermal_resistance; // 250 W
    let op = OperationParameters::default();
    for _ in 0..120 {
        hub.step(Demand::Setpoint(0.0), 60.0).unwrap();
        assert_eq!(hub.count_in(OperatingState::Standby), 1);
        assert_eq!(hub.readings().temperature, t.cooling_setpoint);
        assert!((hub.readings().power - (op.standby_power + hold)).abs() < 1e-9);
    }
    let energy = (op.standby_power + hold) * 7200.0;
    assert!((hub.totals().energy - energy).abs() < 1e-9 * energy);
    // Held warm: a warm start.
    assert_eq!(
        start_time(&mut hub, Demand::Setpoint(80.0)) as f64,
        op.warm_start_time
    );
}

#[test]
fn a_heater_too_weak_for_the_loss_slows_the_cooling() {
    let t = ThermalParameters::default();
    let heater = 100.0;
    let mut hub = standby_hub(heater, t.cooling_setpoint);
    let tau = t.thermal_resistance * t.heat_capacity;
    // C dT/dt = Qh − (T − Ta)/Rth: toward Ta + Rth·Qh = 25 °C.
    let toward = 278.15 + t.thermal_resistance * heater;
    for k in 1..=12 {
        hub.step(Demand::Setpoint(0.0), 600.0).unwrap();
        let time = 600.0 * k as f64;
        let want = toward + (t.cooling_setpoint - toward) * (-time / tau).exp();
        assert!((hub.readings().temperature - want).abs() < 1e-9, "{k}");
        let power = OperationParameters::default().standby_power + heater;
        assert!((hub.readings().power - power).abs() < 1e-12);
        assert!((hub.totals().energy - power * time).abs() < 1e-9 * power * time);
    }
}

#[test]
fn a_cool_stack_in_standby_is_heated_to_the_setpoint_then_held() {
    let t = ThermalParameters::default();
    let heater = 400.0;
    let mut hub = standby_hub(heater, 303.15);
    hub.step(Demand::Setpoint(0.0), 1.0).unwrap(); // one second at 80 %, then standby
    hub.step(Demand::Setpoint(0.0), 1.0).unwrap();
    let (t0, e0) = (hub.readings().temperature, hub.totals().energy);
    assert!(t0 < 304.0, "{t0}");
    let tau = t.thermal_resistance * t.heat_capacity;
    let toward = 278.15 + t.thermal_resistance * heater; // 85 °C: above the setpoint
    let reach = tau * ((toward - t0) / (toward - t.cooling_setpoint)).ln();
    let hold = (t.cooling_setpoint - 278.15) / t.thermal_resistance;
    let standby = OperationParameters::default().standby_power;
    for h in [7.5, 60.0, 900.0] {
        let mut copy = hub.clone();
        let span = 900.0 * (1.0 + (reach / 900.0).ceil());
        for _ in 0..(span / h).round() as usize {
            copy.step(Demand::Setpoint(0.0), h).unwrap();
        }
        assert_eq!(copy.readings().temperature, t.cooling_setpoint, "h = {h}");
        let energy = standby * span + heater * reach + hold * (span - reach);
        let drawn = copy.totals().energy - e0;
        assert!(
            (drawn - energy).abs() < 1e-9 * energy,
            "h = {h}: {drawn} vs {energy}"
        );
    }
    // Half-way there, the exponential toward 85 °C.
    let mut copy = hub.clone();
    copy.step(Demand::Setpoint(0.0), reach / 2.0).unwrap();
    let want = toward + (t0 - toward) * (-reach / 2.0 / tau).exp();
    assert!((copy.readings().temperature - want).abs() < 1e-9);
}

#[test]
fn without_a_heater_a_module_in_standby_cools_and_starts_cold() {
    let t = ThermalParameters::default();
    let mut hub = standby_hub(0.0, t.cooling_setpoint);
    hub.step(Demand::Setpoint(0.0), 7200.0).unwrap();
    let tau = t.thermal_resistance * t.heat_capacity;
    let want = 278.15 + (t.cooling_setpoint - 278.15) * (-7200.0 / tau).exp();
    assert!((hub.readings().temperature - want).abs() < 1e-9);
    assert_eq!(
        hub.readings().power,
        OperationParameters::default().standby_power
    );
    assert_eq!(
        start_time(&mut hub, Demand::Setpoint(80.0)) as f64,
        OperationParameters::default().cold_start_time
    );
}

#[test]
fn after_an_ambient_change_the_reference_is_shared_as_a_fresh_hub_shares_it() {
    // Modules stopped to warm standby whose heaters hold the stack: their power, which the
    // running modules' share of a power reference leaves out, follows the ambient.
    let t = ThermalParameters::default();
    let thermal = ThermalParameters {
        initial_temperature: t.cooling_setpoint,
        standby_heater_power: 400.0,
        ..t
    };
    let cfg = config(
        6,
        DispatchPolicy::Sequential,
        BelowMinimum::Standby,
        thermal,
    );
    let p = Parameters::default();
    let rated = crate::dispatch::power_at_setpoint(&p, 100.0);
    let demand = |k: usize| Demand::Power(if k < 10 { 4.5 } else { 2.5 } * rated);
    let mut hub = Hub::new(p, cfg, demand(0)).unwrap();
    let mut fresh = Hub::new(p, cfg, demand(0)).unwrap();
    for k in 0..60 {
        let ambient = 278.15 + 5.0 * (k / 7) as f64;
        hub.set_ambient_temperature(ambient);
        // Restored from the hub's own state: nothing kept from an earlier step.
        fresh.restore(hub.snapshot()).unwrap();
        fresh.set_ambient_temperature(ambient);
        hub.step(demand(k), 30.0).unwrap();
        fresh.step(demand(k), 30.0).unwrap();
        assert_eq!(hub.snapshot(), fresh.snapshot(), "step {k}");
        assert_eq!(hub.readings(), fresh.readings(), "step {k}");
    }
    assert!(hub.count_in(OperatingState::Standby) >= 2);
}
