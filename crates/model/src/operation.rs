//! Operating states of one module and their exact transitions.
//!
//! States are named after Enapter's public electrolyser state list (MQTT reference on
//! developers.enapter.com: idle, curve, steady, standby, blowdown, …). The mapping is our
//! reading of that list, not a vendor statement:
//!
//! | state      | meaning here                        | stack current | electric power   |
//! |------------|-------------------------------------|---------------|------------------|
//! | `Idle`     | off and cold                        | 0             | 0                |
//! | `Curve`    | starting (cold or warm start)       | 0             | startPower       |
//! | `Steady`   | running: the paper's dynamics       | G(s) + limit  | (V0 + R·I)·I     |
//! | `Standby`  | kept warm; cold after standbyDuration | 0           | standbyPower     |
//! | `Blowdown` | stopping, for stopDuration          | 0             | standbyPower     |
//!
//! Transitions, for a command held over a step (a run request with a setpoint, or stop):
//! - Idle + run → Curve for coldStartTime; Standby + run → Curve for warmStartTime
//!   (each counts one start). At the end of Curve the module is Steady in steady state at
//!   the minimum setpoint, I = K·minSetpoint, and follows G(s) with the rate limit from there.
//! - Curve + stop → Idle (the start is abandoned).
//! - Steady + stop → Standby (belowMinimum = 1) or Blowdown (belowMinimum = 2).
//! - Standby held for standbyDuration → Idle; Blowdown lasts stopDuration → Idle,
//!   whatever the command (a run request waits for the end of Blowdown, then starts cold).
//!
//! All durations are known in advance, so a step is cut at each transition time and every
//! piece is integrated in closed form ([`CurrentDynamics::advance`] while Steady, constant
//! power otherwise): results do not depend on the communication step size.
//!
//! With the stack temperature modelled (a [`HeatBalance`]), every piece also advances the
//! temperature ([`crate::thermal::step`]): along the exact current while Steady, at zero current
//! (a stack that cools in closed form) otherwise; a Steady module's voltage is then the
//! temperature's, V = V0 + kV·(T − Tn) + (R + kR·(T − Tn))·I.

use std::fmt;

use super::ageing::{AgeingParameters, Drift, DriftChange};
use super::current_path::{HeldSetpoint, NoCurrent};
use super::dynamics::{CurrentDynamics, CurrentState, StepFactors};
use super::grid::GridParameters;
use super::parameters::{ParameterError, Parameters};
use super::thermal::step::{self as thermal_step, CurrentPath, ThermalError};
use super::thermal::HeatBalance;

/// Operating state of a module; the discriminant is the FMU's Integer code.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum OperatingState {
    /// Off and cold.
    Idle = 0,
    /// Starting: no stack current, draws startPower.
    Curve = 1,
    /// Running: the paper's current dynamics.
    Steady = 2,
    /// Kept warm for a quick restart: no current, draws standbyPower.
    Standby = 3,
    /// Stopping: no current, draws standbyPower for stopDuration.
    Blowdown = 4,
}

impl OperatingState {
    /// All states, in code order.
    pub const ALL: [OperatingState; 5] = [
        Self::Idle,
        Self::Curve,
        Self::Steady,
        Self::Standby,
        Self::Blowdown,
    ];

    /// The state's Integer code (0…4).
    pub fn code(self) -> i32 {
        self as i32
    }
}

/// What a module does when it is asked for less than its minimum setpoint (or stopped).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BelowMinimum {
    /// 0: keep running at minSetpoint (the paper's model; the module never stops).
    Minimum = 0,
    /// 1: go to Standby (warm).
    Standby = 1,
    /// 2: go through Blowdown to Idle (off).
    Off = 2,
}

impl BelowMinimum {
    /// From the FMU's Integer code; the error names the value.
    pub fn from_code(code: i64) -> Result<Self, ParameterError> {
        match code {
            0 => Ok(Self::Minimum),
            1 => Ok(Self::Standby),
            2 => Ok(Self::Off),
            _ => Err(ParameterError {
                name: "belowMinimum",
                value: code as f64,
                requirement: "must be 0 (stay at minimum), 1 (standby) or 2 (off)".into(),
            }),
        }
    }
}

