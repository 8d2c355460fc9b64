//! AEM electrolyser module after Omtveit, Dannappel, You and Uhlen, "A Closed-Loop Model of
//! an Anion Exchange Membrane Electrolyser Based on Operational Data" (IEEE ISGT 2026),
//! as an FMI 2.0 Co-Simulation FMU.
//!
//! The physics lives in [`model`] (safe Rust, no FMI); [`fmi2`] is the thin C ABI around it.

#![deny(unsafe_op_in_unsafe_fn)]
// `!(x > 0.0)` is used on purpose: it is true for NaN, which must be refused too.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod fmi2;
pub mod identify;
pub mod model;
pub mod model_description;
