//! One FMU instance: FMI semantics on top of the model, in safe Rust.
//!
//! The exports in `exports.rs` check the call against the state table, turn pointers into
//! slices and call one method here. Every method either succeeds or returns a [`Failure`]
//! having changed nothing.

use crate::model::{shown, Module, Parameters};
use crate::model_description::{Causality, RealVariable};

use super::fmu_state::SavedState;
use super::logger::{Logger, LOG_EVENTS};
use super::state_machine::FmiState;
use super::status::{discard, error, CallResult, Status};
use super::variables::{input_mut, output, parameter_mut};

/// Relative tolerance when comparing a master's communication point with the FMU's time;
/// masters that sum their step sizes drift by a few ulps from any other sum.
const TIME_TOLERANCE: f64 = 1e-9;

/// Relative distance outside the setpoint window below which no warning is logged.
const WINDOW_TOLERANCE: f64 = 1e-9;

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
    setpoint: f64,
    /// d(setpoint)/dt for the next step [%/s], from fmi2SetRealInputDerivatives.
    setpoint_slope: f64,
    excursion: bool,
    time: f64,
    /// stopTime of fmi2SetupExperiment, if defined: steps past it are refused [s].
    stop_time: Option<f64>,
    module: Option<Module>,
}

impl Instance {
    /// A freshly instantiated FMU with the model description's start values.
    pub fn new(logger: Logger) -> Self {
        Instance {
            magic: INSTANCE_MAGIC,
            logger,
            state: FmiState::Instantiated,
            params: Parameters::default(),
            setpoint: crate::model_description::start::SETPOINT,
            setpoint_slope: 0.0,
            excursion: false,
            time: 0.0,
            stop_time: None,
            module: None,
        }
    }

    /// Whether `ptr` is aligned and its memory carries a live instance's magic (a cheap
    /// guard against foreign pointers; reads only the magic word, as raw bytes).
    ///
    /// # Safety
    /// `ptr` must be non-null and point to at least `size_of::<Instance>()` readable bytes.
    pub unsafe fn has_magic(ptr: *const Instance) -> bool {
        ptr.is_aligned() && unsafe { std::ptr::addr_of!((*ptr).magic).read_unaligned() } == INSTANCE_MAGIC
    }

    /// Marks the memory as no longer an instance, just before it is freed.
    pub fn invalidate(&mut self) {
        self.magic = 0;
    }

