//! The stack current over one step as a function of time, for what is integrated along it
//! (the stack temperature): the exact current of [`CurrentDynamics`] from the step's start.

use super::ageing::DriftChange;
use super::dynamics::{CurrentDynamics, CurrentState, Envelope, StepFactors};
use super::thermal::step::CurrentPath;

/// Relative distance from the steady state [1] below which the current counts as constant.
const STEADY: f64 = 1e-12;

/// The current from `start` with the setpoint `setpoint` [%] held.
pub struct HeldSetpoint<'a> {
    /// The dynamics.
    pub dynamics: &'a CurrentDynamics,
    /// The state at the start of the step.
    pub start: CurrentState,
    /// The setpoint held over the step [%].
    pub setpoint: f64,
    /// How the voltage drifts over the step ([`DriftChange::NONE`] without ageing).
    pub drift: DriftChange,
}

impl CurrentPath for HeldSetpoint<'_> {
    fn current(&self, tau: f64) -> f64 {
        if tau <= 0.0 {
            return self.start.current;
        }
        if let Some(i) = self
            .dynamics
            .tracked_current(&self.start, self.setpoint, tau)
        {
            return i;
        }
        let mut state = self.start;
        self.dynamics
            .advance(&mut state, self.setpoint, tau, &mut StepFactors::default());
        state.current
    }

    /// At the steady state (within 1e-12 of it) the current stays where it is (and the step is
    /// not constant where the drift moves).
    fn constant(&self) -> Option<f64> {
        if self.drift.varies() {
            return None;
        }
        let steady = self.dynamics.steady_state(self.setpoint);
        let tolerance = STEADY * steady.current.abs().max(1.0);
        let near = |a: f64, b: f64| (a - b).abs() <= tolerance;
        (near(self.start.z1, steady.z1)
            && near(self.start.z2, steady.z2)
            && near(self.start.current, steady.current))
        .then_some(self.start.current)
    }

    /// Where the step tracks (the rate limit does not bind), in closed form.
    fn envelope(&self, h: f64) -> Option<Envelope> {
        self.dynamics
            .tracking_envelope(&self.start, self.setpoint, h)
    }

    fn drift(&self, tau: f64) -> f64 {
        self.drift.at(tau)
    }

    fn drift_bounds(&self, h: f64) -> (f64, f64) {
        self.drift.bounds(h)
    }

    fn drift_charge(&self, h: f64) -> f64 {
        if !self.drift.varies() {
            return 0.0;
        }
        let mut state = self.start;
        let ints =
            self.dynamics
                .advance_with_moments(&mut state, self.setpoint, h, self.drift.rate);
        self.drift.charge(&ints)
    }
}

/// The current from `start` with the setpoint rising linearly from `setpoint` [%] at `slope`
/// [%/s] (inside the operating window).
pub struct LinearSetpoint<'a> {
    /// The dynamics.
    pub dynamics: &'a CurrentDynamics,
    /// The state at the start of the step.
    pub start: CurrentState,
    /// The setpoint at the start [%].
    pub setpoint: f64,
    /// Its rate of change [%/s].
    pub slope: f64,
    /// How the voltage drifts over the step ([`DriftChange::NONE`] without ageing).
    pub drift: DriftChange,
}

impl CurrentPath for LinearSetpoint<'_> {
    fn current(&self, tau: f64) -> f64 {
        if tau <= 0.0 {
            return self.start.current;
        }
        let mut state = self.start;
        self.dynamics
            .advance_linear(&mut state, self.setpoint, self.slope, tau);
        state.current
    }

    fn constant(&self) -> Option<f64> {
        None
    }

    fn drift(&self, tau: f64) -> f64 {
        self.drift.at(tau)
    }

    fn drift_bounds(&self, h: f64) -> (f64, f64) {
        self.drift.bounds(h)
    }
}

/// No current at all (a stopped module).
pub struct NoCurrent;

impl CurrentPath for NoCurrent {
    fn current(&self, _tau: f64) -> f64 {
        0.0
    }

    fn constant(&self) -> Option<f64> {
        Some(0.0)
    }
}
