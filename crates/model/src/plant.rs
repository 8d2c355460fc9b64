//! What one FMU instance simulates: a single module, or a hub of modules.
//!
//! [`PlantSettings`] holds the hub's settings as a user sets them (counts and codes as plain
//! integers, checked only by [`PlantSettings::config`]). [`Plant`] is either
//! - a [`Module`]: one module that never stops, driven by its setpoint (nModules = 1,
//!   belowMinimum = 0, powerInput = false, parameterSpread = 0): the paper's model, which
//!   also integrates a linearly interpolated setpoint exactly; or
//! - a [`Hub`]: everything else (operating states, dispatch, power reference, a spread of
//!   parameters, or per-module parameter sets such as those `aem-identify` writes: module k
//!   of N has set k mod M of M sets).
//!
//! A plant that offers frequency reserves ([`ReserveSettings`]) is always a hub (of one module
//! or more), which holds its inputs over a step; [`Plant::step_with_reserves`] adds the request
//! to its demand.
//!
//! Module outputs of a hub are per-module means: I = ΣI/N [A], P = P_hub/N [W],
//! F = F_hub/N [Nl/h], E = E_hub/N [J], H = H_hub/N [Nl]; V is the mean of V0 + R·I over
//! the modules carrying current [V] (0 when none does).

use super::ageing::AgeingParameters;
use super::dispatch::{Demand, DispatchPolicy, PowerCurve};
use super::grid::{CurrentSums, GridParameters};
use super::hub::{Hub, HubConfig, HubReadings, HubSnapshot, H2_KG_PER_NL};
use super::module::{Module, ModuleState, StepError};
use super::operation::{BelowMinimum, OperatingState, OperationParameters};
use super::parameters::{ParameterError, Parameters};
use super::reserve::{FrequencyResponse, ReserveSettings};
use super::snapshot_error::SnapshotError;
use super::spread::spread_parameters;
use super::thermal::{ThermalParameters, AMBIENT_START};

const SECONDS_PER_HOUR: f64 = 3600.0;

/// Most modules with individual parameter sets (parameterSpread > 0): each set costs memory.
pub const MAX_INDIVIDUAL_MODULES: i32 = 1_000_000;

/// Hub settings as set through the FMU, before validation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantSettings {
    /// nModules [1].
    pub n_modules: i32,
    /// dispatch: 1 equal, 2 sequential, 3 rotation, 4 target.
    pub dispatch: i32,
    /// dispatchTargetSetpoint [%]: the load of a running module under target dispatch.
    pub dispatch_target: f64,
    /// belowMinimum: 0 stay at minimum, 1 standby, 2 off.
    pub below_minimum: i32,
    /// powerInput: the power reference drives the hub.
    pub power_input: bool,
    /// hysteresis [%].
    pub hysteresis: f64,
    /// coldStartTime [s].
    pub cold_start_time: f64,
    /// warmStartTime [s].
    pub warm_start_time: f64,
    /// startPower [W].
    pub start_power: f64,
    /// standbyPower [W].
    pub standby_power: f64,
    /// standbyDuration [s].
    pub standby_duration: f64,
    /// stopDuration [s].
    pub stop_duration: f64,
    /// parameterSpread [1]: relative half-width of the uniform per-module spread.
    pub parameter_spread: f64,
    /// spreadSeed [1].
    pub spread_seed: i32,
    /// initialStandby [1]: modules held in warm standby at the start, of those not running.
    pub initial_standby: i32,
    /// The frequency reserves offered and the compensation.
    pub reserve: ReserveSettings,
    /// thermalModel: the stack temperature is modelled.
    pub thermal_model: bool,
    /// The stack's thermal parameters (used with `thermal_model`).
    pub thermal: ThermalParameters,
    /// The supply's losses, the auxiliaries, and the side a power reference means.
    pub grid: GridParameters,
    /// How the voltage drifts with use (none by default).
    pub ageing: AgeingParameters,
}

