//! Maps each variable of the model description to the model. The matches are exhaustive
//! over the generated [`RealVariable`], [`IntegerVariable`] and [`BooleanVariable`], so the
//! XML and this code cannot drift apart; the model description's start values are the
//! instance's defaults ([`start_values`]).

use crate::model_description::{BooleanVariable, IntegerVariable, RealVariable, StringVariable};
use aem_model::{ModuleParameter, OperatingState, Parameters, Plant, PlantSettings};

/// The instance's input values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inputs {
    /// `setpoint` [%].
    pub setpoint: f64,
    /// `powerReference` [W].
    pub power_reference: f64,
    /// `frequency` [Hz].
    pub frequency: f64,
    /// `ambientTemperature` [K].
    pub ambient_temperature: f64,
}

impl Default for Inputs {
    fn default() -> Self {
        use crate::model_description::start;
        Inputs {
            setpoint: start::SETPOINT,
            power_reference: start::POWER_REFERENCE,
            frequency: start::FREQUENCY,
            ambient_temperature: start::AMBIENT_TEMPERATURE,
        }
    }
}

/// The model description's start values: module parameters, hub settings and inputs.
pub fn start_values() -> (Parameters, PlantSettings, Inputs) {
    let (mut params, mut settings, mut inputs) = (
        Parameters::default(),
        PlantSettings::default(),
        Inputs::default(),
    );
    for var in RealVariable::ALL {
        let slot = real_parameter_mut(&mut params, &mut settings, var)
            .or_else(|| real_input_mut(&mut inputs, var));
        if let (Some(slot), Some(start)) = (slot, var.start()) {
            *slot = start;
        }
    }
    for var in IntegerVariable::ALL {
        if let (Some(slot), Some(start)) = (integer_parameter_mut(&mut settings, var), var.start())
        {
            *slot = start;
        }
    }
    for var in BooleanVariable::ALL {
        if let (Some(slot), Some(start)) = (boolean_parameter_mut(&mut settings, var), var.start())
        {
            *slot = start;
        }
    }
    (params, settings, inputs)
}

/// The Real parameter field behind `var`, or None if `var` is not a parameter.
pub fn real_parameter_mut<'a>(
    params: &'a mut Parameters,
    settings: &'a mut PlantSettings,
    var: RealVariable,
) -> Option<&'a mut f64> {
    match module_parameter(var) {
        Some(parameter) => Some(params.field_mut(parameter)),
        None => setting_mut(settings, var),
    }
}

/// The module parameter (Table I and the operating window) behind `var`, or None if `var`
/// is not one of them.
pub fn module_parameter(var: RealVariable) -> Option<ModuleParameter> {
    use ModuleParameter as P;
    use RealVariable::*;
    match var {
        Gain => Some(P::Gain),
        TauZero => Some(P::TauZero),
        TauPole1 => Some(P::TauPole1),
        TauPole2 => Some(P::TauPole2),
        RampUpLimit => Some(P::RampUpLimit),
        VoltageIntercept => Some(P::VoltageIntercept),
        OhmicResistance => Some(P::OhmicResistance),
        H2Coefficient => Some(P::H2Coefficient),
        NominalCurrent => Some(P::NominalCurrent),
        MinSetpoint => Some(P::MinSetpoint),
        MaxSetpoint => Some(P::MaxSetpoint),
        Hysteresis
        | ColdStartTime
        | WarmStartTime
        | StartPower
        | StandbyPower
        | StandbyDuration
        | StopDuration
        | ParameterSpread
        | Setpoint
        | PowerReference
        | Current
        | Voltage
        | Power
        | H2Flow
        | Energy
        | H2Produced
        | HubPower
        | HubH2Flow
        | HubH2MassFlow
        | HubEnergy
        | HubH2Produced
        | RunningHours
        | Starts
        | Frequency
        | ReserveRequest
        | FcrNCapacity
        | FcrDUpCapacity
        | FcrDDownCapacity
        | FcrCapacity
        | FfrCapacity
        | FfrTriggerFrequency
        | FfrSupportDuration
        | InitialTemperature
        | HeatCapacity
        | ThermalResistance
        | CoolingSetpoint
        | MaxCoolingPower
        | NominalTemperature
        | VoltageTemperatureCoefficient
        | ResistanceTemperatureCoefficient
        | WarmStartTemperature
        | AmbientTemperature
        | StackTemperature
        | CoolingPower
        | AuxiliaryPower
        | SupplyNoLoadLoss
        | SupplyLossVoltage
        | SupplyLossResistance
        | AcPower
        | HubAcPower
        | HubAcEnergy
        | StandbyHeaterPower
        | DriftPerRunningHour
        | DriftPerStart
        | ReversibleDrift
        | DriftBuildUpTime
        | DriftRecoveryTime
        | InitialVoltageDrift
        | ReserveFilterZero
        | DispatchTargetSetpoint
        | VoltageDrift
        | MaxVoltageDrift
        | WarmStarts => None,
    }
}

