//! The root crate's integration tests, one binary (one build and one link instead of four):
//!
//! - `c_abi`: the FMI 2.0 C interface called in process;
//! - `fmu_import`: the packaged `.fmu` through the `fmi` crate;
//! - `fuzz_call_sequences`: random call sequences against a reference state machine;
//! - `workspace_layout`: the workspace's dependencies point one way.
//!
//! One group: `cargo test --test integration c_abi`. (tests/robustness_report.rs is a binary of
//! its own: it installs its own `log` logger, and a process has one.)

mod c_abi;
mod fmu_import;
mod fuzz_call_sequences;
mod workspace_layout;
