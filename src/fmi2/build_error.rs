//! Why the plant cannot be built from the instance's parameters, settings and inputs, and why a
//! variable has no value: typed, with the messages the log shows.

use std::fmt;
use std::path::PathBuf;

use aem_model::parameter_file::{ModuleEntryError, ParameterFileError};
use aem_model::{ParameterError, StepError};

use super::file_location::UriError;

/// A plant that cannot be built.
#[derive(Debug)]
pub enum BuildError {
    /// A parameter or setting is invalid.
    Parameter(ParameterError),
    /// `moduleParameterFile` names no local file.
    ParameterFileLocation(UriError),
    /// The parameter file cannot be read or parsed; `resources` is the folder it was also
    /// looked for in, for a relative name.
    ParameterFile {
        error: ParameterFileError,
        resources: Option<PathBuf>,
    },
    /// A module's entry in the parameter file is unusable.
    ModuleEntry {
        path: PathBuf,
        module: String,
        error: ModuleEntryError,
    },
    /// The inputs cannot be applied (the ambient temperature).
    Input(StepError),
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BuildError::Parameter(e) => write!(f, "{e}"),
            BuildError::ParameterFileLocation(e) => write!(f, "moduleParameterFile: {e}"),
            BuildError::ParameterFile {
                error,
                resources: Some(resources),
            } => write!(
                f,
                "moduleParameterFile: {error} (looked for in the resources folder {} and in the working directory)",
                resources.display()
            ),
            BuildError::ParameterFile {
                error,
                resources: None,
            } => write!(f, "moduleParameterFile: {error}"),
            BuildError::ModuleEntry {
                path,
                module,
                error,
            } => write!(
                f,
                "moduleParameterFile {}, module {module}: {error}",
                path.display()
            ),
            BuildError::Input(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for BuildError {}

impl From<ParameterError> for BuildError {
    fn from(e: ParameterError) -> Self {
        BuildError::Parameter(e)
    }
}

/// A variable without a value.
#[derive(Debug)]
pub enum ValueError {
    /// An output before the plant can be built.
    NotYet {
        name: &'static str,
        cause: Box<BuildError>,
    },
    /// The variable has no value in this role.
    NoValue { name: &'static str },
}

impl fmt::Display for ValueError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ValueError::NotYet { name, cause } => {
                write!(f, "{name} cannot be computed yet: {cause}")
            }
            ValueError::NoValue { name } => write!(f, "{name} has no value here"),
        }
    }
}

impl std::error::Error for ValueError {}