impl Default for PlantSettings {
    /// One module that never stops (the paper's model), with the assumed start-up and standby
    /// parameters of [`OperationParameters::default`]; the FMU's start values are the same.
    fn default() -> Self {
        let operation = OperationParameters::default();
        PlantSettings {
            n_modules: 1,
            dispatch: DispatchPolicy::Equal as i32,
            below_minimum: BelowMinimum::Minimum as i32,
            power_input: false,
            dispatch_target: 80.0,
            hysteresis: 5.0,
            cold_start_time: operation.cold_start_time,
            warm_start_time: operation.warm_start_time,
            start_power: operation.start_power,
            standby_power: operation.standby_power,
            standby_duration: operation.standby_duration,
            stop_duration: operation.stop_duration,
            parameter_spread: 0.0,
            spread_seed: 1,
            initial_standby: 0,
            reserve: ReserveSettings::default(),
            thermal_model: false,
            thermal: ThermalParameters::default(),
            grid: GridParameters::default(),
            ageing: AgeingParameters::default(),
        }
    }
}

/// Validated settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantConfig {
    /// The hub's configuration.
    pub hub: HubConfig,
    /// The power reference drives the hub.
    pub power_input: bool,
    /// Relative spread of per-module parameters (0: identical modules).
    pub parameter_spread: f64,
    /// Seed of the spread.
    pub spread_seed: u64,
    /// The frequency reserves offered (validated).
    pub reserve: ReserveSettings,
    /// The stack's thermal parameters if its temperature is modelled (validated).
    pub thermal: Option<ThermalParameters>,
}

impl PlantSettings {
    /// The validated configuration; the error names the first bad value.
    pub fn config(&self) -> Result<PlantConfig, ParameterError> {
        if self.n_modules < 1 {
            return Err(ParameterError {
                name: "nModules",
                value: self.n_modules as f64,
                requirement: "must be >= 1".into(),
            });
        }
        let spread = self.parameter_spread;
        if !(spread.is_finite() && (0.0..=0.5).contains(&spread)) {
            return Err(ParameterError {
                name: "parameterSpread",
                value: spread,
                requirement: "must be within [0, 0.5]".into(),
            });
        }
        if spread > 0.0 && self.n_modules > MAX_INDIVIDUAL_MODULES {
            return Err(ParameterError {
                name: "nModules",
                value: self.n_modules as f64,
                requirement: format!("must be <= {MAX_INDIVIDUAL_MODULES} when parameterSpread > 0 (one parameter set per module)"),
            });
        }
        if self.initial_standby < 0 {
            return Err(ParameterError {
                name: "initialStandby",
                value: self.initial_standby as f64,
                requirement: "must be >= 0".into(),
            });
        }
        let hub = HubConfig {
            n_modules: self.n_modules as u32,
            policy: DispatchPolicy::from_code(self.dispatch as i64)?,
            dispatch_target: self.dispatch_target,
            hysteresis: self.hysteresis,
            operation: OperationParameters {
                cold_start_time: self.cold_start_time,
                warm_start_time: self.warm_start_time,
                start_power: self.start_power,
                standby_power: self.standby_power,
                standby_duration: self.standby_duration,
                stop_duration: self.stop_duration,
                below_minimum: BelowMinimum::from_code(self.below_minimum as i64)?,
                grid: self.grid,
                ageing: self.ageing,
            },
            compensation: self.reserve.compensation,
            filter_zero: self.reserve.filter_zero,
            thermal: None,
            initial_standby: self.initial_standby as u32,
        };
        super::hub::validate(&hub)?;
        self.reserve.validate()?;
        let config = PlantConfig {
            hub,
            power_input: self.power_input,
            parameter_spread: spread,
            spread_seed: self.spread_seed as u32 as u64,
            reserve: self.reserve,
            thermal: None,
        };
        if !self.thermal_model {
            return Ok(config);
        }
        self.thermal.validate()?;
        Ok(PlantConfig {
            thermal: Some(self.thermal),
            hub: HubConfig {
                thermal: Some(self.thermal),
                ..config.hub
            },
            ..config
        })
    }
}

