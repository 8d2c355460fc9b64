//! Drives the packaged FMU through the `fmi` crate: parameters by their model-description
//! names, one module's rated power from a probe instance, then the run over the reference
//! with communication points start + k·h.

use std::ffi::CString;
use std::path::Path;

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::fmi2::Fmi2Res;
use fmi::schema::fmi2::{Causality, ScalarVariableElement};

use crate::kpis::{Sums, Totals};

pub type Result<T> = std::result::Result<T, String>;

/// Which input the reference drives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Input {
    /// `powerReference` [W] (the FMU's powerInput = true).
    Power,
    /// `setpoint` [%].
    Setpoint,
}

/// One scenario: the FMU, its parameters and the reference held over each step.
pub struct Scenario {
    pub parameters: Vec<(String, String)>,
    pub input: Input,
    /// Value of the driven input over [start + k h, start + (k+1) h).
    pub reference: Vec<f64>,
    pub start: f64,
    pub step: f64,
    /// Hub size as a fraction of `source_rating` [W]: nModules = round(fraction · rating / P_module).
    pub hub_size: Option<(f64, f64)>,
}

/// The module's own parameters: those a probe of one module takes from the scenario.
const MODULE_PARAMETERS: [&str; 11] = [
    "gain",
    "tauZero",
    "tauPole1",
    "tauPole2",
    "rampUpLimit",
    "voltageIntercept",
    "ohmicResistance",
    "h2Coefficient",
    "nominalCurrent",
    "minSetpoint",
    "maxSetpoint",
];

/// Outputs read at the end of the run.
const TOTALS: [&str; 8] = [
    "hubEnergy",
    "hubH2Produced",
    "starts",
    "runningHours",
    "hubAcEnergy",
    "warmStarts",
    "voltageDrift",
    "maxVoltageDrift",
];

/// An fmi2 call's result: OK or Warning pass (the warning's text is collected).
fn check(what: &str, result: std::result::Result<Fmi2Res, fmi::fmi2::Fmi2Error>) -> Result<()> {
    match result {
        Ok(Fmi2Res::OK | Fmi2Res::Warning) => Ok(()),
        Ok(Fmi2Res::Pending) => Err(format!(
            "{what} returned Pending (asynchronous steps are not asked for)"
        )),
        Err(e) => Err(format!("{what} returned {e:?}")),
    }
}

fn value_reference(import: &Fmi2Import, name: &str) -> Result<u32> {
    let md = fmi::traits::FmiImport::model_description(import);
    md.model_variables
        .variables
        .iter()
        .find(|v| v.name == name)
        .map(|v| v.value_reference)
        .ok_or_else(|| format!("the FMU has no variable {name}"))
}

/// Sets a parameter (or an input's value) by name, typed from the model description.
fn set_by_name(import: &Fmi2Import, fmu: &mut InstanceCS, name: &str, text: &str) -> Result<()> {
    let md = fmi::traits::FmiImport::model_description(import);
    let var = md.model_variables.variables.iter().find(|v| v.name == name);
    let var = var.ok_or_else(|| {
        let nearest = md
            .model_variables
            .variables
            .iter()
            .filter(|v| matches!(v.causality, Causality::Parameter | Causality::Input))
            .map(|v| (strsim::jaro_winkler(&v.name, name), v.name.as_str()))
            .max_by(|a, b| a.0.total_cmp(&b.0));
        match nearest {
            Some((score, near)) if score >= 0.8 => {
                format!("--parameter: the FMU has no parameter {name} (did you mean {near}?)")
            }
            _ => format!("--parameter: the FMU has no parameter {name}"),
        }
    })?;
    if !matches!(var.causality, Causality::Parameter | Causality::Input) {
        return Err(format!(
            "{name} is an {} of the FMU, not a parameter",
            var.causality
        ));
    }
    let vr = [var.value_reference];
    let bad = |kind: &str| format!("{name} = {text:?} is not {kind}");
    let what = format!("fmi2Set of {name} = {text}");
    match &var.elem {
        ScalarVariableElement::Real(_) => {
            let x: f64 = text.trim().parse().map_err(|_| bad("a number"))?;
            check(&what, fmu.set_real(&vr, &[x]))
        }
        ScalarVariableElement::Integer(_) | ScalarVariableElement::Enumeration => {
            let n: i32 = text
                .trim()
                .parse()
                .map_err(|_| bad("an integer (enumeration items are set by their code)"))?;
            check(&what, fmu.set_integer(&vr, &[n]))
        }
        ScalarVariableElement::Boolean(_) => {
            let b = match text.trim() {
                "true" | "1" => 1,
                "false" | "0" => 0,
                _ => return Err(bad("true or false")),
            };
            check(&what, fmu.set_boolean(&vr, &[b]))
        }
        ScalarVariableElement::String => {
            let s = CString::new(text).map_err(|_| bad("a string without NUL"))?;
            fmu.set_string(&vr, &[s])
                .map_err(|e| format!("{what} returned {e:?}"))
        }
    }
}

