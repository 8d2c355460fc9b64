//! One FMU instance: FMI semantics on top of the model, in safe Rust.
//!
//! The exports in `exports.rs` check the call against the state table, turn pointers into
//! slices and call one method here. Every method either succeeds or returns a [`Failure`]
//! having changed nothing.

use std::ffi::{c_char, CString};
use std::path::PathBuf;

use crate::model_description::{
    BooleanVariable, Causality, IntegerVariable, RealVariable, StringVariable,
};
use aem_model::events::capacities_beyond_window;
use aem_model::parameter_file::ParameterFile;
use aem_model::{
    shown, EventState, FrequencyResponse, Parameters, Plant, PlantConfig, PlantEvent, PlantSettings,
};

use super::build_error::{BuildError, ValueError};
use super::file_location::{locate, Os};
use super::fmu_state::{ReserveState, SavedState};
use super::logger::{Logger, LOG_EVENTS};
use super::state_machine::FmiState;
use super::status::{discard, error, CallResult, Status};
use super::variables::{
    boolean_parameter_mut, integer_output, integer_parameter_mut, item_name, real_input_mut,
    real_output, real_parameter_mut, start_values, string_parameter_mut, Inputs,
};

/// Relative tolerance when comparing a master's communication point with the FMU's time;
/// masters that sum their step sizes drift by a few ulps from any other sum.
const TIME_TOLERANCE: f64 = 1e-9;

const INSTANCE_MAGIC: u64 = 0x4145_4d5f_494e_5354; // "AEM_INST"

/// The state of one instance. `repr(C)` with the magic first, so a foreign pointer is
/// probed at offset 0 only.
#[repr(C)]
pub struct Instance {
    magic: u64,
    /// The importer's logger.
    pub logger: Logger,
    /// Where the instance is in the FMI state machine.
    pub state: FmiState,
    params: Parameters,
    settings: PlantSettings,
    inputs: Inputs,
    /// d(setpoint)/dt for the next step [%/s], from fmi2SetRealInputDerivatives.
    setpoint_slope: f64,
    /// The plant's events under way (each logged once when it begins and once when it ends).
    events: EventState,
    /// The reserves' controller (FFR's state), from the settings at initialisation.
    response: FrequencyResponse,
    time: f64,
    /// stopTime of fmi2SetupExperiment, if defined: steps past it are refused [s].
    stop_time: Option<f64>,
    /// `moduleParameterFile`: a parameter file of aem-identify, or empty.
    module_parameter_file: String,
    /// The FMU's resources folder, from fmuResourceLocation if that is a local file URI
    /// (where a relative `moduleParameterFile` is looked up first).
    resources: Option<PathBuf>,
    /// The per-module parameter sets read from it at initialisation (kept with the state, so
    /// restoring never reads the file again).
    module_sets: Option<Vec<Parameters>>,
    /// The validated settings and the plant, once initialised.
    plant: Option<(PlantConfig, Plant)>,
    /// Strings returned by the last fmi2GetString (valid until the next call).
    returned_strings: Vec<CString>,
}

impl Instance {
    /// A freshly instantiated FMU with the model description's start values; `resources` is
    /// the FMU's resources folder, if the master named one.
    pub fn new(logger: Logger, resources: Option<PathBuf>) -> Self {
        let (params, settings, inputs) = start_values();
        Instance {
            magic: INSTANCE_MAGIC,
            logger,
            state: FmiState::Instantiated,
            params,
            settings,
            inputs,
            setpoint_slope: 0.0,
            events: EventState::default(),
            response: FrequencyResponse::new(settings.reserve),
            time: 0.0,
            stop_time: None,
            module_parameter_file: String::new(),
            resources,
            module_sets: None,
            plant: None,
            returned_strings: Vec::new(),
        }
    }

    /// Whether `ptr` is aligned and its memory carries a live instance's magic (a cheap
    /// guard against foreign pointers; reads only the magic word, as raw bytes).
    ///
    /// # Safety
    /// `ptr` must be non-null and point to at least `size_of::<Instance>()` readable bytes.
    pub unsafe fn has_magic(ptr: *const Instance) -> bool {
        ptr.is_aligned()
            && unsafe { std::ptr::addr_of!((*ptr).magic).read_unaligned() } == INSTANCE_MAGIC
    }

