//! The readable report (a table like the paper's Table I per module) and the statistics that
//! go into the parameter file.

use std::fmt::Write as _;

use serde_json::{json, Value};

use super::dynamics::Estimate;
use super::read::{BadRow, Dialect};
use super::{ModuleFit, Stage};
use aem_model::parameter_file::Spread;

/// `v` with `digits` significant digits.
pub fn sig(v: f64, digits: usize) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    if v == 0.0 {
        return "0".into();
    }
    let magnitude = v.abs().log10().floor() as i32;
    let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
    format!("{v:.decimals$}")
}

fn estimate_cells(e: &Estimate, unit: &str) -> (String, String) {
    let value = format!("{} {unit}", sig(e.value, 5));
    let se = if e.standard_error.is_finite() {
        format!("± {}", sig(e.standard_error, 2))
    } else {
        "undetermined".into()
    };
    (value, se)
}

/// The report for all modules, with the spread when there are several.
pub fn render(
    fits: &[ModuleFit],
    spread: Option<&std::collections::BTreeMap<String, Spread>>,
) -> String {
    let mut out = String::new();
    for fit in fits {
        render_module(&mut out, fit);
    }
    if let Some(spread) = spread.filter(|s| !s.is_empty()) {
        let _ = writeln!(
            out,
            "Spread over {} modules (identified parameters)",
            fits.len()
        );
        let _ = writeln!(
            out,
            "  {:<18} {:>12} {:>12} {:>12} {:>12} {:>8}",
            "parameter", "mean", "std", "min", "max", "cv [%]"
        );
        for (name, s) in spread {
            let _ = writeln!(
                out,
                "  {:<18} {:>12} {:>12} {:>12} {:>12} {:>8.2}   [{}]",
                name,
                sig(s.mean, 5),
                sig(s.std, 3),
                sig(s.min, 5),
                sig(s.max, 5),
                s.cv_percent,
                s.unit
            );
        }
    }
    out
}

