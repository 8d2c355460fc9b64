//! One step of the stack temperature along a known current trajectory.
//!
//! At constant current C·dT/dt = α·T + β is solved in closed form (a = α/C, d = dT/dt at the
//! start): T(t) = T0 + d·t·φ1(a·t), ∫(T − Tn) dt = (T0 − Tn)·t + d·t²·φ2(a·t), and the
//! setpoint is reached at t = ln(1 + a·(Ts − T0)/d)/a. While the current moves, the balance
//! and its integrals are integrated by Dormand–Prince 5(4) with error control
//! (`ode_solvers`; per integrator step, error ≤ [`ABSOLUTE_TOLERANCE`] +
//! [`RELATIVE_TOLERANCE`]·|y| in every component), and a change of the thermostat's regime
//! is located inside the step: on the integrator's continuous output where the temperature
//! reaches the setpoint, on the exact current where the surplus heat leaves [0, Qmax].
//! Either way the regime changes at the same instants whatever the master's step size.

use ode_solvers::continuous_output_model::ContinuousOutputModel;
use ode_solvers::dop_shared::IntegrationError;
use ode_solvers::{Dopri5, System, Vector5};

pub use super::path::{CurrentPath, ThermalStep, ABSOLUTE_TOLERANCE, RELATIVE_TOLERANCE};
use super::{HeatBalance, Regime};
use crate::roots::first_crossing;

/// Most regime changes in one step before the step is refused (a thermostat that chatters).
pub const MAX_REGIME_CHANGES: u32 = 10_000;
/// Points sampled to find where a regime that started at the setpoint left it.
const DIP_SAMPLES: usize = 32;

/// Why the integrator gave up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IntegratorFailure {
    /// It needed more steps than it allows.
    TooManySteps,
    /// Its step size fell below what the time's precision resolves.
    StepSizeUnderflow,
    /// The balance became stiff.
    Stiff,
}

/// A step the heat balance cannot take.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ThermalError {
    /// The integrator gave up, τ [s] into the step.
    Integrator {
        /// Time into the step [s].
        at: f64,
        /// Why.
        reason: IntegratorFailure,
    },
    /// The regime changed more than [`MAX_REGIME_CHANGES`] times.
    Chattering,
    /// The temperature or its integrals left the finite numbers.
    NonFinite,
}

impl std::fmt::Display for ThermalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ThermalError::Integrator { at, reason } => write!(
                f,
                "the stack temperature's integrator stopped {} s into the step: {}",
                crate::shown(*at),
                match reason {
                    IntegratorFailure::TooManySteps => "it needed too many steps",
                    IntegratorFailure::StepSizeUnderflow => "its step size underflowed",
                    IntegratorFailure::Stiff => "the heat balance became stiff",
                }
            ),
            ThermalError::Chattering => write!(
                f,
                "the thermostat changed regime more than {MAX_REGIME_CHANGES} times in one step"
            ),
            ThermalError::NonFinite => {
                write!(f, "the stack temperature left the finite numbers")
            }
        }
    }
}

impl std::error::Error for ThermalError {}

/// Advances the temperature from `temperature` [K] by `h` [s] along `path`.
pub fn advance(
    balance: &HeatBalance,
    temperature: f64,
    path: &impl CurrentPath,
    h: f64,
) -> Result<ThermalStep, ThermalError> {
    if let Some(held) = held_throughout(balance, temperature, path, h) {
        return Ok(held);
    }
    if path.constant().is_none() {
        let regime = balance.regime(temperature, path.current(0.0));
        if let Some(step) = super::collocation::step(balance, path, regime, temperature, h) {
            return Ok(step);
        }
    }
    integrate(balance, temperature, path, h)
}

