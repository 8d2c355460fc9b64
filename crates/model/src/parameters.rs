//! Parameters of one AEM electrolyser module (the paper's Table I), their validation, and
//! their names and units ([`ModuleParameter`]) as the FMU and the parameter files spell them.

use std::fmt;

use super::select::clamped;

/// Parameters of one module.
///
/// Defaults are the paper's Table I (nominal 55 °C and 29 bar); see [`Parameters::default`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Parameters {
    /// K: stack current per % of hydrogen-production setpoint [A/%].
    pub gain: f64,
    /// τz: time constant of the zero [s].
    pub tau_zero: f64,
    /// τp1: first pole time constant [s].
    pub tau_pole1: f64,
    /// τp2: second pole time constant [s].
    pub tau_pole2: f64,
    /// r: largest rate of rise of the stack current [A/s]; falling current is not limited.
    pub ramp_up_limit: f64,
    /// V0: polarisation-curve intercept, V = V0 + R·I [V].
    pub voltage_intercept: f64,
    /// R: ohmic resistance of the polarisation curve [Ω].
    pub ohmic_resistance: f64,
    /// c: hydrogen production per ampere, flow = c·I [Nl/(h·A)].
    pub h2_coefficient: f64,
    /// Nominal stack current [A] (the vendor's rating; informational for one module).
    pub nominal_current: f64,
    /// Lowest allowed setpoint while running [%].
    pub min_setpoint: f64,
    /// Highest allowed setpoint [%].
    pub max_setpoint: f64,
}

/// Smallest relative separation of the two pole time constants that the modal
/// (partial-fraction) solution accepts; closer poles lose more than 1e-10 relative accuracy.
pub const MIN_RELATIVE_POLE_SEPARATION: f64 = 1e-6;

/// A parameter set that cannot describe a module; the message names the value.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterError {
    /// Name of the offending parameter as in the model description.
    pub name: &'static str,
    /// Its value.
    pub value: f64,
    /// What is required of it.
    pub requirement: String,
}

impl fmt::Display for ParameterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "parameter {} = {} is invalid: {}",
            self.name,
            super::shown(self.value),
            self.requirement
        )
    }
}

impl std::error::Error for ParameterError {}

impl Default for Parameters {
    /// The paper's Table I and its 60…100 % operating window (the FMU's model description
    /// carries the same start values; tests check both against tests/data/table_i.json).
    fn default() -> Self {
        Parameters {
            gain: 0.534,
            tau_zero: 95.371,
            tau_pole1: 1.995,
            tau_pole2: 113.568,
            ramp_up_limit: 0.22,
            voltage_intercept: 35.75,
            ohmic_resistance: 0.1529,
            h2_coefficient: 9.6174,
            nominal_current: 53.35,
            min_setpoint: 60.0,
            max_setpoint: 100.0,
        }
    }
}

/// One field of [`Parameters`], named as in the FMU's model description and in parameter
/// files: the one map from a parameter's name to its place, shared by the FMU and the
/// identification.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ModuleParameter {
    Gain,
    TauZero,
    TauPole1,
    TauPole2,
    RampUpLimit,
    VoltageIntercept,
    OhmicResistance,
    H2Coefficient,
    NominalCurrent,
    MinSetpoint,
    MaxSetpoint,
}

impl ModuleParameter {
    /// Every module parameter, in the model description's order.
    pub const ALL: [ModuleParameter; 11] = {
        use ModuleParameter::*;
        [
            Gain,
            TauZero,
            TauPole1,
            TauPole2,
            RampUpLimit,
            VoltageIntercept,
            OhmicResistance,
            H2Coefficient,
            NominalCurrent,
            MinSetpoint,
            MaxSetpoint,
        ]
    };

    /// The name (model description, parameter files).
    pub fn name(self) -> &'static str {
        use ModuleParameter::*;
        match self {
            Gain => "gain",
            TauZero => "tauZero",
            TauPole1 => "tauPole1",
            TauPole2 => "tauPole2",
            RampUpLimit => "rampUpLimit",
            VoltageIntercept => "voltageIntercept",
            OhmicResistance => "ohmicResistance",
            H2Coefficient => "h2Coefficient",
            NominalCurrent => "nominalCurrent",
            MinSetpoint => "minSetpoint",
            MaxSetpoint => "maxSetpoint",
        }
    }

    /// The unit, spelt as in the model description's unit definitions.
    pub fn unit(self) -> &'static str {
        use ModuleParameter::*;
        match self {
            Gain => "A/%",
            TauZero | TauPole1 | TauPole2 => "s",
            RampUpLimit => "A/s",
            VoltageIntercept => "V",
            OhmicResistance => "Ohm",
            H2Coefficient => "Nl/(h.A)",
            NominalCurrent => "A",
            MinSetpoint | MaxSetpoint => "%",
        }
    }

    /// The parameter called `name`, if there is one.
    pub fn from_name(name: &str) -> Option<ModuleParameter> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }
}