fn render_module(out: &mut String, fit: &ModuleFit) {
    let log = &fit.log;
    let _ = writeln!(
        out,
        "Module {}: {} file(s), {} rows read, {} used",
        log.id, log.files, log.rows_read, log.rows_used
    );
    if log.dialects.iter().any(|d| *d != Dialect::default()) {
        let read_as: Vec<String> = log.dialects.iter().map(Dialect::to_string).collect();
        let _ = writeln!(out, "  read as {}", read_as.join("; "));
    }
    let bad: Vec<String> = BadRow::ALL
        .iter()
        .filter(|r| log.bad.count(**r) > 0)
        .map(|r| {
            let first = log.bad.first(*r).map_or(String::new(), |l| {
                format!(", first {}:{}", l.path.display(), l.line)
            });
            format!("{} {}{first}", r.label(), log.bad.count(*r))
        })
        .collect();
    let _ = writeln!(
        out,
        "  skipped rows: {}",
        if bad.is_empty() {
            "none".to_string()
        } else {
            bad.join("; ")
        }
    );
    if log.bad.gaps > 0 {
        let first = log.bad.first_gap.as_ref().map_or(String::new(), |l| {
            format!(", first ends at {}:{}", l.path.display(), l.line)
        });
        let _ = writeln!(
            out,
            "  gaps: {} ({} s missing{first})",
            log.bad.gaps,
            sig(log.bad.gap_seconds, 4)
        );
    }
    let s = &fit.steps;
    let _ = writeln!(
        out,
        "  steps: {} setpoint changes while running in {} running segments; {} qualify ({} within the settle time after a start-up or gap, {} from/to outside the setpoint window, {} too small, {} after a short level, {} with a short response)",
        s.changes, s.segments, s.qualified, s.after_start, s.outside_window, s.too_small, s.short_level, s.short_response
    );
    let _ = writeln!(out);
    let _ = writeln!(
        out,
        "  {:<20} {:<28} {:<22} Std. error",
        "Model", "Parameter", "Value"
    );
    let _ = writeln!(out, "  {:-<20} {:-<28} {:-<22} {:-<14}", "", "", "", "");
    let mut row = |model: &str, name: &str, value: String, extra: String| {
        let _ = writeln!(out, "  {model:<20} {name:<28} {value:<22} {extra}");
    };
    let flag = |name: &str| {
        if fit.is_poorly_determined(name) {
            "  (poorly determined)"
        } else {
            ""
        }
    };
    match &fit.polarisation {
        Stage::Done(p) => {
            let (v, e) = estimate_cells(&p.voltage_intercept, "V");
            row(
                "Polarisation curve",
                "Voltage intercept V0",
                v,
                e + flag("voltageIntercept"),
            );
            let (v, e) = estimate_cells(&p.ohmic_resistance, "Ω");
            row("", "Ohmic resistance R", v, e + flag("ohmicResistance"));
            row(
                "",
                "RMSE",
                format!("{} V", sig(p.rmse, 4)),
                format!(
                    "{} of {} running points, I {}…{} A",
                    p.points,
                    p.candidates,
                    sig(p.current_range.0, 3),
                    sig(p.current_range.1, 3)
                ),
            );
            for note in &p.notes {
                row("", "note", note.clone(), String::new());
            }
        }
        Stage::Skipped(why) => row(
            "Polarisation curve",
            "not identified",
            why.clone(),
            String::new(),
        ),
    }
    match &fit.dynamics {
        Stage::Done(d) => {
            let (v, e) = estimate_cells(&d.gain, "A/%");
            row("Current dynamics", "K", v, e + flag("gain"));
            let (v, e) = estimate_cells(&d.tau_zero, "s");
            row("", "τz", v, e + flag("tauZero"));
            let (v, e) = estimate_cells(&d.tau_pole1, "s");
            row("", "τp1", v, e + flag("tauPole1"));
            let (v, e) = estimate_cells(&d.tau_pole2, "s");
            row("", "τp2", v, e + flag("tauPole2"));
            let (v, e) = estimate_cells(&d.ratio_zero_pole2, "");
            row(
                "",
                "τz/τp2",
                v,
                format!("{e}  corr(τz, τp2) = {:.4}", d.correlation[1][3]),
            );
            match &d.ramp {
                Ok(r) => {
                    let (v, e) = estimate_cells(r, "A/s");
                    row(
                        "",
                        "Positive ramp-rate limit",
                        v,
                        format!(
                            "{e}{}  binds in {} positive steps",
                            flag("rampUpLimit"),
                            d.ramp_binding
                        ),
                    );
                }
                Err(why) => row(
                    "",
                    "Positive ramp-rate limit",
                    "not identified".into(),
                    why.clone(),
                ),
            }
            row(
                "",
                "RMSE",
                format!("{} A", sig(d.rmse_total, 4)),
                format!(
                    "negative {} A over {} steps, positive {} over {} steps; outliers removed {}/{}; negative steps on a ramp left out {}",
                    sig(d.rmse_negative, 4),
                    d.used.0,
                    d.rmse_positive.map_or("-".into(), |r| format!("{} A", sig(r, 4))),
                    d.used.1,
                    d.outliers.0,
                    d.outliers.1,
                    d.on_ramp
                ),
            );
        }
        Stage::Skipped(why) => row(
            "Current dynamics",
            "not identified",
            why.clone(),
            String::new(),
        ),
    }
    match &fit.hydrogen {
        Stage::Done(h) => {
            let (v, e) = estimate_cells(&h.coefficient, "Nl/(h·A)");
            row(
                "Hydrogen production",
                "Production coefficient",
                v,
                e + flag("h2Coefficient"),
            );
            row(
                "",
                "RMSE",
                format!("{} Nl/h", sig(h.rmse, 4)),
                format!("{} points", h.points),
            );
            row(
                "",
                "Faraday efficiency",
                format!("{:.2} %", 100.0 * h.faraday_efficiency),
                format!(
                    "{} cells, ideal {} Nl/(h·A)",
                    h.cells,
                    sig(super::hydrogen::ideal_coefficient(h.cells), 6)
                ),
            );
        }
        Stage::Skipped(why) => row(
            "Hydrogen production",
            "not identified",
            why.clone(),
            String::new(),
        ),
    }
    row(
        "",
        "Nominal current",
        format!("{} A", sig(fit.parameters.nominal_current, 5)),
        "given (not identified)".into(),
    );
    let interval = |e: &Estimate, unit: &str| {
        let half = crate::temperature::Z95 * e.standard_error;
        format!(
            "± {}  (95 %: {} … {} {unit})",
            sig(e.standard_error, 2),
            sig(e.value - half, 4),
            sig(e.value + half, 4)
        )
    };
    match &fit.temperature {
        Stage::Done(t) => {
            row(
                "Temperature",
                "kV",
                format!("{} V/K", sig(t.voltage_coefficient.value, 4)),
                interval(&t.voltage_coefficient, "V/K"),
            );
            match &t.resistance_coefficient {
                Some(kr) => row(
                    "",
                    "kR",
                    format!("{} Ω/K", sig(kr.value, 4)),
                    interval(kr, "Ω/K"),
                ),
                None => row("", "kR", "not identified".into(), String::new()),
            }
            row(
                "",
                "RMSE",
                format!("{} V", sig(t.rmse, 4)),
                format!(
                    "{} running points, {}…{} °C (σ {} K)",
                    t.points,
                    sig(t.temperature_range.0, 4),
                    sig(t.temperature_range.1, 4),
                    sig(t.temperature_spread, 3)
                ),
            );
            for note in &t.notes {
                row("", "note", note.clone(), String::new());
            }
        }
        Stage::Skipped(why) => row("Temperature", "not identified", why.clone(), String::new()),
    }
    match &fit.heat {
        Stage::Done(h) => {
            row(
                "Heat balance",
                "C",
                format!("{} J/K", sig(h.heat_capacity.value, 4)),
                interval(&h.heat_capacity, "J/K"),
            );
            row(
                "",
                "Rth",
                format!("{} K/W", sig(h.thermal_resistance.value, 4)),
                interval(&h.thermal_resistance, "K/W"),
            );
            row(
                "",
                "RMSE of ΔT",
                format!("{} K", sig(h.rmse, 3)),
                format!(
                    "{} windows below the setpoint, {} with heat",
                    h.windows, h.heated
                ),
            );
        }
        Stage::Skipped(why) => row("Heat balance", "not identified", why.clone(), String::new()),
    }
    match &fit.drift {
        Stage::Done(d) => {
            row(
                "Voltage drift",
                "A (reversible)",
                format!("{} V", sig(d.amplitude.value, 4)),
                interval(&d.amplitude, "V"),
            );
            row(
                "",
                "τb (build-up)",
                format!("{} s", sig(d.build_up_time.value, 4)),
                interval(&d.build_up_time, "s"),
            );
            let optional = |e: &Option<Estimate>, unit: &str| match e {
                Some(e) => (format!("{} {unit}", sig(e.value, 4)), interval(e, unit)),
                None => ("not identified".into(), String::new()),
            };
            let (v, e) = optional(&d.recovery_time, "s");
            row("", "τr (recovery)", v, e);
            row(
                "",
                "ρ (per running hour)",
                format!("{} V/h", sig(d.per_running_hour.value, 4)),
                interval(&d.per_running_hour, "V/h"),
            );
            let (v, e) = optional(&d.per_start, "V");
            row("", "δs (per start)", v, e);
            row(
                "",
                "RMSE",
                format!("{} V", sig(d.rmse, 4)),
                format!(
                    "{} V without the drift; {} points, {} runs, the longest {} h",
                    sig(d.rmse_without_drift, 4),
                    d.points,
                    d.runs,
                    sig(d.longest_run / 3600.0, 3)
                ),
            );
            for note in &d.notes {
                row("", "note", note.clone(), String::new());
            }
        }
        Stage::Skipped(why) => row(
            "Voltage drift",
            "not identified",
            why.clone(),
            String::new(),
        ),
    }
    let _ = writeln!(out);
    if let Stage::Done(d) = &fit.dynamics {
        let groups: Vec<String> = d
            .groups
            .iter()
            .map(|g| {
                format!(
                    "{}{} %: {} A ({})",
                    if g.sign == super::segments::Sign::Negative {
                        "−"
                    } else {
                        "+"
                    },
                    g.size,
                    sig(g.rmse, 3),
                    g.steps
                )
            })
            .collect();
        let _ = writeln!(out, "  RMSE per step size (steps): {}", groups.join(", "));
        if let Some(t) = &d.trajectory {
            match t {
                Ok((p, se, rmse)) => {
                    let _ = writeln!(
                        out,
                        "  Whole-record cross-check: K {} ± {} A/%, τz {} ± {} s, τp1 {} ± {} s, τp2 {} ± {} s, r {} ± {} A/s, RMSE {} A",
                        sig(p.gain, 5), sig(se[0], 2), sig(p.tau_zero, 5), sig(se[1], 2), sig(p.tau_pole1, 5), sig(se[2], 2),
                        sig(p.tau_pole2, 5), sig(se[3], 2), sig(p.ramp_up_limit, 5), sig(se[4], 2), sig(*rmse, 4)
                    );
                }
                Err(e) => {
                    let _ = writeln!(out, "  Whole-record cross-check failed: {e}");
                }
            }
        }
    }
    match &fit.structure {
        Stage::Done(s) => {
            let best = s.best_order();
            let min_aicc = s
                .candidates
                .iter()
                .map(|c| c.aicc)
                .fold(f64::INFINITY, f64::min);
            let _ = writeln!(
                out,
                "  Structure check on the negative steps (N = {} residuals):",
                s.residuals
            );
            let _ = writeln!(
                out,
                "    order  k  RMSE [A]   AICc          ΔAICc       poles [s]"
            );
            for c in &s.candidates {
                let poles: Vec<String> = c.time_constants.iter().map(|t| sig(*t, 4)).collect();
                let _ = writeln!(
                    out,
                    "    {:<5}  {}  {:<9}  {:<12.1}  {:<10}  {}{}",
                    c.order,
                    c.parameters,
                    sig(c.rmse, 4),
                    c.aicc,
                    sig(c.aicc - min_aicc, 4),
                    poles.join(", "),
                    if Some(c.order) == best {
                        "   ← lowest AICc"
                    } else {
                        ""
                    }
                );
            }
            for (order, why) in &s.failures {
                let _ = writeln!(out, "    {order}      not fitted: {why}");
            }
        }
        Stage::Skipped(why) => {
            let _ = writeln!(out, "  Structure check not run: {why}");
        }
    }
    let flagged: Vec<&str> = fit
        .estimates
        .keys()
        .copied()
        .filter(|n| fit.is_poorly_determined(n))
        .collect();
    if !flagged.is_empty() {
        let _ = writeln!(
            out,
            "  Poorly determined (relative standard error above {} %): {}",
            100.0 * fit.poorly_determined,
            flagged.join(", ")
        );
    }
    let _ = writeln!(out);
}