impl PlantConfig {
    /// One module that never stops, driven by its setpoint: the paper's model, simulated by
    /// [`Module`] (which also takes an interpolated setpoint).
    pub fn is_single_module(&self) -> bool {
        self.hub.n_modules == 1
            && self.hub.operation.below_minimum == BelowMinimum::Minimum
            && !self.power_input
            && self.parameter_spread == 0.0
            && !self.reserve.offered()
    }

    /// The hub's demand for these inputs.
    pub fn demand(&self, setpoint: f64, power_reference: f64) -> Demand {
        if self.power_input {
            Demand::Power(power_reference)
        } else {
            Demand::Setpoint(setpoint)
        }
    }
}

/// What a step asked of the reserves and what the operating window let the plant give.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReserveStep {
    /// The request at the end of the step [W] (negative: draw less).
    pub request: f64,
    /// The power the plant is asked to draw without reserves [W].
    pub baseline: f64,
    /// The steady power the operating window allows (least, most) [W].
    pub range: (f64, f64),
    /// The part of the request (largest over the step) that the window keeps the plant from
    /// delivering [W], with the request's sign; 0 if it can deliver all of it.
    pub shortfall: f64,
}

/// The time-varying state of a plant, for saving and restoring.
#[derive(Clone, Debug, PartialEq)]
pub enum PlantSnapshot {
    /// A single module's state.
    Module(ModuleState),
    /// A hub's state.
    Hub(HubSnapshot),
}

/// A single module or a hub, with the hub's outputs cached after every change.
// The single module, the per-step hot path of most users, stays inline; the hub is boxed.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Plant {
    /// One module that never stops.
    Module(Module),
    /// A hub, and its outputs now.
    Hub(Box<Hub>, HubReadings),
}

impl Plant {
    /// A plant in steady state for the inputs at t = 0 (running modules in steady state at
    /// their dispatched setpoint, the others off). `module_sets`: per-module parameter sets
    /// (module k has set k mod M), instead of `params` for every module.
    pub fn new(
        params: Parameters,
        config: &PlantConfig,
        module_sets: Option<&[Parameters]>,
        setpoint: f64,
        power_reference: f64,
    ) -> Result<Self, ParameterError> {
        if let (Some(thermal), true, None) =
            (config.thermal, config.is_single_module(), module_sets)
        {
            let op = &config.hub.operation;
            return Ok(Plant::Module(
                Module::with_thermal(params, thermal, AMBIENT_START, setpoint)?
                    .with_grid(op.grid)
                    .with_ageing(op.ageing)?,
            ));
        }
        if config.is_single_module() && module_sets.is_none() {
            let op = &config.hub.operation;
            return Ok(Plant::Module(
                Module::new(params, setpoint)?
                    .with_grid(op.grid)
                    .with_ageing(op.ageing)?,
            ));
        }
        let demand = config.demand(setpoint, power_reference);
        let hub = if let Some(sets) = module_sets {
            if config.parameter_spread > 0.0 {
                return Err(ParameterError {
                    name: "parameterSpread",
                    value: config.parameter_spread,
                    requirement: "must be 0 with a moduleParameterFile (choose one source of per-module parameters)".into(),
                });
            }
            Hub::with_parameter_counts(
                round_robin(sets, config.hub.n_modules)?,
                config.hub,
                demand,
            )?
        } else if config.parameter_spread > 0.0 {
            params.validate()?;
            let n = config.hub.n_modules as usize;
            Hub::with_parameter_sets(
                spread_parameters(&params, n, config.parameter_spread, config.spread_seed),
                config.hub,
                demand,
            )?
        } else {
            Hub::new(params, config.hub, demand)?
        };
        let readings = hub.readings();
        Ok(Plant::Hub(Box::new(hub), readings))
    }

