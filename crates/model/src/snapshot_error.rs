//! Why a saved state (a [`crate::PlantSnapshot`]) cannot be restored into a plant; the plant
//! is left unchanged.

use std::fmt;

/// A snapshot that cannot belong to the plant it is restored into.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SnapshotError {
    /// A single module's state given to a hub, or the other way round.
    OtherKind,
    /// A group of `count` modules of parameter set `kind`, where the hub has `kinds` sets.
    BadGroup { count: u32, kind: u32, kinds: usize },
    /// A group's timer, current, modal states or running time is non-finite or negative.
    NonFiniteGroup,
    /// The groups do not hold exactly the hub's modules.
    ModuleCount { n_modules: u32 },
    /// The hub's totals are non-finite or its dispatch target exceeds its modules.
    TotalsOutOfRange,
    /// The modules dispatched differ from the dispatch target.
    DispatchMismatch { active: u64, target: u32 },
}

impl fmt::Display for SnapshotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SnapshotError::OtherKind => {
                write!(
                    f,
                    "the state belongs to a plant of another kind (single module or hub)"
                )
            }
            SnapshotError::BadGroup { count, kind, kinds } => {
                write!(
                    f,
                    "a group has count {count} and parameter set {kind} of {kinds}"
                )
            }
            SnapshotError::NonFiniteGroup => {
                write!(f, "a group holds a non-finite or negative value")
            }
            SnapshotError::ModuleCount { n_modules } => {
                write!(
                    f,
                    "the groups do not hold exactly the hub's {n_modules} modules"
                )
            }
            SnapshotError::TotalsOutOfRange => {
                write!(f, "the hub's totals or dispatch target are out of range")
            }
            SnapshotError::DispatchMismatch { active, target } => write!(
                f,
                "{active} modules are dispatched but the dispatch target is {target}"
            ),
        }
    }
}

impl std::error::Error for SnapshotError {}
