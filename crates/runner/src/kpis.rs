//! The scenario's KPIs, accumulated step by step from the FMU's exact energy integral.
//!
//! Over step k the reference r_k [W] is held; the hub draws ΔE_k [J] from the grid (difference
//! of the FMU's `hubAcEnergy`, its exact integral over the step: the electric energy with the
//! supply's losses and the auxiliaries, equal to `hubEnergy` without them), so its step-mean
//! power is p_k = ΔE_k / h.
//! Wind not absorbed = Σ max(r_k h − ΔE_k, 0), grid import = Σ max(ΔE_k − r_k h, 0) (net per
//! step); tracking error e_k = p_k − min(r_k, P_rated), RMS over the steps, on the side the
//! reference means (the stacks' `hubEnergy` unless gridSideReference, with P_rated on that
//! side too).

use serde_json::{Map, Value};

const J_PER_MWH: f64 = 3.6e9;

/// Version of these definitions; aem-study keys stored results with it (aem_electrolyser.study.definition's
/// KPI_VERSION must equal it, which the worker checks), so changed definitions rerun.
pub const KPI_VERSION: u32 = 3;

/// Running sums over the steps of a power-driven run.
#[derive(Debug, Default, Clone)]
pub struct Sums {
    steps: u64,
    reference: f64,
    not_absorbed: f64,
    imported: f64,
    squared_error: f64,
}

impl Sums {
    /// One step of `h` [s] with reference `reference` [W] in which the hub drew `drawn` [J]
    /// from the grid and `followed` [J] on the side the reference means; `rated` [W] (that
    /// side's) caps the reference for the tracking error.
    pub fn add(&mut self, reference: f64, drawn: f64, followed: f64, h: f64, rated: f64) {
        let offered = reference * h;
        self.steps += 1;
        self.reference += offered;
        self.not_absorbed += (offered - drawn).max(0.0);
        self.imported += (drawn - offered).max(0.0);
        let error = followed / h - reference.min(rated);
        self.squared_error += error * error;
    }
}

/// What the FMU reports at the end of the run, all since the start.
#[derive(Debug, Clone, Copy)]
pub struct Totals {
    pub modules: i32,
    /// One module's steady power at maxSetpoint [W].
    pub module_rated_power: f64,
    pub horizon: f64,
    /// hubEnergy [J]: the electric energy (stack, start-up and standby).
    pub energy: f64,
    /// hubAcEnergy [J]: what the grid delivered (with the supply's losses and auxiliaries).
    pub grid_energy: f64,
    /// The reference and the rated power mean grid power (gridSideReference).
    pub grid_side: bool,
    /// hubH2Produced [kg] (converted with the model description's display unit).
    pub hydrogen: f64,
    pub starts: f64,
    /// warmStarts: of the starts, the warm ones.
    pub warm_starts: f64,
    /// runningHours [h], summed over the modules.
    pub running_hours: f64,
    /// voltageDrift and maxVoltageDrift at the end [V]: the mean over the modules, the largest.
    pub voltage_drift: f64,
    pub max_voltage_drift: f64,
}

/// The KPI row, keys with units (the columns of aem_electrolyser.study.kpis). `sums` is None for a
/// setpoint-driven run (no power reference: the wind KPIs are null).
pub fn row(totals: &Totals, sums: Option<&Sums>) -> Map<String, Value> {
    let modules = f64::from(totals.modules);
    let rated = modules * totals.module_rated_power;
    let energy_mwh = totals.energy / J_PER_MWH;
    let grid_mwh = totals.grid_energy / J_PER_MWH;
    let wind = |f: fn(&Sums) -> f64| sums.map_or(Value::Null, |s| number(f(s)));
    let mut row = Map::new();
    let mut put = |key: &str, value: Value| {
        row.insert(key.to_string(), value);
    };
    put("modules [1]", Value::from(totals.modules));
    put("hub rated power [MW]", number(rated / 1e6));
    put("horizon [h]", number(totals.horizon / 3600.0));
    put("reference energy [MWh]", wind(|s| s.reference / J_PER_MWH));
    put("energy drawn [MWh]", number(energy_mwh));
    put("hydrogen [kg]", number(totals.hydrogen));
    put(
        "specific energy [kWh/kg]",
        number(energy_mwh * 1e3 / totals.hydrogen),
    );
    put("grid energy [MWh]", number(grid_mwh));
    put(
        "supply losses and auxiliaries [MWh]",
        number(grid_mwh - energy_mwh),
    );
    put(
        "specific energy, grid side [kWh/kg]",
        number(grid_mwh * 1e3 / totals.hydrogen),
    );
    put(
        "wind not absorbed [MWh]",
        wind(|s| s.not_absorbed / J_PER_MWH),
    );
    put("grid import [MWh]", wind(|s| s.imported / J_PER_MWH));
    put(
        "full-load hours [h]",
        number(
            if totals.grid_side {
                totals.grid_energy
            } else {
                totals.energy
            } / 3600.0
                / rated,
        ),
    );
    put("starts per module [1]", number(totals.starts / modules));
    put(
        "warm starts per module [1]",
        number(totals.warm_starts / modules),
    );
    put(
        "cold starts per module [1]",
        number((totals.starts - totals.warm_starts) / modules),
    );
    put(
        "running hours per module [h]",
        number(totals.running_hours / modules),
    );
    put(
        "mean voltage drift [mV]",
        number(totals.voltage_drift * 1e3),
    );
    put(
        "max voltage drift [mV]",
        number(totals.max_voltage_drift * 1e3),
    );
    put(
        "rms tracking error [MW]",
        wind(|s| (s.squared_error / s.steps as f64).sqrt() / 1e6),
    );
    row
}