/// Start-up, standby and shut-down parameters. Defaults are ASSUMPTIONS (the paper gives
/// no measured values); see documentation/index.html for the reasoning behind each.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OperationParameters {
    /// Start from Idle (cold) to current [s]; assumed 300 s.
    pub cold_start_time: f64,
    /// Start from Standby (warm) to current [s]; assumed 30 s.
    pub warm_start_time: f64,
    /// Electric power while starting (Curve) [W]; assumed 300 W.
    pub start_power: f64,
    /// Electric power in Standby and Blowdown [W]; assumed 100 W.
    pub standby_power: f64,
    /// Time in Standby before the module is cold (Idle) [s]; assumed 3600 s.
    pub standby_duration: f64,
    /// Duration of Blowdown (stopping) [s]; assumed 60 s.
    pub stop_duration: f64,
    /// Where a module asked for less than minSetpoint goes.
    pub below_minimum: BelowMinimum,
    /// The supply's losses and the auxiliaries (zero by default: the grid sees P).
    pub grid: GridParameters,
    /// The voltage's drift with use (none by default).
    pub ageing: AgeingParameters,
}

impl Default for OperationParameters {
    fn default() -> Self {
        OperationParameters {
            cold_start_time: 300.0,
            warm_start_time: 30.0,
            start_power: 300.0,
            standby_power: 100.0,
            standby_duration: 3600.0,
            stop_duration: 60.0,
            below_minimum: BelowMinimum::Minimum,
            grid: GridParameters::default(),
            ageing: AgeingParameters::default(),
        }
    }
}

impl OperationParameters {
    /// Every duration and power must be finite and ≥ 0; the error names the value.
    pub fn validate(&self) -> Result<(), ParameterError> {
        for (name, value) in [
            ("coldStartTime", self.cold_start_time),
            ("warmStartTime", self.warm_start_time),
            ("startPower", self.start_power),
            ("standbyPower", self.standby_power),
            ("standbyDuration", self.standby_duration),
            ("stopDuration", self.stop_duration),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ParameterError {
                    name,
                    value,
                    requirement: "must be a finite number >= 0".into(),
                });
            }
        }
        if self.warm_start_time > self.cold_start_time {
            return Err(ParameterError {
                name: "warmStartTime",
                value: self.warm_start_time,
                requirement: format!("must not exceed coldStartTime = {} s", self.cold_start_time),
            });
        }
        self.grid.validate()?;
        self.ageing.validate()
    }
}

/// A command held over a step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// Run (start if needed) at this setpoint [%], clamped to the operating window.
    Run(f64),
    /// Stop: go to Standby or Blowdown/Idle as belowMinimum says.
    Stop,
}

/// The time-varying state of one module.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnitState {
    /// Operating state.
    pub state: OperatingState,
    /// Time left in Curve, Standby or Blowdown [s]; 0 in Idle and Steady.
    pub timer: f64,
    /// Current dynamics; all zero unless Steady.
    pub current: CurrentState,
    /// Stack temperature [K] (the polarisation curve's, Tn, without the thermal model).
    pub temperature: f64,
    /// The voltage's drift [V] (zero without ageing).
    pub drift: Drift,
}

/// What one module did during a step (per module; a group multiplies by its count).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UnitTotals {
    /// Electric energy [J]: stack ∫(V0·I + R·I²)dt plus start/standby power × time.
    pub energy: f64,
    /// Charge through the stack ∫I dt [A·s].
    pub charge: f64,
    /// ∫I² dt [A²·s].
    pub current_squared: f64,
    /// Time spent Steady [s].
    pub running: f64,
    /// Time spent starting (Curve) [s].
    pub starting: f64,
    /// Starts (entries into Curve).
    pub starts: u32,
    /// Of them, warm starts (warmStartTime).
    pub warm_starts: u32,
    /// Why the stack temperature could not be advanced, if it could not (the step is then
    /// refused by the hub).
    pub failure: Option<ThermalError>,
}

