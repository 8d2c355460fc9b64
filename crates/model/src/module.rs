//! One running AEM module: current dynamics, polarisation curve, power and hydrogen.
//!
//! - Voltage (linear polarisation curve, 55 °C / 29 bar): V = V0 + R·I [V]
//! - DC power: P = V·I = V0·I + R·I² [W]
//! - Hydrogen flow (Faraday): F = c·I [Nl/h]
//! - Energy since the start: E = ∫P dt = V0·∫I dt + R·∫I² dt [J]
//! - Hydrogen since the start: N = c·∫I dt / 3600 [Nl]
//!
//! The integrals come from the exact current integrals of [`CurrentDynamics::advance`].
//!
//! With the stack temperature on ([`Module::with_thermal`]) the voltage is
//! V = V0 + kV·(T − Tn) + (R + kR·(T − Tn))·I, so the energy gains
//! kV·∫(T − Tn)·I dt + kR·∫(T − Tn)·I² dt from the temperature's step ([`crate::thermal`]).
//!
//! With ageing ([`Module::with_ageing`]) the voltage drifts, V + d(t), and the energy gains
//! ∫d·I dt from the current's moments ([`crate::ageing`]); the module never stops, so its
//! reversible drift only builds up.

use std::fmt;

use super::ageing::{AgeingParameters, Drift, DriftChange};
use super::current_path::{HeldSetpoint, LinearSetpoint};
use super::dynamics::{CurrentDynamics, CurrentIntegrals, CurrentState, StepFactors};
use super::grid::{CurrentSums, GridParameters};
use super::parameters::{ParameterError, Parameters};
use super::shown;
use super::thermal::step::{self as thermal_step, CurrentPath, ThermalError, ThermalStep};
use super::thermal::{HeatBalance, ThermalParameters};

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
    /// Stack temperature [K] (the polarisation curve's, Tn, without the thermal model).
    pub temperature: f64,
    /// Charge ∫I dt [A·s] and ∫I² dt [A²·s] since the start (for the supply's losses).
    pub charge: f64,
    pub current_squared: f64,
    /// The voltage's drift [V] (zero without ageing).
    pub drift: Drift,
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
    /// The ambient temperature [K] is not a finite number > 0.
    InvalidAmbientTemperature(f64),
    /// The stack temperature's step failed.
    Thermal(ThermalError),
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
            StepError::InvalidAmbientTemperature(t) => write!(f, "ambientTemperature = {} K must be a finite number > 0", shown(*t)),
            StepError::Thermal(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for StepError {}

impl From<ThermalError> for StepError {
    fn from(e: ThermalError) -> Self {
        StepError::Thermal(e)
    }
}

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
    /// The stack's heat balance, if the temperature is modelled.
    thermal: Option<HeatBalance>,
    /// The supply's losses and the auxiliaries.
    grid: GridParameters,
    /// How the voltage drifts with use.
    ageing: AgeingParameters,
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
                temperature: ThermalParameters::default().nominal_temperature,
                charge: 0.0,
                current_squared: 0.0,
                drift: Drift::default(),
            },
            factors: StepFactors::default(),
            h2_per_coulomb: params.h2_coefficient / SECONDS_PER_HOUR,
            thermal: None,
            grid: GridParameters::default(),
            ageing: AgeingParameters::default(),
        })
    }

    /// The same module whose voltage drifts with use as `ageing` says, from its initial drift.
    pub fn with_ageing(self, ageing: AgeingParameters) -> Result<Self, ParameterError> {
        ageing.validate()?;
        let mut module = Module { ageing, ..self };
        module.state.drift = ageing.initial();
        Ok(module)
    }

    /// How the drift moves over a running piece from `drift` (none without ageing).
    fn drift_change(&self, drift: Drift) -> DriftChange {
        if self.ageing.is_on() {
            self.ageing.change_while_running(drift)
        } else {
            DriftChange::NONE
        }
    }

    /// The current over a piece of `h` [s] at setpoint `u` held (`slope` 0) or rising at
    /// `slope` [%/s], with the moments the drift's energy needs where `change` moves.
    fn advance_piece(
        &mut self,
        current: &mut CurrentState,
        u: f64,
        slope: f64,
        h: f64,
        change: &DriftChange,
    ) -> CurrentIntegrals {
        match (slope == 0.0, change.varies()) {
            (true, false) => self.dynamics.advance(current, u, h, &mut self.factors),
            (true, true) => self
                .dynamics
                .advance_with_moments(current, u, h, change.rate),
            (false, false) => self.dynamics.advance_linear(current, u, slope, h),
            (false, true) => {
                self.dynamics
                    .advance_linear_with_moments(current, u, slope, h, change.rate)
            }
        }
    }

    /// The same module with the supply's losses and the auxiliaries `grid` (what
    /// [`Module::ac_power`] and [`Module::ac_energy`] add; the stack is unchanged).
    pub fn with_grid(self, grid: GridParameters) -> Self {
        Module { grid, ..self }
    }

    /// [`Module::new`] with the stack temperature modelled: `thermal` parameters, ambient
    /// temperature `ambient` [K] (held until [`Module::set_ambient_temperature`]).
    pub fn with_thermal(
        params: Parameters,
        thermal: ThermalParameters,
        ambient: f64,
        setpoint: f64,
    ) -> Result<Self, ParameterError> {
        thermal.validate()?;
        check_ambient(ambient).map_err(|_| ParameterError {
            name: "ambientTemperature",
            value: ambient,
            requirement: "must be a finite number > 0 K".into(),
        })?;
        let mut module = Module::new(params, setpoint)?;
        module.state.temperature = thermal.initial_temperature;
        module.thermal = Some(HeatBalance {
            thermal,
            voltage_intercept: params.voltage_intercept,
            ohmic_resistance: params.ohmic_resistance,
            ambient,
            heater: 0.0,
        });
        Ok(module)
    }

    /// Sets the ambient temperature [K] for the following steps (thermal model only; without
    /// it the value is checked and otherwise has no effect).
    pub fn set_ambient_temperature(&mut self, ambient: f64) -> Result<(), StepError> {
        check_ambient(ambient)?;
        if let Some(balance) = &mut self.thermal {
            balance.ambient = ambient;
        }
        Ok(())
    }

    /// The heat balance, if the temperature is modelled.
    pub fn heat_balance(&self) -> Option<&HeatBalance> {
        self.thermal.as_ref()
    }

    /// The temperature's step along `path` of length `h` [s] from the current temperature.
    fn thermal_step(
        &self,
        temperature: f64,
        drift: Drift,
        path: &impl CurrentPath,
        h: f64,
    ) -> Result<Option<ThermalStep>, StepError> {
        match &self.thermal {
            None => Ok(None),
            Some(balance) => {
                let balance = balance.drifted(drift.total());
                Ok(Some(thermal_step::advance(&balance, temperature, path, h)?))
            }
        }
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
        let drift = self.state.drift;
        let change = self.drift_change(drift);
        let heat = self.thermal_step(
            self.state.temperature,
            drift,
            &HeldSetpoint {
                dynamics: &self.dynamics,
                start: current,
                setpoint: u,
                drift: change,
            },
            h,
        )?;
        let ints = self.advance_piece(&mut current, u, 0.0, h, &change);
        let drift_energy = self.drift_energy(drift, &ints);
        self.commit(current, ints, drift_energy, heat.as_ref(), h)?;
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
        let mut drift_energy = 0.0;
        let mut heat: Option<ThermalStep> = None;
        for w in cuts[..=n].windows(2) {
            let (t0, t1) = (w[0], w[1]);
            if t1 <= t0 {
                continue;
            }
            let middle = setpoint + slope * 0.5 * (t0 + t1);
            let temperature = heat.map_or(self.state.temperature, |q| q.temperature);
            let drift = if self.ageing.is_on() {
                self.ageing.after_running(self.state.drift, t0)
            } else {
                self.state.drift
            };
            let change = self.drift_change(drift);
            let ints = if middle > lo && middle < hi {
                let u0 = self.params.clamp_setpoint(setpoint + slope * t0);
                let path = LinearSetpoint {
                    dynamics: &self.dynamics,
                    start: current,
                    setpoint: u0,
                    slope,
                    drift: change,
                };
                let piece = self.thermal_step(temperature, drift, &path, t1 - t0)?;
                heat = summed(heat, piece);
                self.advance_piece(&mut current, u0, slope, t1 - t0, &change)
            } else {
                let u = self.params.clamp_setpoint(middle);
                let path = HeldSetpoint {
                    dynamics: &self.dynamics,
                    start: current,
                    setpoint: u,
                    drift: change,
                };
                let piece = self.thermal_step(temperature, drift, &path, t1 - t0)?;
                heat = summed(heat, piece);
                self.advance_piece(&mut current, u, 0.0, t1 - t0, &change)
            };
            charge += ints.charge;
            current_squared += ints.current_squared;
            ramp_time += ints.ramp_time;
            drift_energy += self.drift_energy(drift, &ints);
        }
        self.commit(
            current,
            CurrentIntegrals {
                charge,
                current_squared,
                ramp_time,
                ..CurrentIntegrals::default()
            },
            drift_energy,
            heat.as_ref(),
            h,
        )?;
        Ok(StepReport {
            applied_setpoint: self.params.clamp_setpoint(setpoint + slope * h),
            ramp_time,
        })
    }

    /// ∫d·I dt [J] over a piece from `drift` with integrals `ints` (0 without ageing).
    fn drift_energy(&self, drift: Drift, ints: &CurrentIntegrals) -> f64 {
        if self.ageing.is_on() {
            self.ageing.energy(drift, ints)
        } else {
            0.0
        }
    }

    /// Adds a step's integrals (and the drift's energy `drift_energy` [J]) to the totals and
    /// takes its end state, unless a total would overflow (then nothing changes).
    fn commit(
        &mut self,
        current: CurrentState,
        ints: CurrentIntegrals,
        drift_energy: f64,
        heat: Option<&ThermalStep>,
        h: f64,
    ) -> Result<(), StepError> {
        let p = &self.params;
        let mut energy = self.state.energy
            + p.voltage_intercept * ints.charge
            + p.ohmic_resistance * ints.current_squared;
        let mut drift = self.state.drift;
        if self.ageing.is_on() {
            energy += drift_energy;
            drift = self.ageing.after_running(drift, h);
        }
        let mut temperature = self.state.temperature;
        if let (Some(q), Some(balance)) = (heat, &self.thermal) {
            let t = &balance.thermal;
            energy += t.voltage_temperature_coefficient * q.heat_charge
                + t.resistance_temperature_coefficient * q.heat_squared;
            temperature = q.temperature;
        }
        let h2_produced = self.state.h2_produced + self.h2_per_coulomb * ints.charge;
        let charge = self.state.charge + ints.charge;
        let current_squared = self.state.current_squared + ints.current_squared;
        let time = self.state.time + h;
        let states_finite =
            current.current.is_finite() && current.z1.is_finite() && current.z2.is_finite();
        let ac_energy = self.grid.ac_energy(
            energy,
            &CurrentSums {
                running: time,
                starting: 0.0,
                current: charge,
                current_squared,
            },
        );
        if !(energy.is_finite()
            && ac_energy.is_finite()
            && h2_produced.is_finite()
            && time.is_finite()
            && states_finite)
        {
            return Err(StepError::Overflow(h));
        }
        self.state = ModuleState {
            time,
            current,
            energy,
            h2_produced,
            temperature,
            charge,
            current_squared,
            drift,
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

    /// Stack voltage V = V0 + R·I [V]; with the thermal model
    /// V = V0 + kV·(T − Tn) + (R + kR·(T − Tn))·I; plus the drift d with ageing.
    pub fn voltage(&self) -> f64 {
        let curve = match &self.thermal {
            None => self.params.voltage_intercept + self.params.ohmic_resistance * self.current(),
            Some(balance) => balance.voltage(self.state.temperature, self.current()),
        };
        curve + self.state.drift.total()
    }

    /// The voltage's drift d [V] (0 without ageing).
    pub fn voltage_drift(&self) -> f64 {
        self.state.drift.total()
    }

    /// Stack temperature T [K] (Tn without the thermal model).
    pub fn temperature(&self) -> f64 {
        self.state.temperature
    }

    /// Heat the cooling removes now, Qc [W] (0 without the thermal model).
    pub fn cooling_power(&self) -> f64 {
        self.thermal.as_ref().map_or(0.0, |balance| {
            balance
                .drifted(self.state.drift.total())
                .cooling_power(self.state.temperature, self.current())
        })
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

    /// Grid power [W]: P + P0 + Vs·I + Rs·I² + P_aux (see [`crate::grid`]).
    pub fn ac_power(&self) -> f64 {
        let i = self.current();
        let sums = CurrentSums {
            running: 1.0,
            starting: 0.0,
            current: i,
            current_squared: i * i,
        };
        self.grid.ac_power(self.power(), &sums)
    }

    /// Grid energy since the start [J]: E + P0·t + Vs·∫I dt + Rs·∫I² dt + P_aux·t, exact.
    pub fn ac_energy(&self) -> f64 {
        let s = &self.state;
        let sums = CurrentSums {
            running: s.time,
            starting: 0.0,
            current: s.charge,
            current_squared: s.current_squared,
        };
        self.grid.ac_energy(s.energy, &sums)
    }
}

/// Refuses an ambient temperature that is not a finite number > 0 K.
fn check_ambient(ambient: f64) -> Result<(), StepError> {
    if ambient.is_finite() && ambient > 0.0 {
        Ok(())
    } else {
        Err(StepError::InvalidAmbientTemperature(ambient))
    }
}

/// Two consecutive pieces of the temperature's step as one.
fn summed(first: Option<ThermalStep>, second: Option<ThermalStep>) -> Option<ThermalStep> {
    match (first, second) {
        (Some(a), Some(b)) => Some(ThermalStep {
            temperature: b.temperature,
            temperature_integral: a.temperature_integral + b.temperature_integral,
            heat_charge: a.heat_charge + b.heat_charge,
            heat_squared: a.heat_squared + b.heat_squared,
            cooling_energy: a.cooling_energy + b.cooling_energy,
            heating_energy: a.heating_energy + b.heating_energy,
            regime_changes: a.regime_changes + b.regime_changes,
        }),
        (a, b) => b.or(a),
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
    fn a_step_whose_grid_energy_would_overflow_is_refused() {
        let grid = GridParameters {
            auxiliary_power: 1e300,
            ..GridParameters::default()
        };
        let mut m = Module::new(Parameters::default(), 70.0)
            .unwrap()
            .with_grid(grid);
        let before = *m.state();
        assert!(matches!(m.step(70.0, 1e300), Err(StepError::Overflow(_))));
        assert_eq!(*m.state(), before);
        m.step(70.0, 1.0).unwrap();
        assert!(m.ac_energy().is_finite());
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
    #[test]
    fn the_thermal_model_without_temperature_coefficients_changes_nothing_else() {
        use crate::thermal::ThermalParameters;
        let flat = ThermalParameters {
            voltage_temperature_coefficient: 0.0,
            resistance_temperature_coefficient: 0.0,
            ..ThermalParameters::default()
        };
        let mut plain = Module::new(Parameters::default(), 70.0).unwrap();
        let mut warm = Module::with_thermal(Parameters::default(), flat, 288.15, 70.0).unwrap();
        for (k, u) in [95.0, 60.0, 80.0, 100.0].iter().enumerate() {
            plain.step(*u, 7.0 + k as f64).unwrap();
            warm.step(*u, 7.0 + k as f64).unwrap();
            plain.step_interpolated(*u, -0.5, 11.0).unwrap();
            warm.step_interpolated(*u, -0.5, 11.0).unwrap();
        }
        let (a, b) = (plain.state(), warm.state());
        assert_eq!(
            (a.current, a.energy, a.h2_produced),
            (b.current, b.energy, b.h2_produced)
        );
        assert_eq!(plain.voltage(), warm.voltage());
        assert!(b.temperature > 288.15, "the stack warms: {}", b.temperature);
        assert_eq!(a.temperature, 328.15, "without the model: Tn");
    }

    #[test]
    fn a_cold_stack_draws_more_and_the_voltage_falls_as_it_warms() {
        use crate::thermal::ThermalParameters;
        let mut m = Module::with_thermal(
            Parameters::default(),
            ThermalParameters::default(),
            288.15,
            100.0,
        )
        .unwrap();
        let cold = m.voltage();
        // V at 15 °C from the curve written out: kV, kR negative, ΔT = −40 K.
        let expected = 35.75 - 0.046 * -40.0 + (0.1529 - 0.0015 * -40.0) * 53.4;
        assert!((cold - expected).abs() < 1e-12, "{cold} vs {expected}");
        let mut last = cold;
        for _ in 0..12 {
            m.step(100.0, 600.0).unwrap();
            assert!(m.voltage() <= last);
            last = m.voltage();
        }
        assert_eq!(
            m.temperature(),
            328.15,
            "held at the setpoint after two hours"
        );
        assert!(m.cooling_power() > 0.0);
        let warm = 35.75 + 0.1529 * 53.4;
        assert!((m.voltage() - warm).abs() < 1e-12);
    }

    #[test]
    fn the_stack_temperature_does_not_depend_on_the_step_size() {
        use crate::thermal::ThermalParameters;
        let thermal = ThermalParameters {
            heat_capacity: 200.0, // a 40 s time constant: it follows the current's transients
            ..ThermalParameters::default()
        };
        let program = |t: f64| {
            if ((t / 300.0) as u64).is_multiple_of(2) {
                100.0
            } else {
                60.0
            }
        };
        let run = |h: f64| {
            let mut m = Module::with_thermal(Parameters::default(), thermal, 268.15, 60.0).unwrap();
            let mut at = vec![];
            let per = (300.0 / h).round() as usize;
            for k in 0..8 {
                for _ in 0..per {
                    m.step(program(k as f64 * 300.0), h).unwrap();
                }
                at.push((m.temperature(), m.energy()));
            }
            at
        };
        let reference = run(300.0);
        for h in [0.01, 1.0, 30.0] {
            for ((t, e), (tr, er)) in run(h).iter().zip(&reference) {
                assert!((t - tr).abs() < 1e-6, "h = {h}: {t} K vs {tr} K");
                assert!((e - er).abs() < 1e-9 * er, "h = {h}: {e} J vs {er} J");
            }
        }
    }

    #[test]
    fn a_bad_ambient_temperature_is_refused_and_changes_nothing() {
        use crate::thermal::ThermalParameters;
        let mut m = Module::with_thermal(
            Parameters::default(),
            ThermalParameters::default(),
            288.15,
            80.0,
        )
        .unwrap();
        m.step(90.0, 10.0).unwrap();
        let before = (*m.state(), m.heat_balance().copied());
        for bad in [f64::NAN, 0.0, -5.0, f64::INFINITY] {
            assert!(matches!(
                m.set_ambient_temperature(bad),
                Err(StepError::InvalidAmbientTemperature(_))
            ));
        }
        assert_eq!((*m.state(), m.heat_balance().copied()), before);
        assert!(Module::with_thermal(
            Parameters::default(),
            ThermalParameters::default(),
            f64::NAN,
            80.0
        )
        .is_err());
    }
}