/// The Real hub setting behind `var`, or None if `var` is not one.
fn setting_mut(settings: &mut PlantSettings, var: RealVariable) -> Option<&mut f64> {
    use RealVariable::*;
    match var {
        Hysteresis => Some(&mut settings.hysteresis),
        ColdStartTime => Some(&mut settings.cold_start_time),
        WarmStartTime => Some(&mut settings.warm_start_time),
        StartPower => Some(&mut settings.start_power),
        StandbyPower => Some(&mut settings.standby_power),
        StandbyDuration => Some(&mut settings.standby_duration),
        StopDuration => Some(&mut settings.stop_duration),
        ParameterSpread => Some(&mut settings.parameter_spread),
        FcrNCapacity => Some(&mut settings.reserve.fcr_n),
        FcrDUpCapacity => Some(&mut settings.reserve.fcr_d_up),
        FcrDDownCapacity => Some(&mut settings.reserve.fcr_d_down),
        FcrCapacity => Some(&mut settings.reserve.fcr),
        FfrCapacity => Some(&mut settings.reserve.ffr),
        FfrTriggerFrequency => Some(&mut settings.reserve.ffr_trigger),
        FfrSupportDuration => Some(&mut settings.reserve.ffr_duration),
        InitialTemperature => Some(&mut settings.thermal.initial_temperature),
        HeatCapacity => Some(&mut settings.thermal.heat_capacity),
        ThermalResistance => Some(&mut settings.thermal.thermal_resistance),
        CoolingSetpoint => Some(&mut settings.thermal.cooling_setpoint),
        MaxCoolingPower => Some(&mut settings.thermal.max_cooling_power),
        NominalTemperature => Some(&mut settings.thermal.nominal_temperature),
        VoltageTemperatureCoefficient => {
            Some(&mut settings.thermal.voltage_temperature_coefficient)
        }
        ResistanceTemperatureCoefficient => {
            Some(&mut settings.thermal.resistance_temperature_coefficient)
        }
        WarmStartTemperature => Some(&mut settings.thermal.warm_start_temperature),
        StandbyHeaterPower => Some(&mut settings.thermal.standby_heater_power),
        AuxiliaryPower => Some(&mut settings.grid.auxiliary_power),
        SupplyNoLoadLoss => Some(&mut settings.grid.supply_no_load_loss),
        SupplyLossVoltage => Some(&mut settings.grid.supply_loss_voltage),
        SupplyLossResistance => Some(&mut settings.grid.supply_loss_resistance),
        DriftPerRunningHour => Some(&mut settings.ageing.drift_per_running_hour),
        DriftPerStart => Some(&mut settings.ageing.drift_per_start),
        ReversibleDrift => Some(&mut settings.ageing.reversible_drift),
        DriftBuildUpTime => Some(&mut settings.ageing.drift_build_up_time),
        DriftRecoveryTime => Some(&mut settings.ageing.drift_recovery_time),
        InitialVoltageDrift => Some(&mut settings.ageing.initial_drift),
        ReserveFilterZero => Some(&mut settings.reserve.filter_zero),
        DispatchTargetSetpoint => Some(&mut settings.dispatch_target),
        Gain | TauZero | TauPole1 | TauPole2 | RampUpLimit | VoltageIntercept | OhmicResistance
        | H2Coefficient | NominalCurrent | MinSetpoint | MaxSetpoint | Setpoint
        | PowerReference | Current | Voltage | Power | H2Flow | Energy | H2Produced | HubPower
        | HubH2Flow | HubH2MassFlow | HubEnergy | HubH2Produced | RunningHours | Starts
        | Frequency | ReserveRequest | AmbientTemperature | StackTemperature | CoolingPower
        | AcPower | HubAcPower | HubAcEnergy | WarmStarts | VoltageDrift | MaxVoltageDrift => None,
    }
}

