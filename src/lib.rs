//! AEM electrolyser module after Omtveit, Dannappel, You and Uhlen, "A Closed-Loop Model of
//! an Anion Exchange Membrane Electrolyser Based on Operational Data" (IEEE ISGT 2026),
//! as an FMI 2.0 Co-Simulation FMU.
//!
//! The physics lives in [`model`] (safe Rust, no FMI); [`fmi2`] is the thin C ABI around it.

#![deny(unsafe_op_in_unsafe_fn)]

pub mod fmi2;
pub mod identify;
pub mod model;
pub mod model_description;