    /// [`Plant::new`] in steady state for the inputs with the reserves' `request` [W] added
    /// (see [`Plant::step_with_reserves`]).
    pub fn with_request(
        params: Parameters,
        config: &PlantConfig,
        module_sets: Option<&[Parameters]>,
        setpoint: f64,
        power_reference: f64,
        request: f64,
    ) -> Result<Self, ParameterError> {
        if request == 0.0 || config.power_input {
            return Plant::new(
                params,
                config,
                module_sets,
                setpoint,
                power_reference + request,
            );
        }
        // The setpoint's power needs the hub's first parameter set (spread or from a file).
        let plant = Plant::new(params, config, module_sets, setpoint, power_reference)?;
        match plant.requested_demand(config, setpoint, power_reference, request) {
            Demand::Power(p) => Plant::new(params, config, module_sets, setpoint, p),
            Demand::Setpoint(u) => Plant::new(params, config, module_sets, u, power_reference),
        }
    }

    /// Whether the plant integrates a setpoint slope (only a single module does).
    pub fn takes_setpoint_slope(&self) -> bool {
        matches!(self, Plant::Module(_))
    }

    /// Advances by `h` seconds: the setpoint is `setpoint + slope·t` over the step [%] (a
    /// hub takes slope 0 only), the power reference is held [W]. Refused requests leave the
    /// plant unchanged.
    pub fn step(
        &mut self,
        config: &PlantConfig,
        setpoint: f64,
        slope: f64,
        power_reference: f64,
        h: f64,
    ) -> Result<(), StepError> {
        match self {
            Plant::Module(m) => m.step_interpolated(setpoint, slope, h).map(|_| ()),
            Plant::Hub(hub, readings) => {
                if slope != 0.0 {
                    return Err(StepError::SlopeNotSupported(slope));
                }
                hub.step(config.demand(setpoint, power_reference), h)?;
                *readings = hub.readings();
                Ok(())
            }
        }
    }

    /// Advances by `h` seconds from time `t` [s] with the inputs held and the frequency `f`
    /// [Hz] held, adding the reserves' request to the demand; the step is cut where FFR's
    /// support ends. Refused requests leave the plant unchanged (FFR's state may have moved).
    #[allow(clippy::too_many_arguments)]
    pub fn step_with_reserves(
        &mut self,
        config: &PlantConfig,
        response: &mut FrequencyResponse,
        setpoint: f64,
        slope: f64,
        power_reference: f64,
        frequency: f64,
        t: f64,
        h: f64,
    ) -> Result<ReserveStep, StepError> {
        if !frequency.is_finite() {
            return Err(StepError::NonFiniteSetpoint(frequency));
        }
        response.end_due(t);
        response.begin_step(t, frequency);
        let mut shortfall = 0.0_f64;
        let (mut now, mut left) = (t, h);
        while left > 0.0 {
            let cut = response
                .next_event()
                .filter(|until| *until > now && *until - now < left);
            let piece = cut.map_or(left, |until| until - now);
            let request = response.request(frequency);
            self.step_requested(config, setpoint, slope, power_reference, request, piece)?;
            // Nothing asked, nothing short.
            if request != 0.0 {
                let short = self
                    .reserve_step(config, setpoint, power_reference, request)
                    .shortfall;
                if short.abs() > shortfall.abs() {
                    shortfall = short;
                }
            }
            now += piece;
            left = if cut.is_some() { left - piece } else { 0.0 };
            if cut.is_some() {
                response.end_due(f64::INFINITY); // the support ends exactly at the cut
            }
        }
        let report = self.reserve_step(
            config,
            setpoint,
            power_reference,
            response.request(frequency),
        );
        Ok(ReserveStep {
            shortfall,
            ..report
        })
    }