impl Parameters {
    /// The field behind `parameter`, in its unit.
    pub fn field_mut(&mut self, parameter: ModuleParameter) -> &mut f64 {
        use ModuleParameter::*;
        match parameter {
            Gain => &mut self.gain,
            TauZero => &mut self.tau_zero,
            TauPole1 => &mut self.tau_pole1,
            TauPole2 => &mut self.tau_pole2,
            RampUpLimit => &mut self.ramp_up_limit,
            VoltageIntercept => &mut self.voltage_intercept,
            OhmicResistance => &mut self.ohmic_resistance,
            H2Coefficient => &mut self.h2_coefficient,
            NominalCurrent => &mut self.nominal_current,
            MinSetpoint => &mut self.min_setpoint,
            MaxSetpoint => &mut self.max_setpoint,
        }
    }

    /// The value of `parameter`, in its unit.
    pub fn get(&self, parameter: ModuleParameter) -> f64 {
        let mut copy = *self;
        *copy.field_mut(parameter)
    }

    /// Checks that the set describes a module the model can simulate.
    pub fn validate(&self) -> Result<(), ParameterError> {
        for parameter in ModuleParameter::ALL {
            let value = self.get(parameter);
            if !value.is_finite() {
                return Err(err(parameter.name(), value, "must be a finite number"));
            }
        }
        positive("gain", self.gain)?;
        non_negative("tauZero", self.tau_zero)?;
        positive("tauPole1", self.tau_pole1)?;
        positive("tauPole2", self.tau_pole2)?;
        positive("rampUpLimit", self.ramp_up_limit)?;
        non_negative("voltageIntercept", self.voltage_intercept)?;
        non_negative("ohmicResistance", self.ohmic_resistance)?;
        non_negative("h2Coefficient", self.h2_coefficient)?;
        positive("nominalCurrent", self.nominal_current)?;
        non_negative("minSetpoint", self.min_setpoint)?;
        positive("maxSetpoint", self.max_setpoint)?;
        if self.min_setpoint > self.max_setpoint {
            return Err(err(
                "minSetpoint",
                self.min_setpoint,
                &format!("must not exceed maxSetpoint = {}", self.max_setpoint),
            ));
        }
        // Largest steady operating point: its power and hydrogen flow must be representable.
        let current = self.gain * self.max_setpoint;
        let power = (self.voltage_intercept + self.ohmic_resistance * current) * current;
        if !(power.is_finite() && (self.h2_coefficient * current).is_finite()) {
            return Err(err(
                "gain",
                self.gain,
                "with maxSetpoint, voltageIntercept, ohmicResistance and h2Coefficient gives a non-finite power or hydrogen flow",
            ));
        }
        let separation = (self.tau_pole1 - self.tau_pole2).abs();
        if separation < MIN_RELATIVE_POLE_SEPARATION * self.tau_pole1.max(self.tau_pole2) {
            return Err(err(
                "tauPole2",
                self.tau_pole2,
                &format!(
                    "must differ from tauPole1 = {} by at least {} relative (double poles are not supported)",
                    self.tau_pole1, MIN_RELATIVE_POLE_SEPARATION
                ),
            ));
        }
        // The exact integrals of I² scale with a²·τp1 and b²·τp2 (the modal weights) times the
        // squared current, which must stay representable.
        let (t1, t2) = (self.tau_pole1, self.tau_pole2);
        let (a, b) = self.modal_weights();
        let i2 = current * current;
        if !((a * a * t1 * i2).is_finite()
            && (b * b * t2 * i2).is_finite()
            && (a * b * t1 * i2).is_finite())
        {
            return Err(err(
                "tauZero",
                self.tau_zero,
                &format!("with tauPole1 = {t1} s and tauPole2 = {t2} s gives modal weights too large to integrate"),
            ));
        }
        Ok(())
    }

    /// Steady-state stack current at a setpoint: I = K·setpoint [A].
    pub fn steady_current(&self, setpoint_percent: f64) -> f64 {
        self.gain * setpoint_percent
    }

    /// Setpoint limited to the operating window [minSetpoint, maxSetpoint] [%].
    pub fn clamp_setpoint(&self, setpoint_percent: f64) -> f64 {
        clamped(setpoint_percent, self.min_setpoint, self.max_setpoint)
    }