/// The input field behind `var`, or None if `var` is not an input.
pub fn real_input_mut(inputs: &mut Inputs, var: RealVariable) -> Option<&mut f64> {
    use RealVariable::*;
    match var {
        Setpoint => Some(&mut inputs.setpoint),
        PowerReference => Some(&mut inputs.power_reference),
        Frequency => Some(&mut inputs.frequency),
        AmbientTemperature => Some(&mut inputs.ambient_temperature),
        Current
        | Voltage
        | Power
        | H2Flow
        | Energy
        | H2Produced
        | HubPower
        | HubH2Flow
        | HubH2MassFlow
        | HubEnergy
        | HubH2Produced
        | RunningHours
        | Starts
        | Gain
        | TauZero
        | TauPole1
        | TauPole2
        | RampUpLimit
        | VoltageIntercept
        | OhmicResistance
        | H2Coefficient
        | NominalCurrent
        | MinSetpoint
        | MaxSetpoint
        | Hysteresis
        | ColdStartTime
        | WarmStartTime
        | StartPower
        | StandbyPower
        | StandbyDuration
        | StopDuration
        | ParameterSpread
        | ReserveRequest
        | FcrNCapacity
        | FcrDUpCapacity
        | FcrDDownCapacity
        | FcrCapacity
        | FfrCapacity
        | FfrTriggerFrequency
        | FfrSupportDuration
        | InitialTemperature
        | HeatCapacity
        | ThermalResistance
        | CoolingSetpoint
        | MaxCoolingPower
        | NominalTemperature
        | VoltageTemperatureCoefficient
        | ResistanceTemperatureCoefficient
        | WarmStartTemperature
        | StackTemperature
        | CoolingPower
        | AuxiliaryPower
        | SupplyNoLoadLoss
        | SupplyLossVoltage
        | SupplyLossResistance
        | AcPower
        | HubAcPower
        | HubAcEnergy
        | StandbyHeaterPower
        | DriftPerRunningHour
        | DriftPerStart
        | ReversibleDrift
        | DriftBuildUpTime
        | DriftRecoveryTime
        | InitialVoltageDrift
        | ReserveFilterZero
        | DispatchTargetSetpoint
        | VoltageDrift
        | MaxVoltageDrift
        | WarmStarts => None,
    }
}

/// The value of Real output `var` of `plant`, or None if `var` is not an output;
/// `reserve_request` [W] is what the reserves ask for now (it depends on the inputs).
pub fn real_output(var: RealVariable, plant: &Plant, reserve_request: f64) -> Option<f64> {
    use RealVariable::*;
    match var {
        Current => Some(plant.current()),
        Voltage => Some(plant.voltage()),
        Power => Some(plant.power()),
        H2Flow => Some(plant.h2_flow()),
        Energy => Some(plant.energy()),
        H2Produced => Some(plant.h2_produced()),
        HubPower => Some(plant.hub_power()),
        HubH2Flow => Some(plant.hub_h2_flow()),
        HubH2MassFlow => Some(plant.hub_h2_mass_flow()),
        HubEnergy => Some(plant.hub_energy()),
        HubH2Produced => Some(plant.hub_h2_produced()),
        RunningHours => Some(plant.running_hours()),
        Starts => Some(plant.starts()),
        ReserveRequest => Some(reserve_request),
        StackTemperature => Some(plant.stack_temperature()),
        CoolingPower => Some(plant.cooling_power()),
        AcPower => Some(plant.ac_power()),
        HubAcPower => Some(plant.hub_ac_power()),
        HubAcEnergy => Some(plant.hub_ac_energy()),
        WarmStarts => Some(plant.warm_starts()),
        VoltageDrift => Some(plant.voltage_drift()),
        MaxVoltageDrift => Some(plant.max_voltage_drift()),
        Setpoint
        | PowerReference
        | Gain
        | TauZero
        | TauPole1
        | TauPole2
        | RampUpLimit
        | VoltageIntercept
        | OhmicResistance
        | H2Coefficient
        | NominalCurrent
        | MinSetpoint
        | MaxSetpoint
        | Hysteresis
        | ColdStartTime
        | WarmStartTime
        | StartPower
        | StandbyPower
        | StandbyDuration
        | StopDuration
        | ParameterSpread
        | Frequency
        | FcrNCapacity
        | FcrDUpCapacity
        | FcrDDownCapacity
        | FcrCapacity
        | FfrCapacity
        | FfrTriggerFrequency
        | FfrSupportDuration
        | InitialTemperature
        | HeatCapacity
        | ThermalResistance
        | CoolingSetpoint
        | MaxCoolingPower
        | NominalTemperature
        | VoltageTemperatureCoefficient
        | ResistanceTemperatureCoefficient
        | WarmStartTemperature
        | AuxiliaryPower
        | SupplyNoLoadLoss
        | SupplyLossVoltage
        | SupplyLossResistance
        | StandbyHeaterPower
        | DriftPerRunningHour
        | DriftPerStart
        | ReversibleDrift
        | DriftBuildUpTime
        | DriftRecoveryTime
        | InitialVoltageDrift
        | ReserveFilterZero
        | DispatchTargetSetpoint
        | AmbientTemperature => None,
    }
}