/// kg per Nl: the `kg` display unit of the unit `Nl` in the model description.
fn kilograms_per_normal_litre(import: &Fmi2Import) -> Result<f64> {
    let md = fmi::traits::FmiImport::model_description(import);
    let units = md
        .unit_definitions
        .as_ref()
        .map(|u| u.units.as_slice())
        .unwrap_or_default();
    units
        .iter()
        .filter(|u| u.name == "Nl")
        .flat_map(|u| u.display_unit.iter())
        .find(|d| d.name == "kg")
        .and_then(|d| d.factor)
        .ok_or_else(|| "the model description has no display unit kg of Nl".to_string())
}

/// The grid side's parameters: with gridSideReference the power reference means grid power.
const GRID_PARAMETERS: [&str; 5] = [
    "auxiliaryPower",
    "supplyNoLoadLoss",
    "supplyLossVoltage",
    "supplyLossResistance",
    "gridSideReference",
];

/// Whether the scenario's power reference means grid power (gridSideReference = true).
pub fn grid_side(parameters: &[(String, String)]) -> bool {
    parameters
        .iter()
        .any(|(n, v)| n == "gridSideReference" && matches!(v.trim(), "true" | "1"))
}

/// Steady power [W] of one module at maxSetpoint on the side the reference means (the stack's
/// `power`, or with gridSideReference the grid's `acPower`): a probe instance of one module
/// with the scenario's module and grid-side parameters, held at maxSetpoint long enough to
/// settle.
pub fn module_rated_power(import: &Fmi2Import, parameters: &[(String, String)]) -> Result<f64> {
    let mut probe = import
        .instantiate_cs("aem-run probe", false, false)
        .map_err(|e| format!("fmi2Instantiate: {e}"))?;
    for (name, value) in parameters.iter().filter(|(n, _)| {
        MODULE_PARAMETERS.contains(&n.as_str()) || GRID_PARAMETERS.contains(&n.as_str())
    }) {
        set_by_name(import, &mut probe, name, value)?;
    }
    check("setupExperiment", probe.setup_experiment(None, 0.0, None))?;
    check("enterInitializationMode", probe.enter_initialization_mode())?;
    let mut max_setpoint = [0.0];
    check(
        "getReal maxSetpoint",
        probe.get_real(
            &[value_reference(import, "maxSetpoint")?],
            &mut max_setpoint,
        ),
    )?;
    check(
        "setReal setpoint",
        probe.set_real(&[value_reference(import, "setpoint")?], &max_setpoint),
    )?;
    check("exitInitializationMode", probe.exit_initialization_mode())?;
    // The slowest time constant is minutes at most, the start-up a few: a day settles it.
    check("doStep", probe.do_step(0.0, 86_400.0, true))?;
    let mut power = [0.0];
    let side = if grid_side(parameters) {
        "acPower"
    } else {
        "power"
    };
    check(
        "getReal power",
        probe.get_real(&[value_reference(import, side)?], &mut power),
    )?;
    if !(power[0] > 0.0) {
        return Err(format!(
            "a module at maxSetpoint draws {} W: cannot size the hub",
            power[0]
        ));
    }
    Ok(power[0])
}