    /// The demand for these inputs with `request` [W] added: to the power reference, or in
    /// setpoint mode to the power the setpoint stands for (N modules at the first parameter
    /// set's steady power at that setpoint), converted back to a setpoint.
    fn requested_demand(
        &self,
        config: &PlantConfig,
        setpoint: f64,
        power_reference: f64,
        request: f64,
    ) -> Demand {
        match (config.demand(setpoint, power_reference), self) {
            (Demand::Power(p), _) => Demand::Power(p + request),
            (Demand::Setpoint(u), Plant::Hub(hub, _)) => {
                let (curve, n) = (hub.power_curve(0), self.modules());
                Demand::Setpoint(curve.setpoint(curve.power(u.max(0.0)) + request / n))
            }
            (demand, Plant::Module(_)) => demand,
        }
    }

    /// One step of a constant `request` [W] ([`Plant::step`] where it is 0).
    fn step_requested(
        &mut self,
        config: &PlantConfig,
        setpoint: f64,
        slope: f64,
        power_reference: f64,
        request: f64,
        h: f64,
    ) -> Result<(), StepError> {
        if request == 0.0 {
            return self.step(config, setpoint, slope, power_reference, h);
        }
        let demand = self.requested_demand(config, setpoint, power_reference, request);
        let base = config.demand(setpoint, power_reference);
        match self {
            Plant::Hub(hub, readings) if slope == 0.0 => {
                hub.step_with_base(demand, base, h)?;
                *readings = hub.readings();
                Ok(())
            }
            Plant::Hub(..) => Err(StepError::SlopeNotSupported(slope)),
            // A plant that offers reserves is a hub; a module is never asked for one.
            Plant::Module(_) => self.step(config, setpoint, slope, power_reference, h),
        }
    }

    /// What the operating window lets the plant deliver of `request` [W] at these inputs.
    pub fn reserve_step(
        &self,
        config: &PlantConfig,
        setpoint: f64,
        power_reference: f64,
        request: f64,
    ) -> ReserveStep {
        let (baseline, lo, hi) = match self {
            Plant::Module(m) => {
                let p = m.parameters();
                let curve = PowerCurve::new(p, &config.hub.operation.grid);
                let power = |u: f64| curve.power(u);
                (
                    power(p.clamp_setpoint(setpoint)),
                    power(p.min_setpoint),
                    power(p.max_setpoint),
                )
            }
            Plant::Hub(hub, _) => {
                let (lo, hi) = hub.power_range();
                let baseline = match config.demand(setpoint, power_reference) {
                    Demand::Power(p) => p,
                    Demand::Setpoint(u) => self.modules() * hub.power_curve(0).power(u.max(0.0)),
                };
                (baseline, lo, hi)
            }
        };
        let deliverable = (baseline + request).clamp(lo, hi) - baseline.clamp(lo, hi);
        ReserveStep {
            request,
            baseline,
            range: (lo, hi),
            shortfall: request - deliverable,
        }
    }

    /// The time-varying state.
    pub fn snapshot(&self) -> PlantSnapshot {
        match self {
            Plant::Module(m) => PlantSnapshot::Module(*m.state()),
            Plant::Hub(hub, _) => PlantSnapshot::Hub(hub.snapshot()),
        }
    }

    /// Restores a snapshot of a plant built with the same parameters and configuration;
    /// refuses (changing nothing) one of the other kind or out of range.
    pub fn restore(&mut self, snapshot: PlantSnapshot) -> Result<(), SnapshotError> {
        match (self, snapshot) {
            (Plant::Module(m), PlantSnapshot::Module(state)) => {
                m.restore(state);
                Ok(())
            }
            (Plant::Hub(hub, readings), PlantSnapshot::Hub(s)) => {
                hub.restore(s)?;
                *readings = hub.readings();
                Ok(())
            }
            _ => Err(SnapshotError::OtherKind),
        }
    }

    fn modules(&self) -> f64 {
        match self {
            Plant::Module(_) => 1.0,
            Plant::Hub(hub, _) => hub.config().n_modules as f64,
        }
    }

