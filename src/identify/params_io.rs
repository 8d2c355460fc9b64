//! The parameter file: the FMU's parameter names and units (from `modelDescription.xml`),
//! each value with its standard error, plus the fit statistics.
//!
//! ```json
//! { "generator": "aem-identify 0.1.0",
//!   "modules": [ { "module": "A",
//!                  "parameters": { "gain": { "value": 0.512, "unit": "A/%",
//!                                            "standardError": 0.0004, "poorlyDetermined": false,
//!                                            "source": "identified" }, … },
//!                  "statistics": { … } } ],
//!   "spread": { … } }
//! ```
//! `source` is `identified`, or `default` for parameters the data do not determine (the
//! model description's start value is kept, e.g. nominalCurrent, minSetpoint, maxSetpoint).

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::model::Parameters;
use crate::fmi2::variables::module_parameter_mut;
use crate::model_description::RealVariable;

use super::error::{Error, Result};

/// The FMU's module parameters (Table I and the operating window; not the hub's settings):
/// (name, unit) in model-description order.
pub fn fmu_parameters() -> Vec<(&'static str, &'static str)> {
    RealVariable::ALL
        .iter()
        .filter(|v| module_parameter_mut(&mut Parameters::default(), **v).is_some())
        .map(|v| (v.name(), v.unit()))
        .collect()
}

/// The module parameter called `name` (model-description name).
fn field<'a>(p: &'a mut Parameters, name: &str) -> Option<&'a mut f64> {
    RealVariable::ALL.into_iter().find(|v| v.name() == name).and_then(|v| module_parameter_mut(p, v))
}

/// Value of the module parameter called `name` (model-description name).
pub fn get(p: &Parameters, name: &str) -> Option<f64> {
    let mut p = *p;
    field(&mut p, name).map(|v| *v)
}

/// Sets the module parameter called `name`; false for an unknown name.
pub fn set(p: &mut Parameters, name: &str, value: f64) -> bool {
    match field(p, name) {
        Some(slot) => {
            *slot = value;
            true
        }
        None => false,
    }
}

/// Where a parameter value comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum Source {
    /// Fitted to the data.
    Identified,
    /// The model description's start value (or a value given on the command line).
    Default,
}

/// One parameter in the file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ParameterEntry {
    /// Value, in `unit`.
    pub value: f64,
    /// Unit: must equal the model description's.
    pub unit: String,
    /// Standard error, same unit (identified parameters).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub standard_error: Option<f64>,
    /// Relative standard error above the tool's threshold, or undetermined.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poorly_determined: Option<bool>,
    /// Identified or default.
    pub source: Source,
}

/// One module's parameter set and statistics.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ModuleEntry {
    /// Module id.
    pub module: String,
    /// Parameters by the FMU's names.
    pub parameters: BTreeMap<String, ParameterEntry>,
    /// Fit statistics (free-form, for people and scripts).
    #[serde(default)]
    pub statistics: serde_json::Value,
}

/// Spread of one parameter across modules.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Spread {
    /// Unit.
    pub unit: String,
    /// Mean over modules.
    pub mean: f64,
    /// Sample standard deviation over modules.
    pub std: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// std/|mean| [%].
    pub cv_percent: f64,
}

/// The whole parameter file.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ParameterFile {
    /// Tool and version that wrote it.
    pub generator: String,
    /// One entry per module.
    pub modules: Vec<ModuleEntry>,
    /// Spread of the identified parameters across modules (several modules only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spread: Option<BTreeMap<String, Spread>>,
}

impl ParameterFile {
    /// Reads a parameter file.
    pub fn load(path: &Path) -> Result<ParameterFile> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io { path: path.into(), message: e.to_string() })?;
        serde_json::from_str(&text).map_err(|e| Error::Content {
            path: path.into(),
            line: e.line() as u64,
            message: format!("not a parameter file: {e}"),
        })
    }

    /// The module called `id`, or the only one.
    pub fn module(&self, id: Option<&str>) -> std::result::Result<&ModuleEntry, String> {
        let ids: Vec<&str> = self.modules.iter().map(|m| m.module.as_str()).collect();
        match id {
            Some(id) => self
                .modules
                .iter()
                .find(|m| m.module == id)
                .ok_or_else(|| format!("no module `{id}` (modules: {})", ids.join(", "))),
            None if self.modules.len() == 1 => Ok(&self.modules[0]),
            None => Err(format!("{} modules (choose one with --module: {})", self.modules.len(), ids.join(", "))),
        }
    }
}

impl ModuleEntry {
    /// The model's parameters: the file's values over the model description's start values.
    /// Unknown names, wrong units and invalid sets are refused.
    pub fn parameters(&self) -> std::result::Result<Parameters, String> {
        self.parameters_over(Parameters::default())
    }

    /// The model's parameters: the file's values over `base`. Unknown names, wrong units and
    /// invalid sets are refused.
    pub fn parameters_over(&self, base: Parameters) -> std::result::Result<Parameters, String> {
        let known = fmu_parameters();
        let mut p = base;
        for (name, entry) in &self.parameters {
            let Some((_, unit)) = known.iter().find(|(n, _)| n == name) else {
                let names: Vec<&str> = known.iter().map(|(n, _)| *n).collect();
                return Err(format!("unknown parameter `{name}` (the FMU's parameters: {})", names.join(", ")));
            };
            if entry.unit != *unit {
                return Err(format!("parameter `{name}` has unit `{}`, the FMU's is `{unit}`", entry.unit));
            }
            set(&mut p, name, entry.value);
        }
        p.validate().map_err(|e| e.to_string())?;
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_fmu_parameter_has_an_accessor() {
        let mut p = Parameters::default();
        for (name, _) in fmu_parameters() {
            let v = get(&p, name).unwrap_or_else(|| panic!("no getter for {name}"));
            assert!(set(&mut p, name, v + 1.0), "no setter for {name}");
            assert_eq!(get(&p, name), Some(v + 1.0));
        }
        assert_eq!(fmu_parameters().len(), 11);
        assert!(get(&p, "current").is_none());
    }

    #[test]
    fn wrong_units_and_unknown_names_are_refused() {
        let entry = |unit: &str| ParameterEntry {
            value: 0.5,
            unit: unit.into(),
            standard_error: None,
            poorly_determined: None,
            source: Source::Identified,
        };
        let mut m = ModuleEntry { module: "a".into(), parameters: BTreeMap::new(), statistics: serde_json::Value::Null };
        m.parameters.insert("gain".into(), entry("A/%"));
        assert_eq!(m.parameters().unwrap().gain, 0.5);
        m.parameters.insert("gain".into(), entry("A"));
        assert!(m.parameters().unwrap_err().contains("unit `A`"));
        m.parameters.remove("gain");
        m.parameters.insert("gainz".into(), entry("A/%"));
        assert!(m.parameters().unwrap_err().contains("unknown parameter `gainz`"));
    }
}
