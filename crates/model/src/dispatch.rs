//! Dispatch: how many modules of a hub run, and at which setpoint.
//!
//! The hub's demand is expressed per module ("module units": % of one module's setpoint in
//! setpoint mode, W of one module's stack power in power mode). With a total demand D (sum
//! over modules), module limits [m, M] and a hysteresis band b per module in the same units
//! (the hub's band is N·b: the same fraction of the hub as b is of one module):
//! - `Equal` (the paper): all N modules run at the share D/N, or none; they stop when
//!   D/N < m − b and start again when D/N ≥ m.
//! - `Sequential`: as few modules as possible, n = ⌈D/M⌉ (0 if D < m); the count only falls
//!   once the demand is N·b below the next threshold, and never so far that a running module
//!   would drop below m: n stays between ⌈D/M⌉ and min(⌈(D+N·b)/M⌉, ⌊D/m⌋). (A band of one
//!   module's b would let a large hub follow every ripple of a wind-driven reference with
//!   starts and stops.) Each runs at D/n. Between M and 2m (e.g. 100…120 % of a module) no
//!   split keeps every module in [m, M]: the running modules are clamped to m (the hub
//!   over-produces there).
//! - `Rotation`: the count of `Sequential`; which modules run is chosen by running hours
//!   and starts (see [`crate::model::hub`]).
//! - `Target`: the count that puts the running modules nearest to a target load t,
//!   n = round(D/t) within [⌈D/M⌉, min(N, ⌊D/m⌋)] (0 if D < m), each at D/n; the count is kept
//!   while the running modules' share D/n stays within b of t and in [m, M]. Sequential is
//!   its end t = M; the most modules that fit the window its other end t = m. The count
//!   follows the demand without the reserves' request (the base): an activation is shared by
//!   the running modules, and changes their count only where the window requires it
//!   ([`within_window`]). The reserve a hub can sell depends on t: headroom to m for
//!   decreases, the running modules' summed ramp rate and headroom to M for increases
//!   (`aem-prequalify --optimise-dispatch` finds the best t).

use super::grid::GridParameters;
use super::parameters::{ParameterError, Parameters};
use super::select::at_least;

/// Dispatch policy; the discriminant is the FMU's Integer code.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DispatchPolicy {
    /// 1: every module gets the same share (the paper).
    Equal = 1,
    /// 2: as few modules as possible, each within its operating window.
    Sequential = 2,
    /// 3: sequential, fewest running hours (then starts) first.
    Rotation = 3,
    /// 4: the running modules nearest a target load, the others stopped.
    Target = 4,
}

impl DispatchPolicy {
    /// From the FMU's Integer code; the error names the value.
    pub fn from_code(code: i64) -> Result<Self, ParameterError> {
        match code {
            1 => Ok(Self::Equal),
            2 => Ok(Self::Sequential),
            3 => Ok(Self::Rotation),
            4 => Ok(Self::Target),
            _ => Err(ParameterError {
                name: "dispatch",
                value: code as f64,
                requirement: "must be 1 (equal), 2 (sequential), 3 (rotation) or 4 (target)".into(),
            }),
        }
    }
}

/// What the hub is asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Demand {
    /// Production setpoint [% of the hub's nominal], i.e. the same % for each module.
    Setpoint(f64),
    /// Electric (stack) power reference of the whole hub [W].
    Power(f64),
}

impl Demand {
    /// The input's value.
    pub fn value(self) -> f64 {
        match self {
            Demand::Setpoint(v) | Demand::Power(v) => v,
        }
    }
}

/// One module's load window and the hysteresis band, in module units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Smallest load of a running module.
    pub min: f64,
    /// Largest load of a module.
    pub max: f64,
    /// Hysteresis band against switching modules on and off repeatedly.
    pub band: f64,
    /// The load a running module should be nearest to (`Target`), within [min, max].
    pub target: f64,
}