    /// fmi2SetupExperiment: the start time, and the stop time past which steps are refused
    /// (FMI 2.0, section 2.1.6). The tolerance is not needed: the integration is exact.
    pub fn setup_experiment(&mut self, start_time: f64, stop_time: Option<f64>) -> CallResult {
        if !start_time.is_finite() {
            return Err(error(format!("startTime = {} s is not a finite number", shown(start_time))));
        }
        if let Some(stop) = stop_time {
            if !(stop >= start_time) {
                return Err(error(format!("stopTime = {} s is before startTime = {} s", shown(stop), shown(start_time))));
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

    /// fmi2ExitInitializationMode: validates the parameters and starts the module in steady
    /// state at the current setpoint.
    pub fn exit_initialization_mode(&mut self) -> CallResult {
        let module = Module::new(self.params, self.setpoint)
            .map_err(|e| error(format!("initialisation refused: {e}")))?;
        self.logger.info(
            LOG_EVENTS,
            &format!("initialised at t = {} s in steady state: setpoint {} %, current {} A", self.time, self.setpoint, module.current()),
        );
        self.module = Some(module);
        self.state = FmiState::StepComplete;
        Ok(self.update_excursion())
    }

    /// fmi2Terminate.
    pub fn terminate(&mut self) -> CallResult {
        self.state = FmiState::Terminated;
        Ok(Status::Ok)
    }

    /// fmi2Reset: back to the state after fmi2Instantiate.
    pub fn reset(&mut self) -> CallResult {
        let mut logger = std::mem::replace(&mut self.logger, Logger::new(None, std::ptr::null_mut(), Default::default(), false));
        // As if fmi2Instantiate had been called again: debug logging as it was requested then.
        logger.restore_instantiation_logging();
        *self = Instance::new(logger);
        self.logger.info(LOG_EVENTS, "reset to the start values");
        Ok(Status::Ok)
    }

    /// The value of one Real variable.
    fn real(&self, var: RealVariable) -> Result<f64, String> {
        match var.causality() {
            Causality::Input => {
                let mut setpoint = self.setpoint;
                input_mut(&mut setpoint, var).map(|v| *v).ok_or_else(|| format!("{} is not an input", var.name()))
            }
            Causality::Parameter => {
                let mut params = self.params;
                parameter_mut(&mut params, var).map(|v| *v).ok_or_else(|| format!("{} is not a parameter", var.name()))
            }
            Causality::Output => {
                let value = match &self.module {
                    Some(module) => output(var, module),
                    // In initialization mode outputs follow from the current start values.
                    None => output(
                        var,
                        &Module::new(self.params, self.setpoint)
                            .map_err(|e| format!("{} cannot be computed yet: {e}", var.name()))?,
                    ),
                };
                value.ok_or_else(|| format!("{} is not an output", var.name()))
            }
        }
    }

    /// fmi2GetReal.
    pub fn get_real(&self, vrs: &[u32], values: &mut [f64]) -> CallResult {
        for (vr, out) in vrs.iter().zip(values.iter_mut()) {
            let var = known_variable(*vr)?;
            *out = self.real(var).map_err(error)?;
        }
        Ok(Status::Ok)
    }

    /// fmi2SetReal: all values are checked before any is applied.
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> CallResult {
        let mut params = self.params;
        let mut setpoint = self.setpoint;
        for (vr, value) in vrs.iter().zip(values) {
            let var = known_variable(*vr)?;
            if !value.is_finite() {
                return Err(error(format!("{} = {} refused: not a finite number", var.name(), shown(*value))));
            }
            match var.causality() {
                Causality::Input => {
                    if let Some(field) = input_mut(&mut setpoint, var) {
                        *field = *value;
                    }
                }
                Causality::Parameter => {
                    if self.state == FmiState::StepComplete {
                        return Err(error(format!(
                            "{} is a fixed parameter: it can only be set before fmi2ExitInitializationMode",
                            var.name()
                        )));
                    }
                    if let Some(field) = parameter_mut(&mut params, var) {
                        *field = *value;
                    }
                }
                Causality::Output => {
                    return Err(error(format!("{} is an output and cannot be set", var.name())));
                }
            }
        }
        self.params = params;
        self.setpoint = setpoint;
        if self.state == FmiState::StepComplete {
            Ok(self.update_excursion())
        } else {
            Ok(Status::Ok)
        }
    }

    /// fmi2SetRealInputDerivatives: first derivatives of the input for the next step; all
    /// values are checked before any is applied.
    pub fn set_input_derivatives(&mut self, vrs: &[u32], orders: &[i32], values: &[f64]) -> CallResult {
        let mut slope = self.setpoint_slope;
        let mut ignored = Vec::new();
        for ((vr, order), value) in vrs.iter().zip(orders).zip(values) {
            let var = known_variable(*vr)?;
            if input_mut(&mut 0.0, var).is_none() {
                return Err(error(format!("{} is not an input: only inputs take derivatives", var.name())));
            }
            if *order < 1 {
                return Err(error(format!("derivative order {order} of {} refused: orders start at 1", var.name())));
            }
            if !value.is_finite() {
                return Err(error(format!("d({})/dt = {} refused: not a finite number", var.name(), shown(*value))));
            }
            match (var, *order) {
                (RealVariable::Setpoint, 1) => slope = *value,
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

    /// Logs a warning when the setpoint leaves the operating window (once per excursion).
    fn update_excursion(&mut self) -> Status {
        let (lo, hi) = (self.params.min_setpoint, self.params.max_setpoint);
        // Rounding noise from a master's interpolation (100.00000000000001 %) is clamped
        // silently; only a real excursion is worth a warning.
        let slack = WINDOW_TOLERANCE * lo.abs().max(hi.abs()).max(1.0);
        let outside = self.setpoint < lo - slack || self.setpoint > hi + slack;
        if outside && !self.excursion {
            self.excursion = true;
            self.logger.warning(&format!(
                "setpoint = {} % is outside the operating window [{lo}, {hi}] %; the module runs at {} % until it returns",
                self.setpoint,
                self.params.clamp_setpoint(self.setpoint)
            ));
            return Status::Warning;
        }
        if !outside && self.excursion {
            self.excursion = false;
            self.logger.info(LOG_EVENTS, &format!("setpoint = {} % is back in the operating window", self.setpoint));
        }
        Status::Ok
    }

    /// fmi2DoStep: advances exactly from the FMU's time by `h` seconds.
    pub fn do_step(&mut self, communication_point: f64, h: f64) -> CallResult {
        if !(h.is_finite() && h > 0.0) {
            return Err(error(format!("communicationStepSize = {} s must be finite and > 0", shown(h))));
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
        let Some(module) = self.module.as_mut() else {
            return Err(error("the instance is not initialised"));
        };
        // The input is u(t) = setpoint + slope·(t − t_c) over this step (slope 0 unless the
        // master set a derivative at this communication point).
        module.step_interpolated(self.setpoint, self.setpoint_slope, h).map_err(|e| error(e.to_string()))?;
        // Resynchronise to the master's clock: whether it sums its steps or computes t0 + n·h,
        // the FMU's time never drifts away from it.
        self.time = communication_point + h;
        self.setpoint_slope = 0.0;
        Ok(Status::Ok)
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
            self.setpoint,
            self.setpoint_slope,
            self.excursion,
            self.time,
            self.stop_time,
            self.module.as_ref().map(|m| *m.state()),
        )
    }

    /// Restores a copy made by [`Instance::save`] (fmi2SetFMUstate).
    pub fn restore(&mut self, saved: &SavedState) -> CallResult {
        let module = match saved.module {
            Some(state) => {
                let mut m = Module::new(saved.params, saved.setpoint)
                    .map_err(|e| error(format!("the FMU state holds invalid values: {e}")))?;
                m.restore(state);
                Some(m)
            }
            None => None,
        };
        let initialised = matches!(saved.fmi_state, FmiState::StepComplete | FmiState::Terminated);
        if initialised && module.is_none() {
            return Err(error(format!("the FMU state is inconsistent: {} without a module state", saved.fmi_state)));
        }
        self.state = saved.fmi_state;
        self.params = saved.params;
        self.setpoint = saved.setpoint;
        self.setpoint_slope = saved.setpoint_slope;
        self.excursion = saved.excursion;
        self.time = saved.time;
        self.stop_time = saved.stop_time;
        self.module = module;
        Ok(Status::Ok)
    }

    /// A status kind this FMU does not provide.
    pub fn status_not_available(kind: &str) -> CallResult {
        Err(discard(format!("{kind} is not available: fmi2DoStep always completes synchronously")))
    }
}

fn known_variable(vr: u32) -> Result<RealVariable, super::status::Failure> {
    RealVariable::from_value_reference(vr).ok_or_else(|| error(format!("unknown value reference {vr} for a Real variable")))
}