/// The Integer parameter field behind `var`, or None if `var` is not a parameter.
pub fn integer_parameter_mut(
    settings: &mut PlantSettings,
    var: IntegerVariable,
) -> Option<&mut i32> {
    use IntegerVariable::*;
    match var {
        NModules => Some(&mut settings.n_modules),
        Dispatch => Some(&mut settings.dispatch),
        BelowMinimum => Some(&mut settings.below_minimum),
        SpreadSeed => Some(&mut settings.spread_seed),
        InitialStandby => Some(&mut settings.initial_standby),
        NCells => Some(&mut settings.thermal.n_cells),
        OperatingState | ModulesIdle | ModulesStarting | ModulesRunning | ModulesStandby
        | ModulesStopping => None,
    }
}

/// The value of Integer output `var` of `plant`, or None if `var` is not an output.
pub fn integer_output(var: IntegerVariable, plant: &Plant) -> Option<i32> {
    use IntegerVariable as V;
    use OperatingState::*;
    match var {
        V::OperatingState => Some(plant.state().code()),
        V::ModulesIdle => Some(plant.count_in(Idle)),
        V::ModulesStarting => Some(plant.count_in(Curve)),
        V::ModulesRunning => Some(plant.count_in(Steady)),
        V::ModulesStandby => Some(plant.count_in(Standby)),
        V::ModulesStopping => Some(plant.count_in(Blowdown)),
        V::NModules
        | V::Dispatch
        | V::BelowMinimum
        | V::SpreadSeed
        | V::NCells
        | V::InitialStandby => None,
    }
}

/// The name of `value` among the items of Enumeration variable `var` ("equal" for dispatch 1),
/// or "invalid" if it is none of them (or `var` is a plain Integer).
pub fn item_name(var: IntegerVariable, value: i32) -> &'static str {
    var.enumeration()
        .and_then(|e| e.item(value))
        .map_or("invalid", |item| item.name)
}

/// The Boolean parameter field behind `var`, or None if `var` is not a parameter.
pub fn boolean_parameter_mut(
    settings: &mut PlantSettings,
    var: BooleanVariable,
) -> Option<&mut bool> {
    match var {
        BooleanVariable::PowerInput => Some(&mut settings.power_input),
        BooleanVariable::ReserveCompensation => Some(&mut settings.reserve.compensation),
        BooleanVariable::ThermalModel => Some(&mut settings.thermal_model),
        BooleanVariable::GridSideReference => Some(&mut settings.grid.grid_side_reference),
    }
}