    /// Marks the memory as no longer an instance, just before it is freed.
    pub fn invalidate(&mut self) {
        self.magic = 0;
    }

    /// fmi2SetupExperiment: the start time, and the stop time past which steps are refused
    /// (FMI 2.0, section 2.1.6). The tolerance is not needed: the integration is exact.
    pub fn setup_experiment(&mut self, start_time: f64, stop_time: Option<f64>) -> CallResult {
        if !start_time.is_finite() {
            return Err(error(format!(
                "startTime = {} s is not a finite number",
                shown(start_time)
            )));
        }
        if let Some(stop) = stop_time {
            if !(stop >= start_time) {
                return Err(error(format!(
                    "stopTime = {} s is before startTime = {} s",
                    shown(stop),
                    shown(start_time)
                )));
            }
        }
        self.time = start_time;
        // stopTime = +inf bounds nothing: it is the same as no stopTime, and keeps every
        // saved state finite.
        self.stop_time = stop_time.filter(|stop| stop.is_finite());
        Ok(Status::Ok)
    }

    /// fmi2EnterInitializationMode.
    pub fn enter_initialization_mode(&mut self) -> CallResult {
        self.state = FmiState::InitializationMode;
        Ok(Status::Ok)
    }

    /// The parameter sets of `moduleParameterFile` over the current parameters, if one is set.
    fn read_module_sets(&self) -> Result<Option<Vec<Parameters>>, BuildError> {
        let value = self.module_parameter_file.as_str();
        if value.is_empty() {
            return Ok(None);
        }
        let path = locate(value, self.resources.as_deref(), Os::HERE)
            .map_err(BuildError::ParameterFileLocation)?;
        let file = ParameterFile::load(&path).map_err(|error| BuildError::ParameterFile {
            error,
            resources: self.resources.clone().filter(|_| path.is_relative()),
        })?;
        let sets = file
            .modules
            .iter()
            .map(|m| {
                m.parameters_over(self.params)
                    .map_err(|error| BuildError::ModuleEntry {
                        path: path.clone(),
                        module: m.module.clone(),
                        error,
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Some(sets))
    }

    /// The plant for the current parameters, settings and inputs, in steady state, with the
    /// per-module sets it uses.
    fn build_plant(&self) -> Result<(PlantConfig, Plant, Option<Vec<Parameters>>), BuildError> {
        let config = self.settings.config()?;
        let sets = self.read_module_sets()?;
        let request = config.reserve.proportional(self.inputs.frequency);
        let (setpoint, power) = (self.inputs.setpoint, self.inputs.power_reference);
        let mut plant = Plant::with_request(
            self.params,
            &config,
            sets.as_deref(),
            setpoint,
            power,
            request,
        )?;
        plant
            .set_ambient_temperature(self.inputs.ambient_temperature)
            .map_err(BuildError::Input)?;
        Ok((config, plant, sets))
    }

    /// fmi2ExitInitializationMode: validates the parameters and settings and starts the
    /// module or hub in steady state for the current inputs.
    pub fn exit_initialization_mode(&mut self) -> CallResult {
        let (config, plant, sets) = self
            .build_plant()
            .map_err(|e| error(format!("initialisation refused: {e}")))?;
        let policy = format!(
            "dispatch {}, belowMinimum {}",
            item_name(IntegerVariable::Dispatch, self.settings.dispatch),
            item_name(IntegerVariable::BelowMinimum, self.settings.below_minimum)
        );
        let what = match (&plant, &sets) {
            (Plant::Module(_), _) => "one module".to_string(),
            (_, Some(sets)) => format!(
                "a hub of {} modules ({policy}) with {} parameter sets",
                config.hub.n_modules,
                sets.len()
            ),
            _ => format!("a hub of {} modules ({policy})", config.hub.n_modules),
        };
        self.logger.info(
            LOG_EVENTS,
            &format!(
                "initialised {what} at t = {} s in steady state: {} modules running, power {} W",
                self.time,
                plant.count_in(aem_model::OperatingState::Steady),
                plant.hub_power()
            ),
        );
        let slope_dropped = !plant.takes_setpoint_slope() && self.setpoint_slope != 0.0;
        let capacity_warned = capacities_beyond_window(
            &config,
            &plant,
            self.inputs.setpoint,
            self.inputs.power_reference,
        )
        .iter()
        .fold(Status::Ok, |status, event| status.max(self.report(event)))
            == Status::Warning;
        self.response = FrequencyResponse::new(config.reserve);
        self.events.reset_reserves();
        self.module_sets = sets;
        self.plant = Some((config, plant));
        self.state = FmiState::StepComplete;
        let window = self.update_excursion();
        let status = if capacity_warned {
            Status::Warning
        } else {
            window
        };
        if slope_dropped {
            // Set while the settings still described a single module.
            self.logger.warning(&format!(
                "d(setpoint)/dt = {} %/s set before initialisation is dropped: a hub holds its inputs over a step",
                shown(self.setpoint_slope)
            ));
            self.setpoint_slope = 0.0;
            return Ok(Status::Warning);
        }
        Ok(status)
    }

    /// What the reserves ask for at the frequency now [W]: the request of a step begun now
    /// (FFR counted if the frequency is at its trigger). 0 before initialisation.
    fn reserve_request(&self) -> f64 {
        let mut response = self.response;
        if self.plant.is_none() {
            response = FrequencyResponse::new(self.settings.reserve);
        }
        response.end_due(self.time);
        response.begin_step(self.time, self.inputs.frequency);
        response.request(self.inputs.frequency)
    }

    /// Logs a plant event: a warning where the plant does not do what it was asked, else news
    /// (LOG_EVENTS).
    fn report(&self, event: &PlantEvent) -> Status {
        if event.is_warning() {
            self.logger.warning(&event.to_string());
            Status::Warning
        } else {
            self.logger.info(LOG_EVENTS, &event.to_string());
            Status::Ok
        }
    }

    /// fmi2Terminate.
    pub fn terminate(&mut self) -> CallResult {
        self.state = FmiState::Terminated;
        Ok(Status::Ok)
    }

    /// fmi2Reset: back to the state after fmi2Instantiate.
    pub fn reset(&mut self) -> CallResult {
        let mut logger = std::mem::replace(
            &mut self.logger,
            Logger::new(None, std::ptr::null_mut(), Default::default(), false),
        );
        // As if fmi2Instantiate had been called again: debug logging as it was requested then.
        logger.restore_instantiation_logging();
        *self = Instance::new(logger, self.resources.take());
        self.logger.info(LOG_EVENTS, "reset to the start values");
        Ok(Status::Ok)
    }

    /// Calls `f` with the plant: the running one, or in initialization mode one built from
    /// the current start values.
    fn with_plant<T>(
        &self,
        name: &'static str,
        f: impl FnOnce(&Plant) -> T,
    ) -> Result<T, ValueError> {
        match &self.plant {
            Some((_, plant)) => Ok(f(plant)),
            None => self
                .build_plant()
                .map(|(_, plant, _)| f(&plant))
                .map_err(|cause| ValueError::NotYet {
                    name,
                    cause: Box::new(cause),
                }),
        }
    }

    /// The value of one Real variable.
    fn real(&self, var: RealVariable) -> Result<f64, ValueError> {
        let value = match var.causality() {
            Causality::Output => {
                let request = if var == RealVariable::ReserveRequest {
                    self.reserve_request()
                } else {
                    0.0
                };
                self.with_plant(var.name(), |plant| real_output(var, plant, request))?
            }
            Causality::Input => {
                let mut inputs = self.inputs;
                real_input_mut(&mut inputs, var).map(|v| *v)
            }
            Causality::Parameter => {
                let (mut params, mut settings) = (self.params, self.settings);
                real_parameter_mut(&mut params, &mut settings, var).map(|v| *v)
            }
        };
        value.ok_or(ValueError::NoValue { name: var.name() })
    }

    /// fmi2GetReal.
    pub fn get_real(&self, vrs: &[u32], values: &mut [f64]) -> CallResult {
        for (vr, out) in vrs.iter().zip(values.iter_mut()) {
            let var = known(*vr, RealVariable::from_value_reference, "Real")?;
            *out = self.real(var).map_err(|e| error(e.to_string()))?;
        }
        Ok(Status::Ok)
    }

    /// fmi2GetInteger.
    pub fn get_integer(&self, vrs: &[u32], values: &mut [i32]) -> CallResult {
        for (vr, out) in vrs.iter().zip(values.iter_mut()) {
            let var = known(*vr, IntegerVariable::from_value_reference, "Integer")?;
            let mut settings = self.settings;
            let value = match var.causality() {
                Causality::Parameter => integer_parameter_mut(&mut settings, var).map(|v| *v),
                Causality::Output => self
                    .with_plant(var.name(), |plant| integer_output(var, plant))
                    .map_err(|e| error(e.to_string()))?,
                Causality::Input => None,
            };
            *out = value.ok_or_else(|| error(format!("{} has no value here", var.name())))?;
        }
        Ok(Status::Ok)
    }

    /// fmi2GetBoolean.
    pub fn get_boolean(&self, vrs: &[u32], values: &mut [bool]) -> CallResult {
        for (vr, out) in vrs.iter().zip(values.iter_mut()) {
            let var = known(*vr, BooleanVariable::from_value_reference, "Boolean")?;
            let mut settings = self.settings;
            *out = boolean_parameter_mut(&mut settings, var)
                .map(|v| *v)
                .ok_or_else(|| error(format!("{} has no value here", var.name())))?;
        }
        Ok(Status::Ok)
    }

    /// Refuses setting a fixed parameter after initialisation.
    fn parameter_settable(&self, name: &str) -> Result<(), super::status::Failure> {
        if self.state == FmiState::StepComplete || self.state == FmiState::Terminated {
            return Err(error(format!(
                "{name} is a fixed parameter: it can only be set before fmi2ExitInitializationMode"
            )));
        }
        Ok(())
    }

    /// fmi2SetReal: all values are checked before any is applied.
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> CallResult {
        let (mut params, mut settings, mut inputs) = (self.params, self.settings, self.inputs);
        for (vr, value) in vrs.iter().zip(values) {
            let var = known(*vr, RealVariable::from_value_reference, "Real")?;
            if !value.is_finite() {
                return Err(error(format!(
                    "{} = {} refused: not a finite number",
                    var.name(),
                    shown(*value)
                )));
            }
            if var == RealVariable::AmbientTemperature && *value <= 0.0 {
                return Err(error(format!(
                    "ambientTemperature = {} refused: must be a finite number > 0 K",
                    shown(*value)
                )));
            }
            let field = match var.causality() {
                Causality::Input => real_input_mut(&mut inputs, var),
                Causality::Parameter => {
                    self.parameter_settable(var.name())?;
                    real_parameter_mut(&mut params, &mut settings, var)
                }
                Causality::Output => {
                    return Err(error(format!(
                        "{} is an output and cannot be set",
                        var.name()
                    )))
                }
            };
            if let Some(field) = field {
                *field = *value;
            }
        }
        if inputs.ambient_temperature != self.inputs.ambient_temperature {
            // An input the plant holds: handed over now (coolingPower depends on it).
            if let Some((_, plant)) = self.plant.as_mut() {
                plant
                    .set_ambient_temperature(inputs.ambient_temperature)
                    .map_err(|e| error(e.to_string()))?;
            }
        }
        self.params = params;
        self.settings = settings;
        self.inputs = inputs;
        if self.state == FmiState::StepComplete {
            Ok(self.update_excursion())
        } else {
            Ok(Status::Ok)
        }
    }

    /// fmi2SetInteger: parameters only; all values are checked before any is applied (their
    /// ranges at initialisation, as for Real parameters).
    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> CallResult {
        let mut settings = self.settings;
        for (vr, value) in vrs.iter().zip(values) {
            let var = known(*vr, IntegerVariable::from_value_reference, "Integer")?;
            if var.causality() != Causality::Parameter {
                return Err(error(format!(
                    "{} is an output and cannot be set",
                    var.name()
                )));
            }
            self.parameter_settable(var.name())?;
            if let Some(field) = integer_parameter_mut(&mut settings, var) {
                *field = *value;
            }
        }
        self.settings = settings;
        Ok(Status::Ok)
    }

    /// fmi2SetBoolean: parameters only.
    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> CallResult {
        let mut settings = self.settings;
        for (vr, value) in vrs.iter().zip(values) {
            let var = known(*vr, BooleanVariable::from_value_reference, "Boolean")?;
            self.parameter_settable(var.name())?;
            if let Some(field) = boolean_parameter_mut(&mut settings, var) {
                *field = *value;
            }
        }
        self.settings = settings;
        Ok(Status::Ok)
    }

    /// fmi2GetString: the pointers stay valid until the next fmi2GetString on this instance.
    pub fn get_string(&mut self, vrs: &[u32], values: &mut [*const c_char]) -> CallResult {
        let mut strings = Vec::with_capacity(vrs.len());
        for vr in vrs {
            let var = known(*vr, StringVariable::from_value_reference, "String")?;
            let mut file = self.module_parameter_file.clone();
            let value = string_parameter_mut(&mut file, var)
                .map(|v| v.clone())
                .ok_or_else(|| error(format!("{} has no value here", var.name())))?;
            strings.push(super::logger::c_string(&value));
        }
        for (out, s) in values.iter_mut().zip(&strings) {
            *out = s.as_ptr();
        }
        self.returned_strings = strings;
        Ok(Status::Ok)
    }

    /// fmi2SetString: parameters only; all values are checked before any is applied.
    pub fn set_string(&mut self, vrs: &[u32], values: &[String]) -> CallResult {
        let mut file = self.module_parameter_file.clone();
        for (vr, value) in vrs.iter().zip(values) {
            let var = known(*vr, StringVariable::from_value_reference, "String")?;
            self.parameter_settable(var.name())?;
            if let Some(field) = string_parameter_mut(&mut file, var) {
                *field = value.clone();
            }
        }
        self.module_parameter_file = file;
        Ok(Status::Ok)
    }

    /// fmi2SetRealInputDerivatives: first derivatives of the input for the next step; all
    /// values are checked before any is applied.
    pub fn set_input_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        values: &[f64],
    ) -> CallResult {
        let single = self.single_module();
        let power_input = self.settings.power_input;
        let mut slope = self.setpoint_slope;
        let mut ignored = Vec::new();
        for ((vr, order), value) in vrs.iter().zip(orders).zip(values) {
            let var = known(*vr, RealVariable::from_value_reference, "Real")?;
            if var.causality() != Causality::Input {
                return Err(error(format!(
                    "{} is not an input: only inputs take derivatives",
                    var.name()
                )));
            }
            if *order < 1 {
                return Err(error(format!(
                    "derivative order {order} of {} refused: orders start at 1",
                    var.name()
                )));
            }
            if !value.is_finite() {
                return Err(error(format!(
                    "d({})/dt = {} refused: not a finite number",
                    var.name(),
                    shown(*value)
                )));
            }
            let drives = match var {
                RealVariable::PowerReference => power_input,
                RealVariable::Frequency => self.settings.reserve.offered(),
                RealVariable::AmbientTemperature => self.settings.thermal_model,
                _ => !power_input,
            };
            match (var, *order) {
                (RealVariable::Setpoint, 1) if single => slope = *value,
                (RealVariable::AmbientTemperature, 1) if drives && *value != 0.0 => {
                    return Err(error(format!(
                        "d(ambientTemperature)/dt = {} refused: the ambient temperature is held over a step",
                        shown(*value)
                    )))
                }
                (RealVariable::Frequency, 1) if drives && *value != 0.0 => {
                    return Err(error(format!(
                        "d(frequency)/dt = {} refused: the frequency is held over a step (the reserves' request is constant \
                         over it, FFR's end aside)",
                        shown(*value)
                    )))
                }
                (_, 1) if drives && *value != 0.0 => {
                    return Err(error(format!(
                        "d({})/dt = {} refused: a hub holds its inputs over a step; only a single module (nModules = 1, \
                         belowMinimum = 0, powerInput = false, parameterSpread = 0) integrates an interpolated input",
                        var.name(),
                        shown(*value)
                    )))
                }
                // A zero slope, or the slope of an input that does not drive the plant: exact as it is.
                (_, 1) => {}
                _ => ignored.push(format!("order {order} of {}", var.name())),
            }
        }
        self.setpoint_slope = slope;
        if ignored.is_empty() {
            return Ok(Status::Ok);
        }
        self.logger.warning(&format!(
            "fmi2SetRealInputDerivatives: {} ignored: the input is interpolated linearly (first derivative only)",
            ignored.join(", ")
        ));
        Ok(Status::Warning)
    }

    /// Whether a single module (which integrates an interpolated setpoint and warns when its
    /// setpoint leaves the window) is simulated, or (before initialisation, with settings not
    /// yet valid) may be.
    fn single_module(&self) -> bool {
        match &self.plant {
            Some((_, plant)) => plant.takes_setpoint_slope(),
            None => {
                self.module_parameter_file.is_empty()
                    && !self.settings.power_input
                    && self.config().is_none_or(|c| c.is_single_module())
            }
        }
    }

    /// The validated settings: the running plant's, or (before initialisation) the current
    /// ones if they are valid.
    fn config(&self) -> Option<PlantConfig> {
        match &self.plant {
            Some((config, _)) => Some(*config),
            None => self.settings.config().ok(),
        }
    }

    /// Reports where a single module's setpoint leaves or returns to the operating window.
    /// A hub's setpoint is shared out by its dispatch, so only a single module reports.
    fn update_excursion(&mut self) -> Status {
        if self.plant.is_none() || !self.single_module() {
            return Status::Ok;
        }
        match self.events.setpoint(&self.params, self.inputs.setpoint) {
            Some(event) => self.report(&event),
            None => Status::Ok,
        }
    }

    /// fmi2DoStep: advances exactly from the FMU's time by `h` seconds.
    pub fn do_step(&mut self, communication_point: f64, h: f64) -> CallResult {
        if !(h.is_finite() && h > 0.0) {
            return Err(error(format!(
                "communicationStepSize = {} s must be finite and > 0",
                shown(h)
            )));
        }
        let tolerance = TIME_TOLERANCE * self.time.abs().max(1.0);
        if !((communication_point - self.time).abs() <= tolerance) {
            return Err(error(format!(
                "currentCommunicationPoint = {} s does not match the FMU's time {} s",
                shown(communication_point),
                shown(self.time)
            )));
        }
        if let Some(stop) = self.stop_time {
            let end = self.time + h;
            if end > stop + TIME_TOLERANCE * stop.abs().max(1.0) {
                return Err(error(format!(
                    "a step to {} s would pass stopTime = {} s set in fmi2SetupExperiment",
                    shown(end),
                    shown(stop)
                )));
            }
        }
        let Some((config, plant)) = self.plant.as_mut() else {
            return Err(error("the instance is not initialised"));
        };
        // The setpoint is u(t) = setpoint + slope·(t − t_c) over this step (slope 0 unless the
        // master set a derivative at this communication point); the power reference and the
        // frequency are held.
        let inputs = self.inputs;
        let mut response = self.response;
        let step = plant
            .step_with_reserves(
                config,
                &mut response,
                inputs.setpoint,
                self.setpoint_slope,
                inputs.power_reference,
                inputs.frequency,
                self.time,
                h,
            )
            .map_err(|e| error(e.to_string()))?;
        let offered = config.reserve.offered();
        self.response = response;
        // Resynchronise to the master's clock: whether it sums its steps or computes t0 + n·h,
        // the FMU's time never drifts away from it.
        self.time = communication_point + h;
        self.setpoint_slope = 0.0;
        if !offered {
            return Ok(Status::Ok);
        }
        let events = self
            .events
            .reserve_step(&step, inputs.frequency, self.params.ramp_up_limit);
        Ok(events
            .iter()
            .fold(Status::Ok, |status, event| status.max(self.report(event))))
    }

    /// fmi2GetRealStatus(fmi2LastSuccessfulTime).
    pub fn last_successful_time(&self) -> f64 {
        self.time
    }

    /// A complete copy of the state (fmi2GetFMUstate).
    pub fn save(&self) -> SavedState {
        SavedState::new(
            self.state,
            self.params,
            self.settings,
            self.inputs,
            self.setpoint_slope,
            self.events.setpoint_outside,
            self.time,
            self.stop_time,
            self.module_parameter_file.clone(),
            self.module_sets.clone(),
            ReserveState {
                fast: self.response.fast,
                shortfall: self.events.reserve_shortfall,
                increase: self.events.reserve_increase,
            },
            self.plant.as_ref().map(|(_, plant)| plant.snapshot()),
        )
    }

    /// Restores a copy made by [`Instance::save`] (fmi2SetFMUstate); the plant is rebuilt
    /// from the saved parameters and settings, then given the saved state.
    pub fn restore(&mut self, saved: &SavedState) -> CallResult {
        let plant = match &saved.plant {
            Some(snapshot) => {
                let invalid = |e: String| error(format!("the FMU state holds invalid values: {e}"));
                let config = saved
                    .settings
                    .config()
                    .map_err(|e| invalid(e.to_string()))?;
                let sets = saved.module_sets.as_deref();
                let mut plant = Plant::new(
                    saved.params,
                    &config,
                    sets,
                    saved.inputs.setpoint,
                    saved.inputs.power_reference,
                )
                .map_err(|e| invalid(e.to_string()))?;
                plant
                    .restore(snapshot.clone())
                    .map_err(|e| invalid(e.to_string()))?;
                plant
                    .set_ambient_temperature(saved.inputs.ambient_temperature)
                    .map_err(|e| invalid(e.to_string()))?;
                Some((config, plant))
            }
            None => None,
        };
        let initialised = matches!(
            saved.fmi_state,
            FmiState::StepComplete | FmiState::Terminated
        );
        if initialised && plant.is_none() {
            return Err(error(format!(
                "the FMU state is inconsistent: {} without a plant state",
                saved.fmi_state
            )));
        }
        self.state = saved.fmi_state;
        self.params = saved.params;
        self.settings = saved.settings;
        self.inputs = saved.inputs;
        self.setpoint_slope = saved.setpoint_slope;
        self.events = EventState {
            setpoint_outside: saved.excursion,
            reserve_shortfall: saved.reserve.shortfall,
            reserve_increase: saved.reserve.increase,
        };
        self.response = FrequencyResponse {
            settings: saved.settings.reserve,
            fast: saved.reserve.fast,
        };
        self.time = saved.time;
        self.stop_time = saved.stop_time;
        self.module_parameter_file = saved.module_parameter_file.clone();
        self.module_sets = saved.module_sets.clone();
        self.plant = plant;
        Ok(Status::Ok)
    }

    /// A status kind this FMU does not provide.
    pub fn status_not_available(kind: &str) -> CallResult {
        Err(discard(format!(
            "{kind} is not available: fmi2DoStep always completes synchronously"
        )))
    }
}

/// The variable of a type with value reference `vr`, or an error naming it.
fn known<V>(
    vr: u32,
    lookup: fn(u32) -> Option<V>,
    type_name: &str,
) -> Result<V, super::status::Failure> {
    lookup(vr).ok_or_else(|| {
        error(format!(
            "unknown value reference {vr} for a{} {type_name} variable",
            if type_name == "Integer" { "n" } else { "" }
        ))
    })
}
