//! What a step of the stack temperature integrates along, what it gives, and the tolerance
//! it keeps: shared by the step ([`super::step`]) and its collocation ([`super::collocation`]).

use crate::dynamics::Envelope;

/// Relative tolerance of the integrator, per integrator step [1].
pub const RELATIVE_TOLERANCE: f64 = 1e-11;
/// Absolute tolerance of the integrator, per integrator step (K for the temperature).
pub const ABSOLUTE_TOLERANCE: f64 = 1e-9;
/// The stack current over one step.
pub trait CurrentPath {
    /// I(τ) [A] at τ seconds into the step.
    fn current(&self, tau: f64) -> f64;
    /// The current, if it is the same over the whole step [A].
    fn constant(&self) -> Option<f64>;
    /// Over a step of `h` [s], its extremes and integrals where they are known in closed form.
    fn envelope(&self, _h: f64) -> Option<Envelope> {
        None
    }
    /// How much the voltage has drifted since the start of the step, Δd(τ) [V] (ageing).
    fn drift(&self, _tau: f64) -> f64 {
        0.0
    }
    /// The smallest and largest Δd over a step of `h` [s] [V].
    fn drift_bounds(&self, _h: f64) -> (f64, f64) {
        (0.0, 0.0)
    }
    /// ∫Δd·I dτ over a step of `h` [s] [J], in closed form.
    fn drift_charge(&self, _h: f64) -> f64 {
        0.0
    }
}

/// What one step of the temperature gives.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ThermalStep {
    /// T at the end of the step [K].
    pub temperature: f64,
    /// ∫(T − Tn) dt [K·s].
    pub temperature_integral: f64,
    /// ∫(T − Tn)·I dt [K·A·s] (the voltage's kV term of the energy).
    pub heat_charge: f64,
    /// ∫(T − Tn)·I² dt [K·A²·s] (the voltage's kR term of the energy).
    pub heat_squared: f64,
    /// ∫max(Qc, 0) dt: heat the cooling removed [J].
    pub cooling_energy: f64,
    /// ∫max(−Qc, 0) dt: heat the standby heater supplied [J].
    pub heating_energy: f64,
    /// Changes of the thermostat's regime within the step.
    pub regime_changes: u32,
}
