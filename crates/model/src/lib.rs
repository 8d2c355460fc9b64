//! The AEM electrolyser model after Omtveit, Dannappel, You and Uhlen, "A Closed-Loop Model
//! of an Anion Exchange Membrane Electrolyser Based on Operational Data" (IEEE ISGT 2026), in
//! plain safe Rust with no knowledge of FMI, command lines or CSV.
//!
//! Dependencies point here: the FMU (`aem-electrolyser-fmu`, the C ABI) and the identification
//! (`aem-identify`) both use this crate; it uses neither.
//!
//! - [`parameters`]: Table I of the paper and its validation.
//! - [`dynamics`]: setpoint → stack current, G(s) with a rising-rate limit, exact steps.
//! - [`module`]: one running module: polarisation curve, power, hydrogen, integrals.
//! - [`hub`]: N modules simulated as groups; [`dispatch`]: who runs at which setpoint;
//!   [`lanes`]: modules with parameters of their own, stepped four at a time.
//! - [`spread`]: seeded per-module parameter sets.
//! - [`thermal`]: the stack temperature (optional): heat balance, thermostat, exact or
//!   error-controlled steps.
//! - [`grid`]: the supply's losses and the auxiliaries (optional): what the grid sees.
//! - [`operation`]: a module's operating states (idle, curve, steady, standby, blowdown).
//! - [`plant`]: what an FMU instance simulates: one module or a hub, with its settings;
//!   [`events`]: what it reports while it runs (window excursions, reserve shortfalls).
//! - [`parameter_file`]: the JSON file of per-module parameter sets that `aem-identify`
//!   writes and the FMU reads.

#![deny(unsafe_op_in_unsafe_fn)]
// `!(x > 0.0)` is used on purpose: it is true for NaN, which must be refused too.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod ageing;
mod current_path;
pub mod dispatch;
pub mod dynamics;
pub mod events;
pub mod grid;
pub mod hub;
pub mod lanes;
pub mod module;
pub mod operation;
pub mod parameter_file;
pub mod parameters;
pub mod plant;
pub mod reserve;
mod roots;
mod select;
mod snapshot_error;
pub mod spread;
pub mod thermal;

pub use ageing::{AgeingParameters, Drift};
pub use dispatch::{Demand, DispatchPolicy};
pub use dynamics::{CurrentDynamics, CurrentIntegrals, CurrentState, StepFactors};
pub use events::{EventState, PlantEvent};
pub use grid::GridParameters;
pub use hub::{Hub, HubConfig};
pub use module::{Module, ModuleState, StepError};
pub use operation::{BelowMinimum, OperatingState, OperationParameters};
pub use parameters::{ModuleParameter, ParameterError, Parameters};
pub use plant::{Plant, PlantConfig, PlantSettings, PlantSnapshot, ReserveStep};
pub use reserve::{FastReserve, FrequencyResponse, ReserveSettings};
pub use snapshot_error::SnapshotError;
pub use thermal::{HeatBalance, ThermalParameters};

/// A number for messages: plain where that is short, scientific otherwise (1e306, not 307 digits).
pub fn shown(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e15).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}