/// Number of modules that should run for a total demand `total` (module units, summed over
/// the hub), given the count that ran before. `always_on`: belowMinimum = 0, never stop.
pub fn running_count(
    policy: DispatchPolicy,
    modules: u32,
    total: f64,
    limits: Limits,
    previous: u32,
    always_on: bool,
) -> u32 {
    if always_on {
        return modules;
    }
    let n = modules as f64;
    match policy {
        DispatchPolicy::Equal => {
            let share = total / n;
            if share >= limits.min {
                modules
            } else if share < limits.min - limits.band {
                0
            } else if previous > 0 {
                modules
            } else {
                0
            }
        }
        DispatchPolicy::Sequential | DispatchPolicy::Rotation => {
            let count = |d: f64| -> u32 {
                if d < limits.min {
                    0
                } else {
                    (d / limits.max).ceil().min(n) as u32
                }
            };
            let need = count(total);
            let no_lower_than_min = (total / limits.min).floor().min(n) as u32;
            let keep = count(total + limits.band * n)
                .min(no_lower_than_min)
                .max(need);
            previous.clamp(need, keep)
        }
        DispatchPolicy::Target => {
            let kept = within_window(modules, total, limits, previous);
            if kept > 0
                && kept == previous
                && (total / kept as f64 - limits.target).abs() <= limits.band
            {
                return kept;
            }
            within_window(
                modules,
                total,
                limits,
                (total / limits.target).round() as u32,
            )
        }
    }
}

/// `count` running modules brought into the window for a total demand `total`: within
/// [⌈D/M⌉, min(N, ⌊D/m⌋)] (the lower bound wins where the two cross), 0 if D < m.
pub fn within_window(modules: u32, total: f64, limits: Limits, count: u32) -> u32 {
    if total < limits.min {
        return 0;
    }
    let n = modules as f64;
    let need = (total / limits.max).ceil().min(n) as u32;
    let most = ((total / limits.min).floor().min(n) as u32).max(need);
    count.clamp(need, most)
}

/// Setpoint [%] at which a module's steady stack power is `power` [W]: the positive root of
/// P = (V0 + R·I)·I, I = 2P / (V0 + √(V0² + 4RP)) (the cancellation-free form, also valid
/// for R = 0), divided by K: u = 2P / (K·(V0 + √(V0² + 4RP))), one division. Negative powers
/// give 0.
pub fn setpoint_for_power(params: &Parameters, power: f64) -> f64 {
    setpoint_at_power(
        params.voltage_intercept,
        params.ohmic_resistance,
        params.gain,
        power,
    )
}

/// [`setpoint_for_power`] from V0 [V], R [Ω] and K [A/%] (for the lanes, which hold no
/// `Parameters`; one formula for both).
#[inline(always)]
pub fn setpoint_at_power(v0: f64, r: f64, gain: f64, power: f64) -> f64 {
    let p = at_least(power, 0.0);
    let u = 2.0 * p / (gain * (v0 + (v0 * v0 + 4.0 * r * p).sqrt()));
    if u.is_finite() {
        u
    } else {
        0.0
    }
}

/// Steady stack power of a module at `setpoint` [%]: (V0 + R·K·u)·K·u [W].
pub fn power_at_setpoint(params: &Parameters, setpoint: f64) -> f64 {
    let i = params.gain * setpoint;
    (params.voltage_intercept + params.ohmic_resistance * i) * i
}

/// A running module's steady power at a setpoint, on the side a power reference means: the
/// stack's (V0 + R·I)·I, or on the grid side ((V0 + Vs) + (R + Rs)·I)·I + P0 + P_aux with the
/// supply's losses and the auxiliaries (see [`crate::grid`]); I = K·u.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PowerCurve {
    /// Power per ampere at no current [V].
    voltage: f64,
    /// Power per ampere squared [Ω].
    resistance: f64,
    /// Power at no current [W].
    offset: f64,
    /// K [A/%].
    gain: f64,
}