    /// Stack current per module [A].
    pub fn current(&self) -> f64 {
        match self {
            Plant::Module(m) => m.current(),
            Plant::Hub(_, r) => r.current / self.modules(),
        }
    }

    /// Stack voltage [V] (hub: mean over the modules carrying current).
    pub fn voltage(&self) -> f64 {
        match self {
            Plant::Module(m) => m.voltage(),
            Plant::Hub(_, r) => r.voltage,
        }
    }

    /// The voltage's drift [V] (hub: mean over the modules; 0 without ageing).
    pub fn voltage_drift(&self) -> f64 {
        match self {
            Plant::Module(m) => m.voltage_drift(),
            Plant::Hub(_, r) => r.voltage_drift,
        }
    }

    /// The largest drift of any module [V] (0 without ageing).
    pub fn max_voltage_drift(&self) -> f64 {
        match self {
            Plant::Module(m) => m.voltage_drift(),
            Plant::Hub(_, r) => r.max_voltage_drift,
        }
    }

    /// Electric power per module [W].
    pub fn power(&self) -> f64 {
        self.hub_power() / self.modules()
    }

    /// Hydrogen flow per module [Nl/h].
    pub fn h2_flow(&self) -> f64 {
        self.hub_h2_flow() / self.modules()
    }

    /// Energy per module since the start [J].
    pub fn energy(&self) -> f64 {
        self.hub_energy() / self.modules()
    }

    /// Hydrogen per module since the start [Nl].
    pub fn h2_produced(&self) -> f64 {
        self.hub_h2_produced() / self.modules()
    }

    /// Electric power of the plant [W].
    pub fn hub_power(&self) -> f64 {
        match self {
            Plant::Module(m) => m.power(),
            Plant::Hub(_, r) => r.power,
        }
    }

    /// What the grid sees of the plant now [W]: the electric power with the supply's losses
    /// and the auxiliaries (see [`crate::grid`]).
    pub fn hub_ac_power(&self) -> f64 {
        match self {
            Plant::Module(m) => m.ac_power(),
            Plant::Hub(hub, r) => {
                let steady = r.counts[OperatingState::Steady.code() as usize];
                let starting = r.counts[OperatingState::Curve.code() as usize];
                let sums = CurrentSums {
                    running: steady as f64,
                    starting: starting as f64,
                    current: r.current,
                    current_squared: r.current_squared,
                };
                hub.config().operation.grid.ac_power(r.power, &sums)
            }
        }
    }

    /// Grid power per module [W].
    pub fn ac_power(&self) -> f64 {
        self.hub_ac_power() / self.modules()
    }

    /// Grid energy of the plant since the start [J]: the electric energy with the supply's
    /// losses and the auxiliaries', exact (see [`crate::grid`]).
    pub fn hub_ac_energy(&self) -> f64 {
        match self {
            Plant::Module(m) => m.ac_energy(),
            Plant::Hub(hub, _) => {
                let t = hub.totals();
                let sums = CurrentSums {
                    running: t.running,
                    starting: t.starting,
                    current: t.charge,
                    current_squared: t.current_squared,
                };
                hub.config().operation.grid.ac_energy(t.energy, &sums)
            }
        }
    }

    /// Hydrogen flow of the plant [Nl/h].
    pub fn hub_h2_flow(&self) -> f64 {
        match self {
            Plant::Module(m) => m.h2_flow(),
            Plant::Hub(_, r) => r.h2_flow,
        }
    }

    /// Hydrogen flow of the plant by mass [kg/h].
    pub fn hub_h2_mass_flow(&self) -> f64 {
        self.hub_h2_flow() * H2_KG_PER_NL
    }

    /// Energy of the plant since the start [J].
    pub fn hub_energy(&self) -> f64 {
        match self {
            Plant::Module(m) => m.energy(),
            Plant::Hub(hub, _) => hub.totals().energy,
        }
    }

