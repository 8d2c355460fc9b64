"""The KPI columns of a study's table, in the order of the table, each with its unit.

`aem-run` (crates/runner) writes exactly these keys; `study.report` plots and summarises them.
"""

#: KPI column name -> one-line meaning (the units are in the names).
KPIS = {
    "modules [1]": "number of modules in the hub",
    "hub rated power [MW]": "modules x one module's steady power at maxSetpoint (grid power with gridSideReference)",
    "horizon [h]": "simulated time",
    "reference energy [MWh]": "energy of the power reference (the wind offered), held over each step",
    "energy drawn [MWh]": "electric energy drawn by the hub (hubEnergy)",
    "hydrogen [kg]": "hydrogen produced by the hub (hubH2Produced)",
    "specific energy [kWh/kg]": "energy drawn per kilogram of hydrogen",
    "grid energy [MWh]": "energy the grid delivered: energy drawn, the supply's losses and the auxiliaries (hubAcEnergy)",
    "supply losses and auxiliaries [MWh]": "grid energy - energy drawn",
    "specific energy, grid side [kWh/kg]": "grid energy per kilogram of hydrogen",
    "wind not absorbed [MWh]": "sum over steps of max(reference - hub's grid draw, 0) energy",
    "grid import [MWh]": "sum over steps of max(hub's grid draw - reference, 0) energy",
    "full-load hours [h]": "energy drawn (grid energy with gridSideReference) / hub rated power",
    "starts per module [1]": "start-ups summed over the modules / modules",
    "warm starts per module [1]": "of them, the warm ones (warmStartTime: from standby, or a stack at least warmStartTemperature)",
    "cold starts per module [1]": "of them, the cold ones (coldStartTime)",
    "running hours per module [h]": "running time summed over the modules / modules",
    "mean voltage drift [mV]": "the stack voltage's drift with use at the end, mean over the modules (voltageDrift; 0 without ageing)",
    "max voltage drift [mV]": "the largest drift of any module at the end (maxVoltageDrift)",
    "rms tracking error [MW]": "RMS over steps of the hub's step-mean power minus the reference capped at the hub's rated power",
}

#: Columns of a scenario's run, not of the model: they differ between runs of the same scenario.
RUN_COLUMNS = ["run time [s]", "worker"]
