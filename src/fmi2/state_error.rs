//! Why a serialised FMU state is refused (fmi2DeSerializeFMUstate): one variant a reason, the
//! message the importer's log shows.

use std::fmt;

use aem_model::ParameterError;

use crate::model_description::GUID;

/// A serialised state that this FMU does not take.
#[derive(Clone, Debug, PartialEq)]
pub enum StateError {
    /// The first bytes are not this FMU's magic.
    BadMagic,
    /// Another format version than the one this FMU reads.
    Version { found: u32, reads: u32 },
    /// The byte count differs from the header's.
    Length { actual: usize, announced: usize },
    /// No room for the checksum.
    TruncatedChecksum,
    /// The CRC-32 does not match.
    Checksum,
    /// The GUID is another model's.
    OtherModel,
    /// Fewer bytes than a field needs (`what`: the field, where it says more).
    Truncated(Option<&'static str>),
    /// An unknown FMI state code.
    UnknownFmiState,
    /// A flag byte other than 0 or 1.
    InvalidFlag(u8),
    /// A NaN or infinite number at this byte.
    NonFinite(usize),
    /// The module parameter file's name is not UTF-8.
    FileNameNotUtf8,
    /// An unknown FFR state code.
    UnknownFfrState(u8),
    /// An unknown plant kind.
    UnknownPlantKind(u8),
    /// An unknown operating state code of a hub's group.
    UnknownOperatingState(u8),
    /// Bytes after the last field.
    TrailingBytes,
    /// Parameters the model refuses.
    InvalidParameters(ParameterError),
    /// Settings the model refuses.
    InvalidSettings(ParameterError),
}

impl fmt::Display for StateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use StateError::*;
        match self {
            BadMagic => write!(f, "not a serialised state of this FMU (bad magic)"),
            Version { found, reads } => write!(
                f,
                "serialised state has format version {found}; this FMU reads version {reads}"
            ),
            Length { actual, announced } => write!(
                f,
                "serialised state is {actual} bytes; its header announces {announced}"
            ),
            TruncatedChecksum => write!(f, "truncated checksum"),
            Checksum => write!(f, "serialised state is corrupt (checksum mismatch)"),
            OtherModel => write!(
                f,
                "serialised state belongs to another model (GUID differs from {GUID})"
            ),
            Truncated(None) => write!(f, "serialised state is truncated"),
            Truncated(Some(what)) => write!(f, "serialised state is truncated ({what})"),
            UnknownFmiState => write!(f, "serialised state has an unknown FMI state"),
            InvalidFlag(b) => write!(f, "serialised state has an invalid flag {b}"),
            NonFinite(at) => write!(f, "serialised state holds a non-finite value at byte {at}"),
            FileNameNotUtf8 => write!(f, "serialised state holds a file name that is not UTF-8"),
            UnknownFfrState(c) => write!(f, "serialised state has an unknown FFR state {c}"),
            UnknownPlantKind(c) => write!(f, "serialised state has an unknown plant kind {c}"),
            UnknownOperatingState(c) => {
                write!(f, "serialised state has an unknown operating state {c}")
            }
            TrailingBytes => write!(f, "serialised state has trailing bytes"),
            InvalidParameters(e) => write!(f, "serialised state holds invalid parameters: {e}"),
            InvalidSettings(e) => write!(f, "serialised state holds invalid settings: {e}"),
        }
    }
}

impl std::error::Error for StateError {}

impl From<StateError> for String {
    fn from(e: StateError) -> String {
        e.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_reason_reads_as_a_sentence_about_the_state() {
        assert_eq!(
            StateError::Truncated(Some("hub groups")).to_string(),
            "serialised state is truncated (hub groups)"
        );
        assert_eq!(
            StateError::Length {
                actual: 10,
                announced: 11
            }
            .to_string(),
            "serialised state is 10 bytes; its header announces 11"
        );
        assert_eq!(
            StateError::Version { found: 2, reads: 8 }.to_string(),
            "serialised state has format version 2; this FMU reads version 8"
        );
        let e = ParameterError {
            name: "gain",
            value: 0.0,
            requirement: "must be > 0".into(),
        };
        assert!(StateError::InvalidParameters(e)
            .to_string()
            .starts_with("serialised state holds invalid parameters: "));
    }
}
