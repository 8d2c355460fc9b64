//! Errors of the identification tool; each names the file and line, or the step, it is about.

use std::fmt;
use std::path::PathBuf;

/// Why identification or validation could not proceed.
#[derive(Debug)]
pub enum Error {
    /// A file or directory could not be opened or read.
    Io { path: PathBuf, message: String },
    /// A file's content is unusable at a line (1-based), e.g. a header without a time column.
    Content {
        path: PathBuf,
        line: u64,
        message: String,
    },
    /// The data hold too little for a step, or a setting is invalid.
    Input(String),
    /// A fit did not converge or produced an invalid parameter set.
    Fit(String),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Io { path, message } => write!(f, "{}: {message}", path.display()),
            Error::Content {
                path,
                line,
                message,
            } => write!(f, "{}:{line}: {message}", path.display()),
            Error::Input(m) | Error::Fit(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for Error {}

impl From<aem_model::parameter_file::ParameterFileError> for Error {
    fn from(e: aem_model::parameter_file::ParameterFileError) -> Self {
        match e.line {
            Some(line) => Error::Content {
                path: e.path,
                line,
                message: e.message,
            },
            None => Error::Io {
                path: e.path,
                message: e.message,
            },
        }
    }
}

/// Result of the identification tool.
pub type Result<T> = std::result::Result<T, Error>;