/// [`advance`] piece by piece: closed forms at constant current, the error-controlled
/// integrator along a moving one, the regime's changes located.
pub(super) fn integrate(
    balance: &HeatBalance,
    temperature: f64,
    path: &impl CurrentPath,
    h: f64,
) -> Result<ThermalStep, ThermalError> {
    let mut out = ThermalStep {
        temperature,
        ..ThermalStep::default()
    };
    let mut tau = 0.0;
    while tau < h {
        let regime = balance.regime(out.temperature, path.current(tau));
        let reached = match path.constant() {
            Some(current) => constant_piece(balance, current, regime, h - tau, &mut out),
            None => moving_piece(balance, path, regime, tau, h - tau, &mut out)?,
        };
        match reached {
            Some(length) => {
                tau += length;
                out.regime_changes += 1;
                if out.regime_changes > MAX_REGIME_CHANGES {
                    return Err(ThermalError::Chattering);
                }
            }
            None => tau = h,
        }
    }
    let finite = [
        out.temperature,
        out.temperature_integral,
        out.heat_charge,
        out.heat_squared,
        out.cooling_energy,
        out.heating_energy,
    ]
    .iter()
    .all(|x| x.is_finite());
    if finite {
        Ok(out)
    } else {
        Err(ThermalError::NonFinite)
    }
}

/// The whole step in closed form where the thermostat holds the setpoint throughout while the
/// current moves: the current's extremes (and the vertex of the surplus, a quadratic in I, if
/// it lies between them) keep the surplus within [−Qh, Qmax]. T stays Ts; the integrals follow
/// from ∫I dt and ∫I² dt: ∫(T − Tn) = (Ts − Tn)·h, ∫(T − Tn)·I^k = (Ts − Tn)·∫I^k, and
/// ∫Qc = ∫s = (V(Ts, 0) − n·1.481 V)·∫I + R(Ts)·∫I² − (Ts − Ta)/Rth·h. None otherwise.
fn held_throughout(
    balance: &HeatBalance,
    temperature: f64,
    path: &impl CurrentPath,
    h: f64,
) -> Option<ThermalStep> {
    if path.constant().is_some() {
        return None;
    }
    let env = path.envelope(h)?;
    let p = &balance.thermal;
    if temperature != p.cooling_setpoint {
        return None;
    }
    // With a drifting voltage the surplus is held between its values at the drift's extremes
    // (it rises with the voltage, the current being ≥ 0).
    let (drift_lo, drift_hi) = path.drift_bounds(h);
    let (lowest, highest) = (balance.drifted(drift_lo), balance.drifted(drift_hi));
    let deviation = temperature - p.nominal_temperature;
    // s(I) = c2·I² + c1·I − loss.
    let c2 = balance.ohmic_resistance + p.resistance_temperature_coefficient * deviation;
    let c1 = balance.voltage_intercept + p.voltage_temperature_coefficient * deviation
        - p.thermoneutral_voltage();
    let loss = (temperature - balance.ambient) / p.thermal_resistance;
    let within =
        |i: f64| lowest.surplus(i) >= -balance.heater && highest.surplus(i) <= p.max_cooling_power;
    let vertex = |c1: f64| {
        if c2 != 0.0 {
            -c1 / (2.0 * c2)
        } else {
            f64::NAN
        }
    };
    let inside = |v: f64| v > env.min && v < env.max;
    let (v_lo, v_hi) = (vertex(c1 + drift_lo), vertex(c1 + drift_hi));
    if !(within(env.min)
        && within(env.max)
        && (!inside(v_lo) || within(v_lo))
        && (!inside(v_hi) || within(v_hi)))
    {
        return None;
    }
    let surplus_integral =
        c1 * env.charge + c2 * env.current_squared + path.drift_charge(h) - loss * h;
    // Heat is only ever supplied by a heater (in standby); without one a negative integral is
    // rounding of a surplus that stays ≥ 0.
    let (cooling_energy, heating_energy) = if surplus_integral < 0.0 && balance.heater > 0.0 {
        (0.0, -surplus_integral)
    } else {
        (surplus_integral, 0.0)
    };
    Some(ThermalStep {
        temperature,
        temperature_integral: deviation * h,
        heat_charge: deviation * env.charge,
        heat_squared: deviation * env.current_squared,
        cooling_energy,
        heating_energy,
        regime_changes: 0,
    })
}

/// φ1(x) = (eˣ − 1)/x, φ1(0) = 1.
fn phi1(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        x.exp_m1() / x
    }
}

/// φ2(x) = (eˣ − 1 − x)/x², φ2(0) = 1/2 (series near 0, where the difference cancels).
fn phi2(x: f64) -> f64 {
    if x.abs() < 1e-3 {
        0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x / 120.0))
    } else {
        (x.exp_m1() - x) / (x * x)
    }
}