    /// Hydrogen of the plant since the start [Nl].
    pub fn hub_h2_produced(&self) -> f64 {
        match self {
            Plant::Module(m) => m.h2_produced(),
            Plant::Hub(hub, _) => hub.totals().h2_produced,
        }
    }

    /// Running time summed over modules since the start [h].
    pub fn running_hours(&self) -> f64 {
        match self {
            Plant::Module(m) => m.time() / SECONDS_PER_HOUR,
            Plant::Hub(hub, _) => hub.totals().running / SECONDS_PER_HOUR,
        }
    }

    /// Start-ups summed over modules since the start (a single module never stops) [1].
    pub fn starts(&self) -> f64 {
        match self {
            Plant::Module(_) => 0.0,
            Plant::Hub(hub, _) => hub.totals().starts as f64,
        }
    }

    /// Of the start-ups, the warm ones (in warmStartTime: from standby, or with the stack
    /// temperature modelled from a stack at least warmStartTemperature) [1].
    pub fn warm_starts(&self) -> f64 {
        match self {
            Plant::Module(_) => 0.0,
            Plant::Hub(hub, _) => hub.totals().warm_starts as f64,
        }
    }

    /// Stack temperature [K]: the module's (a hub: the mean over its modules) with the thermal
    /// model, else the polarisation curve's (Table I: 55 °C).
    pub fn stack_temperature(&self) -> f64 {
        match self {
            Plant::Module(m) => m.temperature(),
            Plant::Hub(_, r) => r.temperature,
        }
    }

    /// Heat the stack's cooling removes now, per module [W] (0 without the thermal model).
    pub fn cooling_power(&self) -> f64 {
        match self {
            Plant::Module(m) => m.cooling_power(),
            Plant::Hub(_, r) => r.cooling_power / self.modules(),
        }
    }

    /// Sets the ambient temperature [K] for the following steps; refuses (changing nothing)
    /// one that is not a finite number > 0.
    pub fn set_ambient_temperature(&mut self, ambient: f64) -> Result<(), StepError> {
        match self {
            Plant::Module(m) => m.set_ambient_temperature(ambient),
            Plant::Hub(hub, readings) if ambient.is_finite() && ambient > 0.0 => {
                hub.set_ambient_temperature(ambient);
                *readings = hub.readings();
                Ok(())
            }
            Plant::Hub(..) => Err(StepError::InvalidAmbientTemperature(ambient)),
        }
    }

    /// Modules in `state` [1].
    pub fn count_in(&self, state: OperatingState) -> i32 {
        let count = match self {
            Plant::Module(_) => (state == OperatingState::Steady) as u32,
            Plant::Hub(_, r) => r.counts[state.code() as usize],
        };
        count as i32
    }

    /// The most active state of any module: Steady, else Curve, Standby, Blowdown, Idle.
    pub fn state(&self) -> OperatingState {
        use OperatingState::*;
        [Steady, Curve, Standby, Blowdown]
            .into_iter()
            .find(|&s| self.count_in(s) > 0)
            .unwrap_or(Idle)
    }
}

/// Module k of `n` has set k mod M: set j serves ⌊n/M⌋ modules, one more for j < n mod M.
/// Sets beyond the n-th serve no module and are left out.
fn round_robin(sets: &[Parameters], n: u32) -> Result<Vec<(Parameters, u32)>, ParameterError> {
    if sets.is_empty() {
        return Err(ParameterError {
            name: "moduleParameterFile",
            value: 0.0,
            requirement: "must hold at least one module".into(),
        });
    }
    let m = sets.len() as u32;
    Ok(sets
        .iter()
        .enumerate()
        .map(|(j, p)| (*p, n / m + u32::from((j as u32) < n % m)))
        .filter(|(_, count)| *count > 0)
        .collect())
}

#[cfg(test)]
mod ageing_tests;
#[cfg(test)]
mod grid_tests;
#[cfg(test)]
mod tests;
