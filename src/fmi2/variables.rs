//! Maps each variable of the model description to the model. The matches are exhaustive
//! over the generated [`RealVariable`], so the XML and this code cannot drift apart.

use crate::model::{Module, Parameters};
use crate::model_description::RealVariable;

/// The parameter field behind `var`, or None if `var` is not a parameter.
pub fn parameter_mut(params: &mut Parameters, var: RealVariable) -> Option<&mut f64> {
    use RealVariable::*;
    match var {
        Gain => Some(&mut params.gain),
        TauZero => Some(&mut params.tau_zero),
        TauPole1 => Some(&mut params.tau_pole1),
        TauPole2 => Some(&mut params.tau_pole2),
        RampUpLimit => Some(&mut params.ramp_up_limit),
        VoltageIntercept => Some(&mut params.voltage_intercept),
        OhmicResistance => Some(&mut params.ohmic_resistance),
        H2Coefficient => Some(&mut params.h2_coefficient),
        NominalCurrent => Some(&mut params.nominal_current),
        MinSetpoint => Some(&mut params.min_setpoint),
        MaxSetpoint => Some(&mut params.max_setpoint),
        Setpoint | Current | Voltage | Power | H2Flow | Energy | H2Produced => None,
    }
}

/// The input field behind `var` (given the instance's setpoint), or None if `var` is not an
/// input. Exhaustive like the others, so a second input in the XML cannot alias this one.
pub fn input_mut(setpoint: &mut f64, var: RealVariable) -> Option<&mut f64> {
    use RealVariable::*;
    match var {
        Setpoint => Some(setpoint),
        Current | Voltage | Power | H2Flow | Energy | H2Produced | Gain | TauZero | TauPole1 | TauPole2
        | RampUpLimit | VoltageIntercept | OhmicResistance | H2Coefficient | NominalCurrent | MinSetpoint
        | MaxSetpoint => None,
    }
}

/// The value of output `var` of `module`, or None if `var` is not an output.
pub fn output(var: RealVariable, module: &Module) -> Option<f64> {
    use RealVariable::*;
    match var {
        Current => Some(module.current()),
        Voltage => Some(module.voltage()),
        Power => Some(module.power()),
        H2Flow => Some(module.h2_flow()),
        Energy => Some(module.energy()),
        H2Produced => Some(module.h2_produced()),
        Setpoint | Gain | TauZero | TauPole1 | TauPole2 | RampUpLimit | VoltageIntercept | OhmicResistance
        | H2Coefficient | NominalCurrent | MinSetpoint | MaxSetpoint => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model_description::Causality;

    #[test]
    fn every_variable_of_the_xml_maps_to_exactly_one_role() {
        let m = Module::new(Parameters::default(), 100.0).unwrap();
        for var in RealVariable::ALL {
            let mut p = Parameters::default();
            let is_param = parameter_mut(&mut p, var).is_some();
            assert_eq!(is_param, var.causality() == Causality::Parameter, "{var:?}");
            assert_eq!(output(var, &m).is_some(), var.causality() == Causality::Output, "{var:?}");
            assert_eq!(input_mut(&mut 0.0, var).is_some(), var.causality() == Causality::Input, "{var:?}");
            if is_param {
                assert_eq!(parameter_mut(&mut p, var).map(|v| *v), var.start(), "{var:?}");
            }
        }
    }
}
