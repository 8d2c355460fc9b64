//! One running AEM module: current dynamics, polarisation curve, power and hydrogen.
//!
//! - Voltage (linear polarisation curve, 55 °C / 29 bar): V = V0 + R·I [V]
//! - DC power: P = V·I = V0·I + R·I² [W]
//! - Hydrogen flow (Faraday): F = c·I [Nl/h]
//! - Energy since the start: E = ∫P dt = V0·∫I dt + R·∫I² dt [J]
//! - Hydrogen since the start: N = c·∫I dt / 3600 [Nl]
//!
//! The integrals come from the exact current integrals of [`CurrentDynamics::advance`].

use std::fmt;

use super::dynamics::{CurrentDynamics, CurrentIntegrals, CurrentState, StepFactors};
use super::parameters::{ParameterError, Parameters};
use super::shown;

const SECONDS_PER_HOUR: f64 = 3600.0;

/// Everything that evolves in time; with the parameters it fully determines the module.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModuleState {
    /// Model time [s].
    pub time: f64,
    /// Current dynamics state [A].
    pub current: CurrentState,
    /// DC energy drawn since the start [J].
    pub energy: f64,
    /// Hydrogen produced since the start [Nl].
    pub h2_produced: f64,
}

/// A request the model refuses; the module is left unchanged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepError {
    /// The setpoint [%] is NaN or infinite.
    NonFiniteSetpoint(f64),
    /// The setpoint's rate of change [%/s] is NaN or infinite.
    NonFiniteSlope(f64),
    /// The step size [s] is not a finite positive number.
    InvalidStepSize(f64),
    /// A hub was given a setpoint slope [%/s]: only a single module integrates one.
    SlopeNotSupported(f64),
    /// A step of this size [s] would take the totals past the largest representable number.
    Overflow(f64),
}

impl fmt::Display for StepError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StepError::NonFiniteSetpoint(v) => write!(f, "setpoint = {} % is not a finite number", shown(*v)),
            StepError::NonFiniteSlope(v) => write!(f, "setpoint slope = {} %/s is not a finite number", shown(*v)),
            StepError::InvalidStepSize(h) => write!(f, "step size = {} s must be finite and > 0", shown(*h)),
            StepError::SlopeNotSupported(v) => write!(
                f,
                "setpoint slope = {} %/s: a hub holds its inputs over a step (only a single module integrates a slope)",
                shown(*v)
            ),
            StepError::Overflow(h) => write!(f, "a step of {} s would overflow the energy or hydrogen totals", shown(*h)),
        }
    }
}

impl std::error::Error for StepError {}

/// What one step did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepReport {
    /// Setpoint actually applied after clamping to the operating window [%].
    pub applied_setpoint: f64,
    /// Time within the step during which the rate limit was binding [s].
    pub ramp_time: f64,
}

/// One running electrolyser module.
#[derive(Clone, Debug)]
pub struct Module {
    params: Parameters,
    dynamics: CurrentDynamics,
    state: ModuleState,
    factors: StepFactors,
    /// c / 3600: hydrogen per ampere-second [Nl/(A·s)].
    h2_per_coulomb: f64,
}

impl Module {
    /// A module in steady state at `setpoint` [%] (clamped to the operating window) at t = 0.
    pub fn new(params: Parameters, setpoint: f64) -> Result<Self, ParameterError> {
        params.validate()?;
        if !setpoint.is_finite() {
            return Err(ParameterError {
                name: "setpoint",
                value: setpoint,
                requirement: "must be a finite number".into(),
            });
        }
        let dynamics = CurrentDynamics::new(&params);
        let current = dynamics.steady_state(params.clamp_setpoint(setpoint));
        Ok(Module {
            params,
            dynamics,
            state: ModuleState {
                time: 0.0,
                current,
                energy: 0.0,
                h2_produced: 0.0,
            },
            factors: StepFactors::default(),
            h2_per_coulomb: params.h2_coefficient / SECONDS_PER_HOUR,
        })
    }

    /// Advances by `h` seconds with `setpoint` [%] held over the step (clamped to the window).
    #[inline]
    pub fn step(&mut self, setpoint: f64, h: f64) -> Result<StepReport, StepError> {
        if !setpoint.is_finite() {
            return Err(StepError::NonFiniteSetpoint(setpoint));
        }
        if !(h.is_finite() && h > 0.0) {
            return Err(StepError::InvalidStepSize(h));
        }
        let u = self.params.clamp_setpoint(setpoint);
        let mut current = self.state.current;
        let ints = self.dynamics.advance(&mut current, u, h, &mut self.factors);
        self.commit(current, ints, h)?;
        Ok(StepReport {
            applied_setpoint: u,
            ramp_time: ints.ramp_time,
        })
    }