/// A JSON number, or null where the double is not finite (0/0 when nothing was produced).
fn number(x: f64) -> Value {
    serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn net_per_step_energies_and_rms() {
        let mut sums = Sums::default();
        // 10 MW offered for 2 s, 8 MW drawn: 4 MJ not absorbed, error -2 MW.
        sums.add(10e6, 16e6, 16e6, 2.0, 50e6);
        // 1 MW offered, 3 MW drawn: 4 MJ imported, error +2 MW.
        sums.add(1e6, 6e6, 6e6, 2.0, 50e6);
        // 80 MW offered to a 50 MW hub drawing 50 MW: 60 MJ not absorbed, error 0.
        sums.add(80e6, 100e6, 100e6, 2.0, 50e6);
        let totals = Totals {
            modules: 2,
            module_rated_power: 25e6,
            horizon: 6.0,
            energy: 122e6,
            grid_energy: 131e6,
            grid_side: false,
            hydrogen: 2.0,
            starts: 4.0,
            warm_starts: 3.0,
            running_hours: 3.0,
            voltage_drift: 0.0125,
            max_voltage_drift: 0.02,
        };
        let row = row(&totals, Some(&sums));
        let get = |k: &str| row[k].as_f64().unwrap();
        assert_eq!(get("reference energy [MWh]"), 182e6 / J_PER_MWH);
        assert_eq!(get("wind not absorbed [MWh]"), 64e6 / J_PER_MWH);
        assert_eq!(get("grid import [MWh]"), 4e6 / J_PER_MWH);
        assert!((get("rms tracking error [MW]") - (8.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(get("starts per module [1]"), 2.0);
        assert_eq!(get("warm starts per module [1]"), 1.5);
        assert_eq!(get("cold starts per module [1]"), 0.5);
        assert_eq!(get("mean voltage drift [mV]"), 12.5);
        assert_eq!(get("max voltage drift [mV]"), 20.0);
        assert_eq!(get("hub rated power [MW]"), 50.0);
        assert_eq!(get("full-load hours [h]"), 122e6 / 3600.0 / 50e6);
        assert_eq!(
            get("specific energy [kWh/kg]"),
            122e6 / J_PER_MWH * 1e3 / 2.0
        );
        assert_eq!(get("grid energy [MWh]"), 131e6 / J_PER_MWH);
        assert_eq!(
            get("specific energy, grid side [kWh/kg]"),
            131e6 / J_PER_MWH * 1e3 / 2.0
        );
        assert!((get("supply losses and auxiliaries [MWh]") - 9e6 / J_PER_MWH).abs() < 1e-15);
    }

    #[test]
    fn setpoint_runs_have_no_wind_kpis() {
        let totals = Totals {
            modules: 1,
            module_rated_power: 2e3,
            horizon: 3600.0,
            energy: 0.0,
            grid_energy: 0.0,
            grid_side: false,
            hydrogen: 0.0,
            starts: 0.0,
            warm_starts: 0.0,
            running_hours: 0.0,
            voltage_drift: 0.0,
            max_voltage_drift: 0.0,
        };
        let row = row(&totals, None);
        assert!(row["wind not absorbed [MWh]"].is_null());
        assert!(
            row["specific energy [kWh/kg]"].is_null(),
            "0/0 is no number"
        );
    }
}