/// At most `length` [s] at constant `current` [A] in `regime`, in closed form; returns the
/// time at which the temperature reaches the setpoint (where the piece ends) if it does.
fn constant_piece(
    balance: &HeatBalance,
    current: f64,
    regime: Regime,
    length: f64,
    out: &mut ThermalStep,
) -> Option<f64> {
    let p = &balance.thermal;
    let t0 = out.temperature;
    let (end, integral, cooling, reached) = if regime == Regime::Held {
        let held = t0 - p.nominal_temperature;
        (t0, held * length, balance.surplus(current), None)
    } else {
        let (alpha, beta) = balance.linear(current, regime);
        let a = alpha / p.heat_capacity;
        let d = (alpha * t0 + beta) / p.heat_capacity;
        let gap = p.cooling_setpoint - t0;
        // Moving toward the setpoint from its side, reached if the exponential gets there.
        let toward = (regime == Regime::Below && d > 0.0 && gap > 0.0)
            || (regime == Regime::Above && d < 0.0 && gap < 0.0);
        let reach = if toward {
            let x = a * gap / d;
            let t = if x == 0.0 {
                gap / d
            } else if x > -1.0 {
                gap / d * (x.ln_1p() / x)
            } else {
                f64::INFINITY
            };
            Some(t).filter(|t| *t < length)
        } else {
            None
        };
        let span = reach.unwrap_or(length);
        let end = match reach {
            Some(_) => p.cooling_setpoint,
            None => t0 + d * span * phi1(a * span),
        };
        let integral = (t0 - p.nominal_temperature) * span + d * span * span * phi2(a * span);
        let cooling = balance.thermostat_power(current, regime);
        (end, integral, cooling, reach)
    };
    let span = reached.unwrap_or(length);
    out.temperature = end;
    out.temperature_integral += integral;
    out.heat_charge += current * integral;
    out.heat_squared += current * current * integral;
    if cooling < 0.0 && balance.heater > 0.0 {
        out.heating_energy -= cooling * span;
    } else {
        out.cooling_energy += cooling * span;
    }
    reached
}

/// The heat balance with its integrals, y = [T, ∫(T − Tn), ∫(T − Tn)·I, ∫(T − Tn)·I², ∫Qc],
/// in one regime, from `start` [s] into the step (the integrator's time counts from 0).
struct Balance<'a, P> {
    balance: &'a HeatBalance,
    path: &'a P,
    start: f64,
    regime: Regime,
}

impl<P: CurrentPath> Balance<'_, P> {
    /// Whether the regime has ended at time `x` with temperature T [K].
    fn ended(&self, x: f64, temperature: f64) -> bool {
        let setpoint = self.balance.thermal.cooling_setpoint;
        match self.regime {
            Regime::Below => temperature >= setpoint,
            Regime::Above => temperature <= setpoint,
            Regime::Held => {
                let tau = self.start + x;
                let s = self
                    .balance
                    .drifted(self.path.drift(tau))
                    .surplus(self.path.current(tau));
                s < -self.balance.heater || s > self.balance.thermal.max_cooling_power
            }
        }
    }

    /// Whether the temperature is strictly on the regime's side of the setpoint.
    fn inside(&self, temperature: f64) -> bool {
        let setpoint = self.balance.thermal.cooling_setpoint;
        match self.regime {
            Regime::Below => temperature < setpoint,
            Regime::Above => temperature > setpoint,
            Regime::Held => true,
        }
    }
}

impl<P: CurrentPath> System<f64, Vector5<f64>> for Balance<'_, P> {
    fn system(&self, x: f64, y: &Vector5<f64>, dy: &mut Vector5<f64>) {
        let tau = self.start + x;
        let b = &self.balance.drifted(self.path.drift(tau));
        let current = self.path.current(tau);
        let temperature = y[0];
        // Along a moving current the module runs: no heater (Qc ≥ 0 here).
        let cooling = b.thermostat_power(current, self.regime);
        let deviation = temperature - b.thermal.nominal_temperature;
        dy[0] = b.rate(temperature, current, self.regime);
        dy[1] = deviation;
        dy[2] = deviation * current;
        dy[3] = deviation * current * current;
        dy[4] = cooling;
    }

    /// Stops the integrator at the first accepted step where the regime has ended.
    fn solout(&mut self, x: f64, y: &Vector5<f64>, _dy: &Vector5<f64>) -> bool {
        self.ended(x, y[0])
    }
}