const ZERO_CURRENT: CurrentState = CurrentState {
    z1: 0.0,
    z2: 0.0,
    current: 0.0,
};

/// Stack temperature of a module without the thermal model: the polarisation curve's [K].
pub const CURVE_TEMPERATURE: f64 = 328.15;

impl UnitState {
    /// Idle (cold, off).
    pub fn idle() -> Self {
        UnitState {
            state: OperatingState::Idle,
            timer: 0.0,
            current: ZERO_CURRENT,
            temperature: CURVE_TEMPERATURE,
            drift: Drift::default(),
        }
    }

    /// Warm standby for `duration` [s] (then idle), drawing standbyPower.
    pub fn standby(duration: f64) -> Self {
        timed(OperatingState::Standby, duration)
    }

    /// Steady in steady state at `setpoint` [%] (clamped).
    pub fn steady(params: &Parameters, dynamics: &CurrentDynamics, setpoint: f64) -> Self {
        UnitState {
            state: OperatingState::Steady,
            timer: 0.0,
            current: dynamics.steady_state(params.clamp_setpoint(setpoint)),
            temperature: CURVE_TEMPERATURE,
            drift: Drift::default(),
        }
    }

    /// The same state with the stack at `temperature` [K].
    pub fn at_temperature(self, temperature: f64) -> Self {
        UnitState {
            temperature,
            ..self
        }
    }

    /// The same state with the voltage drifted by `drift`.
    pub fn with_drift(self, drift: Drift) -> Self {
        UnitState { drift, ..self }
    }

    /// Moves to `next`, keeping the stack temperature and the drift.
    fn enter(&mut self, next: UnitState) {
        *self = next.at_temperature(self.temperature).with_drift(self.drift);
    }

    /// Stack current [A].
    pub fn stack_current(&self) -> f64 {
        self.current.current
    }

    /// Stack voltage of a Steady module [V]: V0 + R·I, or the temperature's with `thermal`,
    /// plus the drift.
    pub fn voltage(&self, params: &Parameters, thermal: Option<&HeatBalance>) -> f64 {
        let i = self.current.current;
        let curve = match thermal {
            None => params.voltage_intercept + params.ohmic_resistance * i,
            Some(balance) => balance.voltage(self.temperature, i),
        };
        curve + self.drift.total()
    }

    /// Electric power now [W]: V·I when Steady (V as [`Self::voltage`]), else the state's
    /// constant power; in Standby with the thermal model plus the standby heater's.
    pub fn power(
        &self,
        params: &Parameters,
        op: &OperationParameters,
        thermal: Option<&HeatBalance>,
    ) -> f64 {
        match (self.state, thermal) {
            (OperatingState::Steady, _) => self.voltage(params, thermal) * self.current.current,
            (OperatingState::Curve, _) => op.start_power,
            (OperatingState::Standby, Some(b)) if b.thermal.standby_heater_power > 0.0 => {
                op.standby_power + b.in_standby().heating_power(self.temperature, 0.0)
            }
            (OperatingState::Standby | OperatingState::Blowdown, _) => op.standby_power,
            (OperatingState::Idle, _) => 0.0,
        }
    }