fn stage_json<T>(stage: &Stage<T>, f: impl Fn(&T) -> Value) -> Value {
    match stage {
        Stage::Done(t) => f(t),
        Stage::Skipped(why) => json!({ "skipped": why }),
    }
}

/// An estimate with its standard error and 95 % interval (±1.96 standard errors).
fn estimate_json(e: &Estimate, unit: &str) -> Value {
    let half = crate::temperature::Z95 * e.standard_error;
    json!({
        "value": num(e.value), "standardError": num(e.standard_error),
        "interval95": [num(e.value - half), num(e.value + half)], "unit": unit,
    })
}

fn num(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else {
        Value::Null
    }
}

/// Fit statistics of one module for the parameter file.
pub fn statistics_json(fit: &ModuleFit) -> Value {
    let bad: serde_json::Map<String, Value> = BadRow::ALL
        .iter()
        .map(|r| (r.label().to_string(), json!(fit.log.bad.count(*r))))
        .collect();
    let s = &fit.steps;
    json!({
        "rowsRead": fit.log.rows_read,
        "rowsUsed": fit.log.rows_used,
        "files": fit.log.files,
        "dialects": fit.log.dialects.iter().map(Dialect::to_string).collect::<Vec<_>>(),
        "skippedRows": bad,
        "gaps": fit.log.bad.gaps,
        "gapSeconds": fit.log.bad.gap_seconds,
        "steps": {
            "runningSegments": s.segments, "changes": s.changes, "qualified": s.qualified,
            "afterStart": s.after_start, "outsideWindow": s.outside_window, "tooSmall": s.too_small,
            "shortLevel": s.short_level, "shortResponse": s.short_response,
        },
        "polarisation": stage_json(&fit.polarisation, |p| json!({
            "rmseV": num(p.rmse), "points": p.points, "candidates": p.candidates,
            "currentRangeA": [p.current_range.0, p.current_range.1], "notes": p.notes,
        })),
        "dynamics": stage_json(&fit.dynamics, |d| json!({
            "rmseA": num(d.rmse_total), "rmseNegativeA": num(d.rmse_negative),
            "rmsePositiveA": d.rmse_positive.map_or(Value::Null, num),
            "stepsUsed": { "negative": d.used.0, "positive": d.used.1 },
            "outliersRemoved": { "negative": d.outliers.0, "positive": d.outliers.1 },
            "negativeStepsOnRampLeftOut": d.on_ramp,
            "positiveStepsWhereTheRampBinds": d.ramp_binding,
            "ratioTauZeroTauPole2": { "value": num(d.ratio_zero_pole2.value), "standardError": num(d.ratio_zero_pole2.standard_error) },
            "correlation": { "order": ["gain", "tauZero", "tauPole1", "tauPole2"],
                             "matrix": d.correlation.iter().map(|r| r.iter().map(|v| num(*v)).collect::<Vec<_>>()).collect::<Vec<_>>() },
            "rampLimit": match &d.ramp { Ok(_) => Value::Null, Err(e) => json!({ "skipped": e }) },
            "groups": d.groups.iter().map(|g| json!({ "sign": g.sign.label(), "sizePercent": g.size, "steps": g.steps, "rmseA": num(g.rmse) })).collect::<Vec<_>>(),
            "optimizer": { "termination": d.termination, "evaluations": d.evaluations },
            "trajectoryCrossCheck": match &d.trajectory {
                None => Value::Null,
                Some(Err(e)) => json!({ "failed": e }),
                Some(Ok((p, se, rmse))) => json!({
                    "gain": [p.gain, num(se[0])], "tauZero": [p.tau_zero, num(se[1])], "tauPole1": [p.tau_pole1, num(se[2])],
                    "tauPole2": [p.tau_pole2, num(se[3])], "rampUpLimit": [p.ramp_up_limit, num(se[4])], "rmseA": num(*rmse),
                }),
            },
        })),
        "structure": stage_json(&fit.structure, |s| json!({
            "residuals": s.residuals,
            "bestOrder": s.best_order(),
            "candidates": s.candidates.iter().map(|c| json!({
                "order": c.order, "parameters": c.parameters, "rmseA": num(c.rmse), "aicc": num(c.aicc), "poles": c.time_constants,
            })).collect::<Vec<_>>(),
            "failures": s.failures.iter().map(|(o, e)| json!({ "order": o, "reason": e })).collect::<Vec<_>>(),
        })),
        "temperature": stage_json(&fit.temperature, |t| json!({
            "voltageTemperatureCoefficient": estimate_json(&t.voltage_coefficient, "V/K"),
            "resistanceTemperatureCoefficient": t.resistance_coefficient.as_ref().map_or(Value::Null, |e| estimate_json(e, "Ohm/K")),
            "voltageIntercept": estimate_json(&t.voltage_intercept, "V"),
            "ohmicResistance": t.ohmic_resistance.as_ref().map_or(Value::Null, |e| estimate_json(e, "Ohm")),
            "rmseV": num(t.rmse), "points": t.points,
            "temperatureRangeDegC": [t.temperature_range.0, t.temperature_range.1],
            "temperatureSpreadK": num(t.temperature_spread), "fittedWithDrift": t.drift_terms, "notes": t.notes,
        })),
        "heat": stage_json(&fit.heat, |h| json!({
            "heatCapacity": estimate_json(&h.heat_capacity, "J/K"),
            "thermalResistance": estimate_json(&h.thermal_resistance, "K/W"),
            "rmseK": num(h.rmse), "windows": h.windows, "windowsWithHeat": h.heated,
        })),
        "drift": stage_json(&fit.drift, |d| json!({
            "reversibleDrift": estimate_json(&d.amplitude, "V"),
            "driftBuildUpTime": estimate_json(&d.build_up_time, "s"),
            "driftRecoveryTime": d.recovery_time.as_ref().map_or(Value::Null, |e| estimate_json(e, "s")),
            "driftPerRunningHour": estimate_json(&d.per_running_hour, "V/h"),
            "driftPerStart": d.per_start.as_ref().map_or(Value::Null, |e| estimate_json(e, "V")),
            "rmseV": num(d.rmse), "rmseWithoutDriftV": num(d.rmse_without_drift),
            "points": d.points, "runs": d.runs, "longestRunS": num(d.longest_run), "notes": d.notes,
        })),
        "hydrogen": stage_json(&fit.hydrogen, |h| json!({
            "rmseNlPerH": num(h.rmse), "points": h.points, "cells": h.cells, "faradayEfficiency": num(h.faraday_efficiency),
        })),
        "poorlyDeterminedThreshold": fit.poorly_determined,
        "stageSeconds": fit.timings.iter().map(|(n, d)| (n.to_string(), json!(d.as_secs_f64()))).collect::<serde_json::Map<_, _>>(),
    })
}