/// At most `length` [s] from `start` [s] into the step along a moving current, in `regime`,
/// integrated; returns the time at which the regime ends (where the piece ends) if it does.
fn moving_piece(
    balance: &HeatBalance,
    path: &impl CurrentPath,
    regime: Regime,
    start: f64,
    length: f64,
    out: &mut ThermalStep,
) -> Result<Option<f64>, ThermalError> {
    let t0 = out.temperature;
    let system = Balance {
        balance,
        path,
        start,
        regime,
    };
    let inside_at_start = system.inside(t0);
    let y0 = Vector5::new(t0, 0.0, 0.0, 0.0, 0.0);
    let mut stepper = Dopri5::new(
        system,
        0.0,
        length,
        0.0,
        y0,
        RELATIVE_TOLERANCE,
        ABSOLUTE_TOLERANCE,
    );
    let mut dense = ContinuousOutputModel::new();
    stepper
        .integrate_with_continuous_output_model(&mut dense)
        .map_err(|e| ThermalError::Integrator {
            at: start,
            reason: match e {
                IntegrationError::MaxNumStepReached { .. } => IntegratorFailure::TooManySteps,
                IntegrationError::StepSizeUnderflow { .. } => IntegratorFailure::StepSizeUnderflow,
                IntegrationError::StiffnessDetected { .. } => IntegratorFailure::Stiff,
            },
        })?;
    let xs = stepper.x_out();
    let ys = stepper.y_out();
    let (Some(&x_end), Some(y_end)) = (xs.last(), ys.last()) else {
        return Err(ThermalError::Integrator {
            at: start,
            reason: IntegratorFailure::StepSizeUnderflow,
        });
    };
    let probe = Balance {
        balance,
        path,
        start,
        regime,
    };
    if !probe.ended(x_end, y_end[0]) {
        add(out, y_end);
        return Ok(None);
    }
    // The regime ended within the last integrator step [x_a, x_end].
    let x_a = if xs.len() >= 2 { xs[xs.len() - 2] } else { 0.0 };
    let temperature_at = |x: f64| dense.evaluate(x).map_or(f64::NAN, |y| y[0]);
    let ended = |x: f64| match regime {
        Regime::Held => probe.ended(x, t0),
        _ => probe.ended(x, temperature_at(x)),
    };
    let lo = if regime == Regime::Held || inside_at_start || xs.len() >= 2 {
        x_a
    } else {
        // Started at the setpoint: first find where the temperature was on the regime's
        // side (the dip), then the crossing after it.
        let inside = (1..DIP_SAMPLES)
            .map(|k| x_a + (x_end - x_a) * k as f64 / DIP_SAMPLES as f64)
            .find(|&x| probe.inside(temperature_at(x)));
        match inside {
            Some(x) => x,
            None => {
                // Never strictly inside: the regime lasted no longer than the first sample.
                let x = x_a + (x_end - x_a) / DIP_SAMPLES as f64;
                finish_at(out, &dense, x, balance.thermal.cooling_setpoint);
                return Ok(Some(x));
            }
        }
    };
    let x = first_crossing(ended, lo, x_end);
    let at_setpoint = if regime == Regime::Held {
        t0
    } else {
        balance.thermal.cooling_setpoint
    };
    finish_at(out, &dense, x, at_setpoint);
    Ok(Some(x))
}

/// Takes the integrals at `x` from the continuous output and the temperature `temperature`.
fn finish_at(
    out: &mut ThermalStep,
    dense: &ContinuousOutputModel<f64, Vector5<f64>>,
    x: f64,
    temperature: f64,
) {
    let mut y = dense
        .evaluate(x)
        .unwrap_or_else(|| Vector5::repeat(f64::NAN));
    y[0] = temperature;
    add(out, &y);
}

/// Adds a piece's integrals and takes its end temperature.
fn add(out: &mut ThermalStep, y: &Vector5<f64>) {
    out.temperature = y[0];
    out.temperature_integral += y[1];
    out.heat_charge += y[2];
    out.heat_squared += y[3];
    out.cooling_energy += y[4];
}