    /// Advances by `h` > 0 seconds under `command`, cutting the step at every transition.
    /// `h` and the setpoint must be finite (the caller checks). With `thermal`, the stack
    /// temperature too (a failure is reported in the totals).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn advance(
        &mut self,
        params: &Parameters,
        dynamics: &CurrentDynamics,
        factors: &mut StepFactors,
        op: &OperationParameters,
        thermal: Option<&HeatBalance>,
        command: Command,
        h: f64,
    ) -> UnitTotals {
        use OperatingState::*;
        if command == Stop {
            if let Some(totals) = self.wait_stopped(op, thermal, h) {
                return totals;
            }
        }
        let mut totals = UnitTotals::default();
        let mut left = h;
        // Each pass either uses up the rest of the step or moves along a finite chain of
        // transitions (at most Blowdown → Idle → Curve → Steady), so the loop ends.
        loop {
            match (self.state, command) {
                (Steady, Run(u)) => {
                    let ageing = &op.ageing;
                    self.run(
                        params,
                        dynamics,
                        factors,
                        thermal,
                        ageing,
                        u,
                        left,
                        h,
                        &mut totals,
                    );
                    return totals;
                }
                (Steady, Stop) => match op.below_minimum {
                    BelowMinimum::Minimum => {
                        self.run(
                            params,
                            dynamics,
                            factors,
                            thermal,
                            &op.ageing,
                            params.min_setpoint,
                            left,
                            h,
                            &mut totals,
                        );
                        return totals;
                    }
                    BelowMinimum::Standby => self.enter(timed(Standby, op.standby_duration)),
                    BelowMinimum::Off => self.enter(timed(Blowdown, op.stop_duration)),
                },
                (Idle, Stop) => {
                    self.cool(thermal, &op.ageing, left, &mut totals);
                    return totals;
                }
                (Idle | Standby, Run(_)) => {
                    let warm = match thermal {
                        // With the stack temperature: warm if the stack is warm enough.
                        Some(b) => self.temperature >= b.thermal.warm_start_temperature,
                        None => self.state == Standby,
                    };
                    let duration = if warm {
                        op.warm_start_time
                    } else {
                        op.cold_start_time
                    };
                    self.enter(timed(Curve, duration));
                    self.drift = op.ageing.after_start(self.drift);
                    totals.starts += 1;
                    totals.warm_starts += u32::from(warm);
                }
                (Curve, Stop) => self.enter(UnitState::idle()),
                (Curve, Run(_)) => {
                    let before = left;
                    let done =
                        self.wait(op, op.start_power, thermal, false, &mut left, &mut totals);
                    totals.starting += before - left;
                    if done {
                        return totals;
                    }
                    // Start complete: current appears at K·minSetpoint in steady state.
                    self.enter(UnitState::steady(params, dynamics, params.min_setpoint));
                }
                (Standby, Stop) | (Blowdown, _) => {
                    let heated = self.state == Standby;
                    if self.wait(
                        op,
                        op.standby_power,
                        thermal,
                        heated,
                        &mut left,
                        &mut totals,
                    ) {
                        return totals;
                    }
                    self.enter(UnitState::idle());
                }
            }
        }
    }

    /// [`Self::advance`] under `Stop` where the state holds throughout the `h` seconds (Idle;
    /// Standby or Blowdown with more than `h` left): the same result in a few instructions,
    /// which [`Self::advance`] itself uses. None, changing nothing, otherwise.
    #[inline(always)]
    pub fn wait_stopped(
        &mut self,
        op: &OperationParameters,
        thermal: Option<&HeatBalance>,
        h: f64,
    ) -> Option<UnitTotals> {
        let mut totals = UnitTotals::default();
        match self.state {
            OperatingState::Idle => {
                self.cool(thermal, &op.ageing, h, &mut totals);
                Some(totals)
            }
            OperatingState::Standby | OperatingState::Blowdown if self.timer > h => {
                let mut left = h;
                let heated = self.state == OperatingState::Standby;
                self.wait(
                    op,
                    op.standby_power,
                    thermal,
                    heated,
                    &mut left,
                    &mut totals,
                );
                Some(totals)
            }
            _ => None,
        }
    }

    /// Steady for `length` seconds at setpoint `u` (clamped); reuses the step factors when the
    /// piece is the whole step. With a drift that moves, the current's moments give its energy
    /// exactly ([`AgeingParameters::energy`]).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn run(
        &mut self,
        params: &Parameters,
        dynamics: &CurrentDynamics,
        factors: &mut StepFactors,
        thermal: Option<&HeatBalance>,
        ageing: &AgeingParameters,
        u: f64,
        length: f64,
        h: f64,
        totals: &mut UnitTotals,
    ) {
        if length <= 0.0 {
            return;
        }
        let u = params.clamp_setpoint(u);
        let moving = ageing.is_on() && ageing.moves_while_running(self.drift);
        let change = if moving {
            ageing.change_while_running(self.drift)
        } else {
            DriftChange::NONE
        };
        if let Some(balance) = thermal {
            let path = HeldSetpoint {
                dynamics,
                start: self.current,
                setpoint: u,
                drift: change,
            };
            self.heat(&balance.drifted(self.drift.total()), &path, length, totals);
        }
        let ints = if moving {
            dynamics.advance_with_moments(&mut self.current, u, length, ageing.build_up_rate())
        } else if length == h {
            dynamics.advance(&mut self.current, u, length, factors)
        } else {
            dynamics.advance(&mut self.current, u, length, &mut StepFactors::default())
        };
        totals.energy +=
            params.voltage_intercept * ints.charge + params.ohmic_resistance * ints.current_squared;
        if ageing.is_on() {
            totals.energy += ageing.energy(self.drift, &ints);
            self.drift = ageing.after_running(self.drift, length);
        }
        totals.charge += ints.charge;
        totals.current_squared += ints.current_squared;
        totals.running += length;
    }

    /// Spends time in a timed state at constant `power` [W] (the stack cooling with
    /// `thermal`, `heated` by the standby heater, whose energy is drawn too). Returns true if
    /// the step ends first (the timer keeps the rest), false if the timer ran out (`left`
    /// reduced).
    #[inline]
    fn wait(
        &mut self,
        op: &OperationParameters,
        power: f64,
        thermal: Option<&HeatBalance>,
        heated: bool,
        left: &mut f64,
        totals: &mut UnitTotals,
    ) -> bool {
        let standby;
        let thermal = match thermal {
            Some(b) if heated && b.thermal.standby_heater_power > 0.0 => {
                standby = b.in_standby();
                Some(&standby)
            }
            other => other,
        };
        if self.timer > *left {
            self.cool(thermal, &op.ageing, *left, totals);
            self.timer -= *left;
            totals.energy += power * *left;
            *left = 0.0;
            true
        } else {
            self.cool(thermal, &op.ageing, self.timer, totals);
            totals.energy += power * self.timer;
            *left -= self.timer;
            self.timer = 0.0;
            false
        }
    }

    /// `length` [s] without stack current: the stack cools in closed form (with `thermal`), the
    /// reversible drift recovers.
    #[inline]
    fn cool(
        &mut self,
        thermal: Option<&HeatBalance>,
        ageing: &AgeingParameters,
        length: f64,
        totals: &mut UnitTotals,
    ) {
        if ageing.is_on() {
            self.drift = ageing.after_rest(self.drift, length);
        }
        if let Some(balance) = thermal {
            if length > 0.0 {
                self.heat(balance, &NoCurrent, length, totals);
            }
        }
    }

    /// The stack temperature over `length` [s] along `path`, and the voltage's temperature
    /// terms of the energy, kV·∫(T − Tn)·I dt + kR·∫(T − Tn)·I² dt.
    fn heat(
        &mut self,
        balance: &HeatBalance,
        path: &impl CurrentPath,
        length: f64,
        totals: &mut UnitTotals,
    ) {
        match thermal_step::advance(balance, self.temperature, path, length) {
            Ok(q) => {
                let t = &balance.thermal;
                totals.energy += t.voltage_temperature_coefficient * q.heat_charge
                    + t.resistance_temperature_coefficient * q.heat_squared;
                if q.heating_energy > 0.0 {
                    totals.energy += q.heating_energy;
                }
                self.temperature = q.temperature;
            }
            Err(e) => {
                totals.failure.get_or_insert(e);
            }
        }
    }
}

