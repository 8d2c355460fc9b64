//! The FMI 2.0 co-simulation layer: the only unsafe code of the crate.
//!
//! - `exports`: the 34 C functions; catch panics, check pointers and the call sequence.
//! - `state_machine`: which call is allowed in which state (one table).
//! - `instance`: FMI semantics on top of [`aem_model::Module`], in safe Rust.
//! - `variables`: model description variables ↔ model fields (exhaustive matches).
//! - `build_error`: why the plant cannot be built or a variable has no value.
//! - `fmu_state`: saved and serialised FMU states; `state_error`: why a serialised one is refused.
//! - `file_location`: `file:` URIs and paths of the master (Windows drive letters, UNC).
//! - `logger`, `status`: the importer's logger and fmi2Status.

pub mod build_error;
pub mod exports;
pub mod file_location;
pub mod fmu_state;
pub mod instance;
pub mod logger;
pub mod state_error;
pub mod state_machine;
pub mod status;
pub mod variables;
