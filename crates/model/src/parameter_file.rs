//! The parameter file: per-module parameter sets by the FMU's parameter names and units
//! ([`ModuleParameter`]), each value with its standard error, plus the fit statistics.
//! `aem-identify` writes it; the FMU's `moduleParameterFile` reads it.
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
//! default value is kept, e.g. nominalCurrent, minSetpoint, maxSetpoint).

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::{ModuleParameter, ParameterError, Parameters};

/// A parameter file that cannot be read; shown as `path: message` or `path:line: message`.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterFileError {
    /// The file.
    pub path: PathBuf,
    /// The line (1-based) where its content is wrong, or None if it could not be read.
    pub line: Option<u64>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ParameterFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{line}: {}", self.path.display(), self.message),
            None => write!(f, "{}: {}", self.path.display(), self.message),
        }
    }
}

impl std::error::Error for ParameterFileError {}

/// A module that cannot be chosen from a parameter file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ModuleChoiceError {
    /// No module of that id; `ids` are the file's.
    NoSuchModule { id: String, ids: Vec<String> },
    /// None named and the file has several.
    Ambiguous { ids: Vec<String> },
}

impl fmt::Display for ModuleChoiceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ModuleChoiceError::NoSuchModule { id, ids } => {
                write!(f, "no module `{id}` (modules: {})", ids.join(", "))
            }
            ModuleChoiceError::Ambiguous { ids } => write!(
                f,
                "{} modules (choose one with --module: {})",
                ids.len(),
                ids.join(", ")
            ),
        }
    }
}

impl std::error::Error for ModuleChoiceError {}

/// A module's entry whose parameters the model refuses.
#[derive(Clone, Debug, PartialEq)]
pub enum ModuleEntryError {
    /// A name that is none of the FMU's parameters.
    UnknownParameter { name: String },
    /// A parameter given in another unit than the FMU's.
    WrongUnit {
        name: String,
        unit: String,
        expected: &'static str,
    },
    /// The values, over their base, are not a valid parameter set.
    Invalid(ParameterError),
}

impl fmt::Display for ModuleEntryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ModuleEntryError::UnknownParameter { name } => {
                let names: Vec<&str> = ModuleParameter::ALL.iter().map(|p| p.name()).collect();
                write!(
                    f,
                    "unknown parameter `{name}` (the FMU's parameters: {})",
                    names.join(", ")
                )
            }
            ModuleEntryError::WrongUnit {
                name,
                unit,
                expected,
            } => write!(
                f,
                "parameter `{name}` has unit `{unit}`, the FMU's is `{expected}`"
            ),
            ModuleEntryError::Invalid(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for ModuleEntryError {}

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
    pub fn load(path: &Path) -> Result<ParameterFile, ParameterFileError> {
        let text = std::fs::read(path).map_err(|e| ParameterFileError {
            path: path.into(),
            line: None,
            message: e.to_string(),
        })?;
        ParameterFile::parse(&text, path)
    }

    /// Parses the bytes of a parameter file; `path` names it in the error.
    pub fn parse(bytes: &[u8], path: &Path) -> Result<ParameterFile, ParameterFileError> {
        serde_json::from_slice(bytes).map_err(|e| ParameterFileError {
            path: path.into(),
            line: Some(e.line() as u64),
            message: format!("not a parameter file: {e}"),
        })
    }

    /// The module called `id`, or the only one.
    pub fn module(&self, id: Option<&str>) -> Result<&ModuleEntry, ModuleChoiceError> {
        let ids = || self.modules.iter().map(|m| m.module.clone()).collect();
        match id {
            Some(id) => self.modules.iter().find(|m| m.module == id).ok_or_else(|| {
                ModuleChoiceError::NoSuchModule {
                    id: id.into(),
                    ids: ids(),
                }
            }),
            None if self.modules.len() == 1 => Ok(&self.modules[0]),
            None => Err(ModuleChoiceError::Ambiguous { ids: ids() }),
        }
    }
}

impl ModuleEntry {
    /// The model's parameters: the file's values over the defaults (Table I).
    /// Unknown names, wrong units and invalid sets are refused.
    pub fn parameters(&self) -> Result<Parameters, ModuleEntryError> {
        self.parameters_over(Parameters::default())
    }

    /// The model's parameters: the file's values over `base`. Unknown names, wrong units and
    /// invalid sets are refused.
    pub fn parameters_over(&self, base: Parameters) -> Result<Parameters, ModuleEntryError> {
        let mut p = base;
        for (name, entry) in &self.parameters {
            let Some(parameter) = ModuleParameter::from_name(name) else {
                return Err(ModuleEntryError::UnknownParameter { name: name.clone() });
            };
            if entry.unit != parameter.unit() {
                return Err(ModuleEntryError::WrongUnit {
                    name: name.clone(),
                    unit: entry.unit.clone(),
                    expected: parameter.unit(),
                });
            }
            *p.field_mut(parameter) = entry.value;
        }
        p.validate().map_err(ModuleEntryError::Invalid)?;
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_that_is_not_a_parameter_file_names_its_line() {
        let dir =
            std::env::temp_dir().join(format!("aem-model-parameter-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("bad.json");
        std::fs::write(&path, "{\n  \"generator\": \"x\",\n  \"modules\": 3\n}\n").unwrap();
        let e = ParameterFile::load(&path).unwrap_err();
        assert_eq!(e.line, Some(3), "{e}");
        assert!(
            e.to_string()
                .starts_with(&format!("{}:3: not a parameter file", path.display())),
            "{e}"
        );
        let missing = ParameterFile::load(&dir.join("missing.json")).unwrap_err();
        assert_eq!(missing.line, None);
        std::fs::remove_dir_all(&dir).unwrap();
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
        let mut m = ModuleEntry {
            module: "a".into(),
            parameters: BTreeMap::new(),
            statistics: serde_json::Value::Null,
        };
        m.parameters.insert("gain".into(), entry("A/%"));
        assert_eq!(m.parameters().unwrap().gain, 0.5);
        m.parameters.insert("gain".into(), entry("A"));
        let wrong = m.parameters().unwrap_err();
        assert_eq!(
            wrong,
            ModuleEntryError::WrongUnit {
                name: "gain".into(),
                unit: "A".into(),
                expected: "A/%"
            }
        );
        assert!(wrong.to_string().contains("unit `A`"), "{wrong}");
        m.parameters.remove("gain");
        m.parameters.insert("gainz".into(), entry("A/%"));
        let unknown = m.parameters().unwrap_err().to_string();
        assert!(unknown.contains("unknown parameter `gainz`"), "{unknown}");
    }
}