use Command::{Run, Stop};

fn timed(state: OperatingState, duration: f64) -> UnitState {
    UnitState {
        state,
        timer: duration,
        current: ZERO_CURRENT,
        temperature: CURVE_TEMPERATURE,
        drift: Drift::default(),
    }
}

impl fmt::Display for OperatingState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            OperatingState::Idle => "idle",
            OperatingState::Curve => "curve",
            OperatingState::Steady => "steady",
            OperatingState::Standby => "standby",
            OperatingState::Blowdown => "blowdown",
        };
        f.write_str(name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Rig {
        p: Parameters,
        d: CurrentDynamics,
        f: StepFactors,
        op: OperationParameters,
        s: UnitState,
        totals: UnitTotals,
    }

    impl Rig {
        fn new(below: BelowMinimum, s: impl Fn(&Parameters, &CurrentDynamics) -> UnitState) -> Rig {
            let p = Parameters::default();
            let d = CurrentDynamics::new(&p);
            let op = OperationParameters {
                below_minimum: below,
                ..OperationParameters::default()
            };
            let s = s(&p, &d);
            Rig {
                p,
                d,
                f: StepFactors::default(),
                op,
                s,
                totals: UnitTotals::default(),
            }
        }
        fn run(&mut self, c: Command, duration: f64, h: f64) {
            let n = (duration / h).round() as usize;
            for _ in 0..n {
                let t = self
                    .s
                    .advance(&self.p, &self.d, &mut self.f, &self.op, None, c, h);
                self.totals.energy += t.energy;
                self.totals.charge += t.charge;
                self.totals.running += t.running;
                self.totals.starts += t.starts;
            }
        }
    }

    #[test]
    fn a_cold_start_takes_cold_start_time_and_draws_start_power() {
        let mut r = Rig::new(BelowMinimum::Off, |_, _| UnitState::idle());
        r.run(Run(80.0), 299.0, 1.0);
        assert_eq!(r.s.state, OperatingState::Curve);
        assert_eq!(r.totals.charge, 0.0);
        assert!((r.totals.energy - 300.0 * 299.0).abs() < 1e-9);
        assert_eq!(r.totals.starts, 1);
        r.run(Run(80.0), 1.0, 1.0);
        assert_eq!(r.s.state, OperatingState::Steady);
        // The start ends exactly at 300 s with I = K·minSetpoint (the step ends there too).
        assert!((r.s.stack_current() - 0.534 * 60.0).abs() < 1e-12);
        assert!((r.totals.energy - 300.0 * 300.0).abs() < 1e-9);
        assert_eq!(r.totals.running, 0.0);
    }

    #[test]
    fn current_after_a_start_is_the_ramp_from_the_minimum() {
        // One 310 s step from Idle: 300 s Curve, then 10 s ramping from K·60 at r (the
        // paper's 60 → 80 % response rises faster than r at first).
        let mut r = Rig::new(BelowMinimum::Off, |_, _| UnitState::idle());
        r.run(Run(80.0), 310.0, 310.0);
        let want = 0.534 * 60.0 + r.p.ramp_up_limit * 10.0;
        assert!(
            (r.s.stack_current() - want).abs() < 1e-9,
            "{} vs {want}",
            r.s.stack_current()
        );
        let charge = 0.534 * 60.0 * 10.0 + 0.5 * r.p.ramp_up_limit * 100.0;
        assert!((r.totals.charge - charge).abs() < 1e-9);
        assert!((r.totals.running - 10.0).abs() < 1e-12);
    }

    #[test]
    fn a_warm_start_from_standby_takes_warm_start_time() {
        let mut r = Rig::new(BelowMinimum::Standby, |p, d| UnitState::steady(p, d, 70.0));
        r.run(Stop, 100.0, 1.0);
        assert_eq!(r.s.state, OperatingState::Standby);
        assert!((r.totals.energy - 100.0 * 100.0).abs() < 1e-9);
        r.run(Run(70.0), 29.5, 0.5);
        assert_eq!(r.s.state, OperatingState::Curve);
        r.run(Run(70.0), 0.5, 0.5);
        assert_eq!(r.s.state, OperatingState::Steady);
        assert!((r.totals.energy - (100.0 * 100.0 + 300.0 * 30.0)).abs() < 1e-9);
    }

    #[test]
    fn standby_times_out_to_idle_and_blowdown_lasts_stop_duration() {
        let mut r = Rig::new(BelowMinimum::Standby, |p, d| UnitState::steady(p, d, 70.0));
        r.run(Stop, 4000.0, 7.0 / 3.0 * 3.0);
        assert_eq!(r.s.state, OperatingState::Idle);
        assert!((r.totals.energy - 100.0 * 3600.0).abs() < 1e-6);
        let mut r = Rig::new(BelowMinimum::Off, |p, d| UnitState::steady(p, d, 70.0));
        r.run(Stop, 59.0, 1.0);
        assert_eq!(r.s.state, OperatingState::Blowdown);
        r.run(Stop, 1.0, 1.0);
        assert_eq!(r.s.state, OperatingState::Idle);
        assert!((r.totals.energy - 100.0 * 60.0).abs() < 1e-9);
        // A run request during Blowdown waits for its end, then starts cold.
        let mut r = Rig::new(BelowMinimum::Off, |p, d| UnitState::steady(p, d, 70.0));
        r.run(Stop, 20.0, 1.0);
        r.run(Run(70.0), 340.0, 340.0);
        assert_eq!(r.s.state, OperatingState::Steady);
        assert!((r.totals.energy - (100.0 * 60.0 + 300.0 * 300.0)).abs() < 1e-9);
        assert_eq!(r.totals.starts, 1);
    }

    #[test]
    fn minimum_mode_never_stops() {
        let mut r = Rig::new(BelowMinimum::Minimum, |p, d| UnitState::steady(p, d, 90.0));
        r.run(Stop, 3000.0, 1.0);
        assert_eq!(r.s.state, OperatingState::Steady);
        assert!((r.s.stack_current() - 0.534 * 60.0).abs() < 1e-9);
    }

    #[test]
    fn transitions_do_not_depend_on_the_step_size() {
        let schedule = [
            (Run(90.0), 450.0),
            (Stop, 120.0),
            (Run(75.0), 600.0),
            (Stop, 3900.0),
            (Run(100.0), 900.0),
        ];
        let run = |below, h: f64| {
            let mut r = Rig::new(below, |_, _| UnitState::idle());
            let mut out = Vec::new();
            for &(c, d) in &schedule {
                r.run(c, d, h);
                out.push((r.s.state, r.s.stack_current(), r.totals));
            }
            out
        };
        for below in [BelowMinimum::Standby, BelowMinimum::Off] {
            let reference = run(below, 30.0);
            for h in [0.1, 0.5, 1.0, 7.5, 15.0] {
                for (i, (got, want)) in run(below, h).iter().zip(&reference).enumerate() {
                    assert_eq!(got.0, want.0, "h={h} piece {i}");
                    assert!(
                        (got.1 - want.1).abs() < 1e-9,
                        "h={h} piece {i}: {} vs {}",
                        got.1,
                        want.1
                    );
                    assert!(
                        (got.2.energy - want.2.energy).abs() < 1e-9 * want.2.energy.max(1.0),
                        "h={h} piece {i}: {:?} vs {:?}",
                        got,
                        want
                    );
                    assert!(
                        (got.2.running - want.2.running).abs() < 1e-8,
                        "h={h} piece {i}"
                    );
                    assert_eq!(got.2.starts, want.2.starts);
                }
            }
        }
    }

    #[test]
    fn bad_operation_parameters_are_named() {
        let mut op = OperationParameters {
            stop_duration: -1.0,
            ..Default::default()
        };
        assert_eq!(op.validate().unwrap_err().name, "stopDuration");
        op = OperationParameters {
            warm_start_time: 400.0,
            ..Default::default()
        };
        let e = op.validate().unwrap_err();
        assert!(e.to_string().contains("warmStartTime = 400"), "{e}");
        assert!(BelowMinimum::from_code(3)
            .unwrap_err()
            .to_string()
            .contains("belowMinimum = 3"));
    }
}