    /// Advances by `h` seconds with a setpoint that changes linearly from `setpoint` [%] at
    /// `slope` [%/s] over the step (an interpolated input). Where the line leaves the
    /// operating window the step is split at the crossing and the clamped part held constant,
    /// so the result is exact.
    pub fn step_interpolated(
        &mut self,
        setpoint: f64,
        slope: f64,
        h: f64,
    ) -> Result<StepReport, StepError> {
        if slope == 0.0 {
            return self.step(setpoint, h);
        }
        if !setpoint.is_finite() {
            return Err(StepError::NonFiniteSetpoint(setpoint));
        }
        if !slope.is_finite() {
            return Err(StepError::NonFiniteSlope(slope));
        }
        if !(h.is_finite() && h > 0.0) {
            return Err(StepError::InvalidStepSize(h));
        }
        let (lo, hi) = (self.params.min_setpoint, self.params.max_setpoint);
        // Break points: where u(τ) = setpoint + slope·τ crosses the window's edges.
        let mut cuts = [0.0, h, h, h];
        let mut n = 1;
        for edge in [lo, hi] {
            let t = (edge - setpoint) / slope;
            if t > 0.0 && t < h {
                cuts[n] = t;
                n += 1;
            }
        }
        cuts[..n].sort_by(f64::total_cmp);
        cuts[n] = h;
        let mut current = self.state.current;
        let (mut charge, mut current_squared, mut ramp_time) = (0.0, 0.0, 0.0);
        for w in cuts[..=n].windows(2) {
            let (t0, t1) = (w[0], w[1]);
            if t1 <= t0 {
                continue;
            }
            let middle = setpoint + slope * 0.5 * (t0 + t1);
            let ints = if middle > lo && middle < hi {
                let u0 = self.params.clamp_setpoint(setpoint + slope * t0);
                self.dynamics
                    .advance_linear(&mut current, u0, slope, t1 - t0)
            } else {
                self.dynamics.advance(
                    &mut current,
                    self.params.clamp_setpoint(middle),
                    t1 - t0,
                    &mut self.factors,
                )
            };
            charge += ints.charge;
            current_squared += ints.current_squared;
            ramp_time += ints.ramp_time;
        }
        self.commit(
            current,
            CurrentIntegrals {
                charge,
                current_squared,
                ramp_time,
            },
            h,
        )?;
        Ok(StepReport {
            applied_setpoint: self.params.clamp_setpoint(setpoint + slope * h),
            ramp_time,
        })
    }

    /// Adds a step's integrals to the totals and takes its end state, unless a total would
    /// overflow (then nothing changes).
    fn commit(
        &mut self,
        current: CurrentState,
        ints: CurrentIntegrals,
        h: f64,
    ) -> Result<(), StepError> {
        let p = &self.params;
        let energy = self.state.energy
            + p.voltage_intercept * ints.charge
            + p.ohmic_resistance * ints.current_squared;
        let h2_produced = self.state.h2_produced + self.h2_per_coulomb * ints.charge;
        let time = self.state.time + h;
        let states_finite =
            current.current.is_finite() && current.z1.is_finite() && current.z2.is_finite();
        if !(energy.is_finite() && h2_produced.is_finite() && time.is_finite() && states_finite) {
            return Err(StepError::Overflow(h));
        }
        self.state = ModuleState {
            time,
            current,
            energy,
            h2_produced,
        };
        Ok(())
    }

    /// The parameters.
    pub fn parameters(&self) -> &Parameters {
        &self.params
    }

    /// The time-varying state (for saving and restoring).
    pub fn state(&self) -> &ModuleState {
        &self.state
    }

    /// Replaces the time-varying state, e.g. with one saved earlier by [`Module::state`].
    pub fn restore(&mut self, state: ModuleState) {
        self.state = state;
    }

    /// Model time [s].
    pub fn time(&self) -> f64 {
        self.state.time
    }

    /// Stack current I [A].
    pub fn current(&self) -> f64 {
        self.state.current.current
    }

    /// Stack voltage V = V0 + R·I [V].
    pub fn voltage(&self) -> f64 {
        self.params.voltage_intercept + self.params.ohmic_resistance * self.current()
    }

    /// DC power P = V·I [W].
    pub fn power(&self) -> f64 {
        self.voltage() * self.current()
    }

    /// Hydrogen flow c·I [Nl/h].
    pub fn h2_flow(&self) -> f64 {
        self.params.h2_coefficient * self.current()
    }