    /// The weights (a, b) of G(s) in modal form, the one place they are computed:
    ///   G(s) = K·(a/(τp1 s + 1) + b/(τp2 s + 1)),  a = (τz − τp1)/(τp2 − τp1),
    ///   b = (τp2 − τz)/(τp2 − τp1)  (a + b = 1) [1].
    pub fn modal_weights(&self) -> (f64, f64) {
        let (t1, t2, tz) = (self.tau_pole1, self.tau_pole2, self.tau_zero);
        ((tz - t1) / (t2 - t1), (t2 - tz) / (t2 - t1))
    }

    /// Where the reserve control may put the transfer function's zero [s]: between the two
    /// poles, [min(τp1, τp2), max(τp1, τp2)] (the step response is monotone there).
    pub fn filter_zero_range(&self) -> (f64, f64) {
        let (t1, t2) = (self.tau_pole1, self.tau_pole2);
        (t1.min(t2), t1.max(t2))
    }

    /// ∂a/∂τz, ∂a/∂τp1, ∂a/∂τp2 of the fast mode's weight a [1/s]:
    ///   1/(τp2 − τp1),  (τz − τp2)/(τp2 − τp1)²,  −(τz − τp1)/(τp2 − τp1)².
    pub fn modal_weight_sensitivities(&self) -> (f64, f64, f64) {
        let (t1, t2, tz) = (self.tau_pole1, self.tau_pole2, self.tau_zero);
        let d = t2 - t1;
        (1.0 / d, (tz - t2) / (d * d), -(tz - t1) / (d * d))
    }
}

fn err(name: &'static str, value: f64, requirement: &str) -> ParameterError {
    ParameterError {
        name,
        value,
        requirement: requirement.to_string(),
    }
}

fn positive(name: &'static str, value: f64) -> Result<(), ParameterError> {
    if value > 0.0 {
        Ok(())
    } else {
        Err(err(name, value, "must be > 0"))
    }
}

fn non_negative(name: &'static str, value: f64) -> Result<(), ParameterError> {
    if value >= 0.0 {
        Ok(())
    } else {
        Err(err(name, value, "must be >= 0"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_values_are_valid_and_give_the_sanity_figures() {
        let p = Parameters::default();
        assert_eq!(p.validate(), Ok(()));
        assert!((p.steady_current(100.0) - 53.4).abs() < 1e-12);
    }

    /// The defaults are the paper's values as tests/data/table_i.json records them (the one
    /// copy of Table I the tests read; the model keeps its literals, the file checks them).
    #[test]
    fn defaults_are_the_papers_table_i() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/table_i.json");
        let text =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let rows: Vec<serde_json::Value> = serde_json::from_str(&text).expect("a JSON array");
        let defaults = Parameters::default();
        let mut named = Vec::new();
        for row in &rows {
            let name = row["name"].as_str().expect("a name");
            let parameter = ModuleParameter::from_name(name)
                .unwrap_or_else(|| panic!("{name} is not a module parameter"));
            assert_eq!(
                defaults.get(parameter),
                row["value"].as_f64().expect("a value"),
                "{name}"
            );
            assert_eq!(row["unit"].as_str(), Some(parameter.unit()), "{name}");
            named.push(parameter);
        }
        assert_eq!(
            named,
            ModuleParameter::ALL,
            "every parameter once, in order"
        );
    }

    #[test]
    fn every_parameter_has_its_own_field_and_name() {
        let mut p = Parameters::default();
        for (k, parameter) in ModuleParameter::ALL.into_iter().enumerate() {
            *p.field_mut(parameter) = k as f64 + 0.5;
            assert_eq!(
                ModuleParameter::from_name(parameter.name()),
                Some(parameter)
            );
        }
        // Eleven distinct fields: each got its own value.
        for (k, parameter) in ModuleParameter::ALL.into_iter().enumerate() {
            assert_eq!(p.get(parameter), k as f64 + 0.5, "{parameter:?}");
        }
        assert_eq!(ModuleParameter::from_name("current"), None);
    }

    #[test]
    fn each_invalid_value_is_named() {
        let cases: [(fn(&mut Parameters), &str); 9] = [
            (|p| p.tau_pole1 = -1.0, "tauPole1"),
            (|p| p.tau_zero = -0.5, "tauZero"),
            (|p| p.gain = 0.0, "gain"),
            (|p| p.ramp_up_limit = f64::NAN, "rampUpLimit"),
            (|p| p.min_setpoint = 101.0, "minSetpoint"),
            (|p| p.tau_pole2 = p.tau_pole1, "tauPole2"),
            (|p| p.ohmic_resistance = -0.1, "ohmicResistance"),
            (|p| p.nominal_current = f64::INFINITY, "nominalCurrent"),
            (|p| p.gain = 1e200, "gain"),
        ];
        for (mutate, name) in cases {
            let mut p = Parameters::default();
            mutate(&mut p);
            let e = p.validate().expect_err(name);
            assert_eq!(e.name, name);
            assert!(e.to_string().contains(name));
        }
    }
}