/// Runs the scenario and returns the FMU's totals and, for a power reference, the sums.
pub fn run(fmu_path: &Path, scenario: &Scenario) -> Result<(Totals, Option<Sums>)> {
    let import: Fmi2Import = fmi::import::from_path(fmu_path)
        .map_err(|e| format!("--fmu {}: not an FMU that loads: {e}", fmu_path.display()))?;
    let h = scenario.step;
    let n = scenario.reference.len();
    if !(h > 0.0 && h.is_finite()) || n == 0 {
        return Err("need a step > 0 and a reference of at least one step".into());
    }
    if let Some(k) = scenario.reference.iter().position(|x| !x.is_finite()) {
        return Err(format!(
            "the reference is not a number at step {k} (time {} s)",
            scenario.start + k as f64 * h
        ));
    }
    if scenario
        .parameters
        .iter()
        .any(|(name, _)| name == "powerInput")
    {
        return Err(
            "powerInput follows the driven input (power or setpoint); do not set it".into(),
        );
    }
    let module_power = module_rated_power(&import, &scenario.parameters)?;
    let mut parameters = scenario.parameters.clone();
    if let Some((fraction, rating)) = scenario.hub_size {
        if parameters.iter().any(|(name, _)| name == "nModules") {
            return Err("give either the hub size or nModules, not both".into());
        }
        let modules = (fraction * rating / module_power).round();
        if !(modules >= 1.0 && modules <= f64::from(i32::MAX)) {
            return Err(format!(
                "hub size {fraction} of {rating} W is {modules} modules of {module_power} W"
            ));
        }
        parameters.push(("nModules".into(), format!("{modules}")));
    }
    parameters.push((
        "powerInput".into(),
        (scenario.input == Input::Power).to_string(),
    ));

    let mut fmu = import
        .instantiate_cs("aem-run", false, false)
        .map_err(|e| format!("fmi2Instantiate: {e}"))?;
    for (name, value) in &parameters {
        set_by_name(&import, &mut fmu, name, value)?;
    }
    let input_vr = [value_reference(
        &import,
        if scenario.input == Input::Power {
            "powerReference"
        } else {
            "setpoint"
        },
    )?];
    // What the hub draws from the grid, step by step (hubEnergy without losses or auxiliaries).
    // What the hub draws from the grid (hubAcEnergy), and on the side the reference means.
    let followed = if grid_side(&scenario.parameters) {
        "hubAcEnergy"
    } else {
        "hubEnergy"
    };
    let energy_vr = [
        value_reference(&import, "hubAcEnergy")?,
        value_reference(&import, followed)?,
    ];
    let totals_vrs = TOTALS
        .iter()
        .map(|name| value_reference(&import, name))
        .collect::<Result<Vec<u32>>>()?;
    let stop = scenario.start + n as f64 * h;
    check(
        "setupExperiment",
        fmu.setup_experiment(None, scenario.start, Some(stop)),
    )?;
    check(
        "setReal of the input",
        fmu.set_real(&input_vr, &scenario.reference[..1]),
    )?;
    check("enterInitializationMode", fmu.enter_initialization_mode())?;
    check("exitInitializationMode", fmu.exit_initialization_mode())?;
    let mut modules = [0];
    check(
        "getInteger nModules",
        fmu.get_integer(&[value_reference(&import, "nModules")?], &mut modules),
    )?;
    let mut at_start = [0.0; TOTALS.len()];
    check("getReal", fmu.get_real(&totals_vrs, &mut at_start))?;

    let mut sums = (scenario.input == Input::Power).then(Sums::default);
    let rated = f64::from(modules[0]) * module_power;
    let mut energy = [
        at_start[4],
        if grid_side(&scenario.parameters) {
            at_start[4]
        } else {
            at_start[0]
        },
    ];
    for (k, &reference) in scenario.reference.iter().enumerate() {
        let t = scenario.start + k as f64 * h;
        check(
            "setReal of the input",
            fmu.set_real(&input_vr, &[reference]),
        )?;
        // The call's name is formatted only when it failed (a year is 31.5 million steps).
        check("doStep", fmu.do_step(t, h, true)).map_err(|e| format!("{e} at {t} s"))?;
        let before = energy;
        check("getReal hubAcEnergy", fmu.get_real(&energy_vr, &mut energy))?;
        if let Some(s) = sums.as_mut() {
            s.add(
                reference,
                energy[0] - before[0],
                energy[1] - before[1],
                h,
                rated,
            );
        }
    }
    let mut at_end = [0.0; TOTALS.len()];
    check("getReal", fmu.get_real(&totals_vrs, &mut at_end))?;
    check("terminate", fmu.terminate())?;
    let since = |i: usize| at_end[i] - at_start[i];
    let totals = Totals {
        modules: modules[0],
        module_rated_power: module_power,
        horizon: n as f64 * h,
        energy: since(0),
        hydrogen: since(1) * kilograms_per_normal_litre(&import)?,
        starts: since(2),
        running_hours: since(3),
        grid_energy: since(4),
        grid_side: grid_side(&scenario.parameters),
        warm_starts: since(5),
        voltage_drift: at_end[6],
        max_voltage_drift: at_end[7],
    };
    Ok((totals, sums))
}