/// The String parameter field behind `var` (given the instance's `moduleParameterFile`).
pub fn string_parameter_mut(
    module_parameter_file: &mut String,
    var: StringVariable,
) -> Option<&mut String> {
    match var {
        StringVariable::ModuleParameterFile => Some(module_parameter_file),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model_description::Causality;

    /// The model description's enumeration items carry the model's own codes: each item's
    /// value is the code of the model's variant of that meaning, and every code has an item.
    #[test]
    fn enumeration_items_are_the_model_codes() {
        use crate::model_description::enumeration;
        use aem_model::{BelowMinimum, DispatchPolicy};
        let names = |e: crate::model_description::Enumeration| {
            e.items
                .iter()
                .map(|i| (i.name, i.value))
                .collect::<Vec<_>>()
        };
        assert_eq!(
            names(enumeration::DISPATCH),
            [
                ("equal", DispatchPolicy::Equal as i32),
                ("sequential", DispatchPolicy::Sequential as i32),
                ("rotation", DispatchPolicy::Rotation as i32),
                ("target", DispatchPolicy::Target as i32)
            ]
        );
        assert_eq!(
            names(enumeration::BELOW_MINIMUM),
            [
                ("stayAtMinimum", BelowMinimum::Minimum as i32),
                ("standby", BelowMinimum::Standby as i32),
                ("off", BelowMinimum::Off as i32)
            ]
        );
        use OperatingState::*;
        let states = [
            ("idle", Idle),
            ("starting", Curve),
            ("running", Steady),
            ("standby", Standby),
            ("stopping", Blowdown),
        ];
        assert_eq!(
            names(enumeration::OPERATING_STATE),
            states.map(|(n, s)| (n, s.code()))
        );
        for e in [enumeration::DISPATCH, enumeration::BELOW_MINIMUM] {
            for item in e.items {
                let code = i64::from(item.value);
                let accepted = if e.name == "Dispatch" {
                    DispatchPolicy::from_code(code).is_ok()
                } else {
                    BelowMinimum::from_code(code).is_ok()
                };
                assert!(
                    accepted,
                    "{}.{} = {} is a code the model accepts",
                    e.name, item.name, item.value
                );
            }
        }
        assert_eq!(
            IntegerVariable::Dispatch.enumeration(),
            Some(enumeration::DISPATCH)
        );
        assert_eq!(
            IntegerVariable::BelowMinimum.enumeration(),
            Some(enumeration::BELOW_MINIMUM)
        );
        assert_eq!(
            IntegerVariable::OperatingState.enumeration(),
            Some(enumeration::OPERATING_STATE)
        );
        assert_eq!(IntegerVariable::NModules.enumeration(), None);
        assert_eq!(
            (
                item_name(IntegerVariable::Dispatch, 2),
                item_name(IntegerVariable::Dispatch, 9)
            ),
            ("sequential", "invalid")
        );
    }

    #[test]
    fn module_parameters_have_the_model_description_names_and_units() {
        let mapped: Vec<ModuleParameter> = RealVariable::ALL
            .into_iter()
            .filter_map(module_parameter)
            .collect();
        assert_eq!(
            mapped,
            ModuleParameter::ALL,
            "every module parameter once, in the XML's order"
        );
        for var in RealVariable::ALL {
            if let Some(parameter) = module_parameter(var) {
                assert_eq!(
                    (parameter.name(), parameter.unit()),
                    (var.name(), var.unit()),
                    "{var:?}"
                );
            }
        }
    }

    /// The repository's model description carries the model's defaults (the paper's Table I
    /// and the assumed start-up values), so `aem-identify` (which knows only the model) and
    /// the FMU start from the same values. A binary built from another model description
    /// (packaging with identified parameters) has other start values on purpose.
    #[test]
    fn the_repository_start_values_are_the_model_defaults() {
        if option_env!("AEM_MODEL_DESCRIPTION").is_some_and(|path| !path.is_empty()) {
            return;
        }
        let (params, settings, inputs) = start_values();
        assert_eq!(params, Parameters::default());
        assert_eq!(settings, PlantSettings::default());
        assert_eq!(
            inputs.ambient_temperature,
            aem_model::thermal::AMBIENT_START
        );
    }

    #[test]
    fn every_variable_of_the_xml_maps_to_exactly_one_role_and_its_start_value() {
        let (params, defaults, inputs) = start_values();
        let plant = Plant::new(params, &defaults.config().unwrap(), None, 100.0, 0.0).unwrap();
        for var in RealVariable::ALL {
            let (mut p, mut s, mut i) = (params, defaults, inputs);
            let param = real_parameter_mut(&mut p, &mut s, var).map(|v| *v);
            assert_eq!(
                param.is_some(),
                var.causality() == Causality::Parameter,
                "{var:?}"
            );
            assert_eq!(
                real_output(var, &plant, 0.0).is_some(),
                var.causality() == Causality::Output,
                "{var:?}"
            );
            let input = real_input_mut(&mut i, var).map(|v| *v);
            assert_eq!(
                input.is_some(),
                var.causality() == Causality::Input,
                "{var:?}"
            );
            if var.causality() != Causality::Output {
                assert_eq!(
                    param.or(input),
                    var.start(),
                    "{var:?}: the instance's default is the XML's start"
                );
            }
        }
        for var in IntegerVariable::ALL {
            let mut s = defaults;
            let param = integer_parameter_mut(&mut s, var).map(|v| *v);
            assert_eq!(
                param.is_some(),
                var.causality() == Causality::Parameter,
                "{var:?}"
            );
            assert_eq!(
                integer_output(var, &plant).is_some(),
                var.causality() == Causality::Output,
                "{var:?}"
            );
            assert_eq!(param, var.start(), "{var:?}");
        }
        for var in StringVariable::ALL {
            let mut file = String::new();
            let param = string_parameter_mut(&mut file, var).map(|v| v.clone());
            assert_eq!(
                param.is_some(),
                var.causality() == Causality::Parameter,
                "{var:?}"
            );
            assert_eq!(param.as_deref(), var.start(), "{var:?}");
        }
        for var in BooleanVariable::ALL {
            let mut s = defaults;
            let param = boolean_parameter_mut(&mut s, var).map(|v| *v);
            assert_eq!(
                param.is_some(),
                var.causality() == Causality::Parameter,
                "{var:?}"
            );
            assert_eq!(param, var.start(), "{var:?}");
        }
    }
}