    /// DC energy since the start [J].
    pub fn energy(&self) -> f64 {
        self.state.energy
    }

    /// Hydrogen produced since the start [Nl].
    pub fn h2_produced(&self) -> f64 {
        self.state.h2_produced
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sanity_figures_at_full_load() {
        let m = Module::new(Parameters::default(), 100.0).unwrap();
        assert!((m.current() - 53.4).abs() < 1e-12);
        assert!((m.voltage() - (35.75 + 0.1529 * 53.4)).abs() < 1e-12);
        assert!((m.voltage() - 43.92).abs() < 0.01);
        assert!((m.power() - 2345.0).abs() < 1.0);
        assert!((m.h2_flow() - 513.6).abs() < 0.1);
    }

    #[test]
    fn steady_energy_and_hydrogen_are_linear_in_time() {
        let mut m = Module::new(Parameters::default(), 80.0).unwrap();
        for _ in 0..3600 {
            m.step(80.0, 1.0).unwrap();
        }
        let i = 0.534 * 80.0;
        let p = (35.75 + 0.1529 * i) * i;
        assert!((m.energy() - p * 3600.0).abs() < 1e-6 * p * 3600.0);
        assert!((m.h2_produced() - 9.6174 * i).abs() < 1e-9 * 9.6174 * i);
    }

    #[test]
    fn setpoint_outside_the_window_is_clamped() {
        let mut m = Module::new(Parameters::default(), 20.0).unwrap();
        assert!((m.current() - 0.534 * 60.0).abs() < 1e-12);
        let r = m.step(150.0, 1.0).unwrap();
        assert_eq!(r.applied_setpoint, 100.0);
    }

    /// Reference for an interpolated input: many short constant steps at the midpoint value
    /// (second-order accurate in the short step).
    fn fine_reference(m: &Module, u0: f64, slope: f64, h: f64, fine: f64) -> Module {
        let mut r = m.clone();
        let n = (h / fine).round() as usize;
        for k in 0..n {
            r.step(u0 + slope * (k as f64 + 0.5) * fine, fine).unwrap();
        }
        r
    }

    #[test]
    fn interpolated_input_matches_a_fine_step_reference() {
        // (start setpoint, slope [%/s], step [s]): rising beyond the rate limit, falling,
        // leaving the window below and above, and crossing the whole window in one step.
        for &(u0, slope, h) in &[
            (70.0, 2.0, 10.0),
            (95.0, -1.5, 20.0),
            (70.0, -1.0, 30.0),
            (90.0, 1.0, 30.0),
            (50.0, 4.0, 20.0),
        ] {
            let mut m = Module::new(Parameters::default(), 75.0).unwrap();
            m.step(65.0, 3.0).unwrap(); // not in steady state
            let reference = fine_reference(&m, u0, slope, h, 1e-4);
            m.step_interpolated(u0, slope, h).unwrap();
            assert!(
                (m.current() - reference.current()).abs() < 1e-6,
                "{u0} {slope}: {} vs {}",
                m.current(),
                reference.current()
            );
            assert!((m.energy() - reference.energy()).abs() < 1e-7 * reference.energy());
        }
    }

    #[test]
    fn interpolated_input_does_not_depend_on_the_step_size() {
        let mut one = Module::new(Parameters::default(), 62.0).unwrap();
        let mut many = one.clone();
        one.step_interpolated(62.0, 1.5, 30.0).unwrap();
        for k in 0..300 {
            many.step_interpolated(62.0 + 1.5 * 0.1 * k as f64, 1.5, 0.1)
                .unwrap();
        }
        assert!(
            (one.current() - many.current()).abs() < 1e-9,
            "{} vs {}",
            one.current(),
            many.current()
        );
        assert!((one.energy() - many.energy()).abs() < 1e-9 * one.energy());
    }

    #[test]
    fn bad_requests_leave_the_module_unchanged() {
        let mut m = Module::new(Parameters::default(), 70.0).unwrap();
        m.step(90.0, 3.0).unwrap();
        let before = *m.state();
        assert!(matches!(
            m.step(f64::NAN, 1.0),
            Err(StepError::NonFiniteSetpoint(_))
        ));
        assert!(m.step(f64::INFINITY, 1.0).is_err());
        assert!(m.step(80.0, -1.0).is_err());
        assert!(m.step(80.0, 0.0).is_err());
        assert!(m.step(80.0, f64::NAN).is_err());
        assert!(matches!(m.step(80.0, 1e307), Err(StepError::Overflow(_))));
        assert_eq!(*m.state(), before);
    }
}