impl PowerCurve {
    /// The curve a power reference follows for a module of `params` with `grid`.
    pub fn new(params: &Parameters, grid: &GridParameters) -> Self {
        let stack = PowerCurve {
            voltage: params.voltage_intercept,
            resistance: params.ohmic_resistance,
            offset: 0.0,
            gain: params.gain,
        };
        if !grid.grid_side_reference {
            return stack;
        }
        PowerCurve {
            voltage: stack.voltage + grid.supply_loss_voltage,
            resistance: stack.resistance + grid.supply_loss_resistance,
            offset: grid.supply_no_load_loss + grid.auxiliary_power,
            gain: stack.gain,
        }
    }

    /// Steady power at `setpoint` [%] [W] ([`power_at_setpoint`] on the stack side).
    #[inline]
    pub fn power(&self, setpoint: f64) -> f64 {
        let i = self.gain * setpoint;
        (self.voltage + self.resistance * i) * i + self.offset
    }

    /// Setpoint [%] at which the steady power is `power` [W] ([`setpoint_for_power`] on the
    /// stack side); 0 below the power at no current.
    #[inline]
    pub fn setpoint(&self, power: f64) -> f64 {
        setpoint_at_power(
            self.voltage,
            self.resistance,
            self.gain,
            power - self.offset,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const L: Limits = Limits {
        min: 60.0,
        max: 100.0,
        band: 5.0,
        target: 80.0,
    };

    #[test]
    fn the_stack_side_curve_is_the_polarisation_curve_bit_for_bit() {
        let p = Parameters::default();
        let lossy = crate::grid::TEST_LOSSES;
        let curve = PowerCurve::new(&p, &lossy);
        for u in [0.0, 1.0, 60.0, 77.7, 100.0] {
            assert_eq!(curve.power(u).to_bits(), power_at_setpoint(&p, u).to_bits());
            let w = power_at_setpoint(&p, u);
            assert_eq!(
                curve.setpoint(w).to_bits(),
                setpoint_for_power(&p, w).to_bits()
            );
        }
    }

    #[test]
    fn the_grid_side_curve_adds_the_losses_and_auxiliaries_and_inverts() {
        let p = Parameters::default();
        let grid = GridParameters {
            grid_side_reference: true,
            ..crate::grid::TEST_LOSSES
        };
        let curve = PowerCurve::new(&p, &grid);
        for u in [1.0, 60.0, 77.7, 100.0] {
            let i = p.gain * u;
            let want = power_at_setpoint(&p, u) + grid.running_extra(i);
            assert!((curve.power(u) - want).abs() < 1e-10 * want);
            assert!((curve.setpoint(curve.power(u)) - u).abs() < 1e-12);
        }
        assert_eq!(curve.setpoint(100.0), 0.0, "below the no-current power");
    }

    #[test]
    fn power_inversion_is_the_inverse_of_the_polarisation_curve() {
        let p = Parameters::default();
        for u in [0.0, 1.0, 60.0, 77.7, 100.0, 140.0] {
            let back = setpoint_for_power(&p, power_at_setpoint(&p, u));
            assert!((back - u).abs() < 1e-12, "{u} vs {back}");
        }
        let ohmic_free = Parameters {
            ohmic_resistance: 0.0,
            ..p
        };
        assert!((setpoint_for_power(&ohmic_free, 1000.0) - 1000.0 / 35.75 / 0.534).abs() < 1e-12);
        assert_eq!(setpoint_for_power(&p, -5.0), 0.0);
    }

    #[test]
    fn sequential_counts_with_hysteresis() {
        use DispatchPolicy::Sequential as S;
        assert_eq!(running_count(S, 10, 250.0, L, 0, false), 3);
        assert_eq!(running_count(S, 10, 50.0, L, 0, false), 0);
        // The hub's band: 10 modules × 5 = 50 module-%.
        assert_eq!(
            running_count(S, 10, 57.0, L, 1, false),
            0,
            "one module would run below its minimum"
        );
        assert_eq!(
            running_count(S, 10, 160.0, L, 3, false),
            2,
            "three would run at 53 %"
        );
        assert_eq!(running_count(S, 10, 185.0, L, 3, false), 3); // 185 + 50 > 200: keep 3
        assert_eq!(running_count(S, 10, 149.0, L, 3, false), 2); // 149 + 50 < 200
        assert_eq!(running_count(S, 10, 149.0, L, 1, false), 2); // rising: ⌈149/100⌉
        assert_eq!(running_count(S, 1, 57.0, L, 1, false), 0);
        assert_eq!(running_count(S, 10, 5000.0, L, 3, false), 10);
    }

    #[test]
    fn target_counts_put_the_running_modules_nearest_the_target() {
        use DispatchPolicy::Target as T;
        // 400 module-% at a target of 80 %: 5 modules at 80 %.
        assert_eq!(running_count(T, 10, 400.0, L, 0, false), 5);
        // 430: 5.375 → 5 at 86 %; kept from 5 while within 80 ± 5 %, else re-chosen.
        assert_eq!(running_count(T, 10, 430.0, L, 0, false), 5);
        assert_eq!(
            running_count(T, 10, 420.0, L, 5, false),
            5,
            "84 % is within the band"
        );
        assert_eq!(
            running_count(T, 10, 440.0, L, 5, false),
            6,
            "88 % is not: 5.5 → 6 at 73 %"
        );
        assert_eq!(
            running_count(T, 10, 370.0, L, 6, false),
            5,
            "62 %: re-chosen"
        );
        // Never below the window nor above it, and never more modules than the hub has.
        assert_eq!(running_count(T, 10, 50.0, L, 3, false), 0);
        assert_eq!(running_count(T, 10, 70.0, L, 0, false), 1);
        assert_eq!(
            running_count(T, 10, 190.0, L, 0, false),
            2,
            "2.4 → 2 at 95 %"
        );
        assert_eq!(
            running_count(T, 10, 130.0, L, 0, false),
            2,
            "1.6 → 2 at 65 %"
        );
        assert_eq!(
            running_count(T, 10, 950.0, L, 0, false),
            10,
            "11.9 → the hub's 10"
        );
        let low = Limits { target: 60.0, ..L };
        assert_eq!(
            running_count(T, 10, 290.0, low, 0, false),
            4,
            "five would run at 58 %"
        );
        // Sequential is the end t = M.
        let top = Limits {
            target: 100.0,
            band: 0.0,
            ..L
        };
        for total in [60.0, 99.0, 101.0, 250.0, 777.0, 1000.0] {
            assert_eq!(
                running_count(T, 10, total, top, 0, false),
                running_count(DispatchPolicy::Sequential, 10, total, top, 0, false),
                "{total}"
            );
        }
        assert_eq!(DispatchPolicy::from_code(4), Ok(T));
    }

    #[test]
    fn equal_counts_with_hysteresis() {
        use DispatchPolicy::Equal as E;
        assert_eq!(running_count(E, 4, 240.0, L, 0, false), 4);
        assert_eq!(running_count(E, 4, 230.0, L, 0, false), 0);
        assert_eq!(running_count(E, 4, 230.0, L, 4, false), 4);
        assert_eq!(running_count(E, 4, 210.0, L, 4, false), 0);
        assert_eq!(running_count(E, 4, 0.0, L, 0, true), 4);
    }

    #[test]
    fn policy_codes_are_checked() {
        assert_eq!(DispatchPolicy::from_code(3), Ok(DispatchPolicy::Rotation));
        assert!(DispatchPolicy::from_code(0)
            .unwrap_err()
            .to_string()
            .contains("dispatch = 0"));
    }
}
