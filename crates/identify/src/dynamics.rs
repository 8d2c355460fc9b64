//! Current dynamics from setpoint steps (paper §III-C), simulated with the FMU's own model.
//!
//! For a step at time t₀ with pre-step window W and response rows i, the residual is
//!   rᵢ = (I_meas(tᵢ) − mean_W I_meas) − (I_model(tᵢ) − mean_W I_model)   [A],
//! where I_model comes from [`crate::model::Module`] stepped over the whole running segment
//! from steady state at its first setpoint. Applying the same pre-step-mean subtraction to the
//! model as to the data removes the baseline bias of short preceding levels that have not yet
//! settled on the slow pole: the model carries the same unsettled history.
//!
//! 1. K, τz, τp1, τp2 (as logarithms) minimise Σ r² over the negative steps, where the
//!    rising-rate limit cannot act; steps whose RMSE is an outlier are removed and the fit
//!    repeated.
//! 2. With those fixed, the ramp limit r minimises Σ r² over the positive steps (same outlier
//!    rule).
//! 3. Optionally, a whole-record (trajectory) fit of all five parameters to the absolute
//!    current of every steady running row cross-checks the step fit.

use aem_model::{Module, Parameters};

use nalgebra::DMatrix;

use super::lsq::{self, Fit, Residuals};
use super::modal;
use super::segments::{Segment, Sign, StepSet};
use super::stats;

/// Which parameters a fit varies (the others come from the base set).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Free {
    /// ln K, ln τz, ln τp1, ln τp2.
    Linear,
    /// ln r.
    Ramp,
    /// ln K, ln τz, ln τp1, ln τp2, ln r.
    All,
}

impl Free {
    fn count(self) -> usize {
        match self {
            Free::Linear => 4,
            Free::Ramp => 1,
            Free::All => 5,
        }
    }

    /// θ of `p`.
    pub fn theta(self, p: &Parameters) -> Vec<f64> {
        let linear = [
            p.gain.ln(),
            p.tau_zero.ln(),
            p.tau_pole1.ln(),
            p.tau_pole2.ln(),
        ];
        match self {
            Free::Linear => linear.to_vec(),
            Free::Ramp => vec![p.ramp_up_limit.ln()],
            Free::All => linear.into_iter().chain([p.ramp_up_limit.ln()]).collect(),
        }
    }

    /// `base` with θ applied.
    pub fn apply(self, base: &Parameters, theta: &[f64]) -> Parameters {
        let mut p = *base;
        if matches!(self, Free::Linear | Free::All) {
            p.gain = theta[0].exp();
            p.tau_zero = theta[1].exp();
            p.tau_pole1 = theta[2].exp();
            p.tau_pole2 = theta[3].exp();
        }
        match self {
            Free::Ramp => p.ramp_up_limit = theta[0].exp(),
            Free::All => p.ramp_up_limit = theta[4].exp(),
            Free::Linear => {}
        }
        p
    }
}

/// Model current [A] at rows 0..`len` of a segment, from [`Module`] in steady state at the
/// first setpoint, stepped from t[n−1] to t[n] with setpoint u[n]. False if the module
/// refuses the parameters.
pub fn simulate_segment(
    params: &Parameters,
    seg: &Segment,
    len: usize,
    out: &mut Vec<f64>,
) -> bool {
    out.clear();
    let Ok(mut module) = Module::new(*params, seg.setpoint[0]) else {
        return false;
    };
    out.push(module.current());
    for n in 1..len.min(seg.len()) {
        if module
            .step(seg.setpoint[n], seg.time[n] - seg.time[n - 1])
            .is_err()
        {
            return false;
        }
        out.push(module.current());
    }
    true
}

/// Residuals of chosen steps (or of the whole record) for the parameters `free` leaves open.
pub struct StepResiduals<'a> {
    set: &'a StepSet,
    base: Parameters,
    free: Free,
    /// (segment, rows to simulate, steps in it) in segment order.
    plan: modal::Plan,
    /// Whole-record mode: rows from this time after the segment start are compared.
    trajectory_settle: Option<f64>,
}

impl<'a> StepResiduals<'a> {
    /// Residuals of the steps `chosen` (indices into `set.steps`).
    pub fn steps(set: &'a StepSet, chosen: &[usize], base: Parameters, free: Free) -> Self {
        StepResiduals {
            set,
            base,
            free,
            plan: modal::plan(set, chosen),
            trajectory_settle: None,
        }
    }

    /// Residuals I_meas − I_model of every running row at least `settle` seconds after its
    /// segment started.
    pub fn trajectory(set: &'a StepSet, base: Parameters, settle: f64) -> Self {
        let plan = set
            .segments
            .iter()
            .enumerate()
            .filter(|(_, s)| s.time[s.len() - 1] - s.time[0] > settle)
            .map(|(i, s)| (i, s.len(), Vec::new()))
            .collect();
        StepResiduals {
            set,
            base,
            free: Free::All,
            plan,
            trajectory_settle: Some(settle),
        }
    }

    /// Steps in residual order, with the range of their residuals.
    pub fn layout(&self) -> Vec<(usize, std::ops::Range<usize>)> {
        let mut offset = 0;
        let mut out = Vec::new();
        for (_, _, list) in &self.plan {
            for &k in list {
                let n = self.set.steps[k].post.len();
                out.push((k, offset..offset + n));
                offset += n;
            }
        }
        out
    }
}

impl Residuals for StepResiduals<'_> {
    fn parameters(&self) -> usize {
        self.free.count()
    }

    /// Exact for K, τz, τp1, τp2 when the rate limit is lifted (stage 1): the model's
    /// response is then the modal one of [`modal`], whose sensitivities with respect to
    /// (ln K, ln τp1, ln τp2, w₁) are mapped to (ln K, ln τz, ln τp1, ln τp2) through
    /// w₁ = a = (τz − τp1)/D, D = τp2 − τp1:
    ///   ∂a/∂ln τz = τz/D,  ∂a/∂ln τp1 = τp1(τz − τp2)/D²,  ∂a/∂ln τp2 = −τp2(τz − τp1)/D².
    fn exact_jacobian(&self, theta: &[f64]) -> Option<DMatrix<f64>> {
        if self.free != Free::Linear
            || self.trajectory_settle.is_some()
            || self.base.ramp_up_limit < UNLIMITED_RAMP
        {
            return None;
        }
        let p = self.free.apply(&self.base, theta);
        p.validate().ok()?;
        let (a, b) = p.modal_weights();
        let taus = [p.tau_pole1, p.tau_pole2];
        let weights = [a, b];
        let modal = modal::Modal {
            gain: p.gain,
            taus: &taus,
            weights: &weights,
            window: (p.min_setpoint, p.max_setpoint),
        };
        let mut out = Vec::new();
        let mut raw: Vec<Vec<f64>> = vec![Vec::new(); 4];
        if !modal.residuals(self.set, &self.plan, &mut out, Some(&mut raw[..])) {
            return None;
        }
        // ∂a/∂ln τ = τ·∂a/∂τ (the fit's parameters are logarithms)
        let (a_z, a_1, a_2) = p.modal_weight_sensitivities();
        let (da_z, da_1, da_2) = (p.tau_zero * a_z, p.tau_pole1 * a_1, p.tau_pole2 * a_2);
        let (k, t1s, t2s, dw) = (&raw[0], &raw[1], &raw[2], &raw[3]);
        let columns = k
            .iter()
            .copied()
            .chain(dw.iter().map(|x| x * da_z))
            .chain(t1s.iter().zip(dw).map(|(s, x)| s + x * da_1))
            .chain(t2s.iter().zip(dw).map(|(s, x)| s + x * da_2));
        Some(DMatrix::from_iterator(out.len(), 4, columns))
    }

    /// Each step's residuals share the noise of its pre-step mean: one cluster per step.
    fn clusters(&self) -> Option<Vec<std::ops::Range<usize>>> {
        if self.trajectory_settle.is_some() {
            return None;
        }
        Some(self.layout().into_iter().map(|(_, range)| range).collect())
    }

    fn residuals(&self, theta: &[f64], out: &mut Vec<f64>) -> bool {
        out.clear();
        let params = self.free.apply(&self.base, theta);
        if params.validate().is_err() {
            return false;
        }
        // Segments are independent: simulate them on two threads (the machine's cores) when
        // there is enough work, and concatenate in plan order.
        let rows: usize = self.plan.iter().map(|(_, len, _)| len).sum();
        let workers = std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .min(self.plan.len());
        if workers < 2 || rows < PARALLEL_ROWS {
            return self.residuals_of(&self.plan, &params, out);
        }
        let (head, tail) = modal::halves(&self.plan);
        let mut second = Vec::new();
        let (ok_head, ok_tail) = std::thread::scope(|scope| {
            let handle = scope.spawn(|| self.residuals_of(tail, &params, &mut second));
            let ok = self.residuals_of(head, &params, out);
            (ok, handle.join().unwrap_or(false))
        });
        out.extend_from_slice(&second);
        ok_head && ok_tail
    }
}

/// Below this many simulated rows one thread is faster than two.
const PARALLEL_ROWS: usize = 20_000;

/// Relative tolerance on the sum of squares and the parameters for the final dynamics fits:
/// the objective is flat along τz/τp2, so converge tightly.
const TOLERANCE: f64 = 1e-12;

/// Fewest positive steps in which the rate limit must bind (for at least
/// [`MIN_BINDING_SECONDS`]) for it to count as determined.
pub const MIN_BINDING_STEPS: usize = 3;

/// Shortest binding time [s] that makes a step inform the rate limit (a few samples at 1 Hz).
pub const MIN_BINDING_SECONDS: f64 = 5.0;

/// Tolerance of the first fit, which only has to find the outliers.
const LOOSE_TOLERANCE: f64 = 1e-6;

/// A rate limit [A/s] that never binds at the model's currents: the unlimited model.
pub const UNLIMITED_RAMP: f64 = 1e9;

impl StepResiduals<'_> {
    fn residuals_of(
        &self,
        plan: &[modal::PlanEntry],
        params: &Parameters,
        out: &mut Vec<f64>,
    ) -> bool {
        let mut model = Vec::new();
        for (seg_index, len, list) in plan {
            let seg = &self.set.segments[*seg_index];
            if !simulate_segment(params, seg, *len, &mut model) {
                return false;
            }
            if let Some(settle) = self.trajectory_settle {
                let from = seg.time.partition_point(|&t| t < seg.time[0] + settle);
                out.extend(
                    seg.current[from..]
                        .iter()
                        .zip(&model[from..])
                        .map(|(m, s)| m - s),
                );
                continue;
            }
            for &k in list {
                let step = &self.set.steps[k];
                let model_pre = stats::mean(&model[step.pre.clone()]);
                out.extend(
                    step.post
                        .clone()
                        .map(|i| (seg.current[i] - step.pre_mean) - (model[i] - model_pre)),
                );
            }
        }
        true
    }
}

/// A fitted parameter with its standard error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Value in the model description's unit.
    pub value: f64,
    /// Standard error, same unit (infinite when undetermined).
    pub standard_error: f64,
}

impl Estimate {
    /// Relative standard error.
    pub fn relative_error(&self) -> f64 {
        self.standard_error / self.value.abs()
    }
}

/// RMSE of one group of steps (same sign, same size to the whole percent).
#[derive(Clone, Debug, PartialEq)]
pub struct GroupRmse {
    /// Direction.
    pub sign: Sign,
    /// Step size [%], rounded.
    pub size: i64,
    /// Steps used.
    pub steps: usize,
    /// RMSE of their residuals [A].
    pub rmse: f64,
}

/// Settings of the dynamics fit.
#[derive(Clone, Debug)]
pub struct DynamicsOptions {
    /// A step is an outlier when its RMSE exceeds the median step RMSE by more than this many
    /// robust standard deviations (1.4826·MAD) of the step RMSEs.
    pub outlier_sigmas: f64,
    /// Also run the whole-record (trajectory) fit.
    pub trajectory: bool,
    /// Settle time for the trajectory fit [s].
    pub settle: f64,
}

impl Default for DynamicsOptions {
    fn default() -> Self {
        DynamicsOptions {
            outlier_sigmas: 5.0,
            trajectory: false,
            settle: 600.0,
        }
    }
}

/// Whole-record cross-check: parameters, standard errors of (K, τz, τp1, τp2, r), RMSE [A].
pub type TrajectoryFit = (Parameters, [f64; 5], f64);

/// Result of the dynamics identification.
#[derive(Clone, Debug)]
pub struct DynamicsFit {
    /// K [A/%].
    pub gain: Estimate,
    /// τz [s].
    pub tau_zero: Estimate,
    /// τp1 [s].
    pub tau_pole1: Estimate,
    /// τp2 [s].
    pub tau_pole2: Estimate,
    /// τz/τp2 [-].
    pub ratio_zero_pole2: Estimate,
    /// Correlation matrix of (K, τz, τp1, τp2) from the negative-step fit.
    pub correlation: [[f64; 4]; 4],
    /// Rising-rate limit r [A/s], or why it is undetermined.
    pub ramp: Result<Estimate, String>,
    /// RMSE over the negative steps used [A].
    pub rmse_negative: f64,
    /// RMSE over the positive steps used [A] (with the fitted limit).
    pub rmse_positive: Option<f64>,
    /// RMSE over all steps used [A].
    pub rmse_total: f64,
    /// RMSE per group.
    pub groups: Vec<GroupRmse>,
    /// Negative and positive steps used.
    pub used: (usize, usize),
    /// Negative and positive steps removed as outliers.
    pub outliers: (usize, usize),
    /// Positive steps used in whose response the identified rate limit binds for at least
    /// [`MIN_BINDING_SECONDS`]; below
    /// [`MIN_BINDING_STEPS`] the limit is undetermined (infinite standard error).
    pub ramp_binding: usize,
    /// Negative steps left out because the rate limit binds in their window (after a rise
    /// that has not finished), where the unlimited transfer function does not apply.
    pub on_ramp: usize,
    /// Indices (into the step set) of the negative steps used.
    pub negative_steps: Vec<usize>,
    /// Optimiser's stop reason for the negative-step fit and its evaluations.
    pub termination: String,
    /// Residual evaluations of the negative-step fit.
    pub evaluations: usize,
    /// Whole-record cross-check (K, τz, τp1, τp2, r with standard errors and RMSE).
    pub trajectory: Option<Result<TrajectoryFit, String>>,
    /// The identified parameters applied to the base set.
    pub parameters: Parameters,
}

/// Identifies K, τz, τp1, τp2 and r from the steps of `set`; `base` supplies the others.
pub fn fit_dynamics(
    set: &StepSet,
    base: Parameters,
    options: &DynamicsOptions,
) -> Result<DynamicsFit, String> {
    let negative: Vec<usize> = (0..set.steps.len())
        .filter(|&k| set.steps[k].sign() == Sign::Negative)
        .collect();
    let positive: Vec<usize> = (0..set.steps.len())
        .filter(|&k| set.steps[k].sign() == Sign::Positive)
        .collect();
    if negative.len() < 2 {
        return Err(format!(
            "{} negative step(s) during steady running; at least 2 are needed for K, τz, τp1, τp2",
            negative.len()
        ));
    }
    // Start values: the mean negative response, and the initial slopes of the positive steps.
    let r0 = initial_ramp(set, &positive, &base);
    let start = Parameters {
        ramp_up_limit: r0,
        ..initial_guess(set, &negative, base)?
    };
    // Stage 1 on the negative steps whose window the rate limit does not touch: there the
    // limited model equals the unlimited one, which is simulated with the limit lifted.
    let on_ramp = ramp_rows(set, &start)?;
    let mut clean: Vec<usize> = negative
        .iter()
        .copied()
        .filter(|&k| !touches_ramp(set, &on_ramp, k))
        .collect();
    if clean.len() < 2 {
        return Err(format!(
            "{} negative step(s) clear of the rate limit; at least 2 are needed",
            clean.len()
        ));
    }
    let unlimited = Parameters {
        ramp_up_limit: UNLIMITED_RAMP,
        ..start
    };
    let (mut linear_fit, mut negative_used, negative_outliers) =
        fit_with_outlier_removal(set, &clean, unlimited, Free::Linear, options.outlier_sigmas)?;
    let mut params = Parameters {
        ramp_up_limit: r0,
        ..Free::Linear.apply(&unlimited, &linear_fit.theta)
    };
    // Stage 2: the ramp limit on the positive steps (full model).
    let mut ramp_stage = fit_ramp(set, &positive, params, options);
    if let Ok(Some((fit, _, _))) = &ramp_stage {
        params = Free::Ramp.apply(&params, &fit.theta);
    }
    // Check the stage-1 selection with the identified model; refit if a used step turns out
    // to be touched by the limit.
    let on_ramp = ramp_rows(set, &params)?;
    let touched: Vec<usize> = negative_used
        .iter()
        .copied()
        .filter(|&k| touches_ramp(set, &on_ramp, k))
        .collect();
    if !touched.is_empty() {
        negative_used.retain(|k| !touched.contains(k));
        clean.retain(|k| !touched.contains(k));
        let problem = StepResiduals::steps(set, &negative_used, unlimited, Free::Linear);
        linear_fit = lsq::minimize(&problem, &linear_fit.theta, 100, TOLERANCE, true)
            .map_err(|e| format!("K, τz, τp1, τp2 refit: {e}"))?;
        params = Parameters {
            ramp_up_limit: params.ramp_up_limit,
            ..Free::Linear.apply(&unlimited, &linear_fit.theta)
        };
        ramp_stage = fit_ramp(set, &positive, params, options);
        if let Ok(Some((fit, _, _))) = &ramp_stage {
            params = Free::Ramp.apply(&params, &fit.theta);
        }
    }
    let on_ramp_excluded = negative.len() - clean.len();
    let parameters = params;
    let value = |i: usize| linear_fit.theta[i].exp();
    // θ = ln(x): σ_x = x·σ_θ to first order.
    let estimate = |i: usize| Estimate {
        value: value(i),
        standard_error: value(i) * linear_fit.standard_error(i),
    };
    let mut correlation = [[0.0; 4]; 4];
    for (i, row) in correlation.iter_mut().enumerate() {
        for (j, c) in row.iter_mut().enumerate() {
            *c = linear_fit.correlation(i, j);
        }
    }
    // ln(τz/τp2) = θ1 − θ3: variance C11 + C33 − 2·C13.
    let ratio_se = linear_fit.covariance.as_ref().map_or(f64::INFINITY, |c| {
        (c[(1, 1)] + c[(3, 3)] - 2.0 * c[(1, 3)]).max(0.0).sqrt()
    });
    let ratio = value(1) / value(3);

    // Residuals of the final model, step by step.
    let mut ramp_binding = 0;
    let mut residuals_by_step = step_residuals(set, &negative_used, parameters);
    let (ramp, positive_used, positive_outliers) = match ramp_stage {
        Err(e) => (Err(e), Vec::new(), 0),
        Ok(None) => (
            Err("no positive step during steady running".to_string()),
            Vec::new(),
            0,
        ),
        Ok(Some((fit, used, removed))) => {
            residuals_by_step.extend(step_residuals(set, &used, parameters));
            let r = fit.theta[0].exp();
            // The limit is only seen where it binds for several samples: with too few such
            // steps the data bound r from below at best, whatever the local curvature says.
            let on_ramp = ramp_rows(set, &parameters)?;
            let binding = used
                .iter()
                .filter(|&&k| {
                    let step = &set.steps[k];
                    on_ramp[step.segment][step.post.clone()].iter().sum::<f64>()
                        >= MIN_BINDING_SECONDS
                })
                .count();
            let standard_error = if binding >= MIN_BINDING_STEPS {
                r * fit.standard_error(0)
            } else {
                f64::INFINITY
            };
            ramp_binding = binding;
            (
                Ok(Estimate {
                    value: r,
                    standard_error,
                }),
                used,
                removed,
            )
        }
    };

    let pooled = |sign: Option<Sign>| -> Option<f64> {
        let all: Vec<f64> = residuals_by_step
            .iter()
            .filter(|(k, _)| sign.is_none_or(|s| set.steps[*k].sign() == s))
            .flat_map(|(_, r)| r.iter().copied())
            .collect();
        (!all.is_empty()).then(|| stats::rms(&all))
    };
    let mut groups: Vec<GroupRmse> = Vec::new();
    let mut keys: Vec<(Sign, i64)> = residuals_by_step
        .iter()
        .map(|(k, _)| set.steps[*k].group())
        .collect();
    keys.sort();
    keys.dedup();
    for key in keys {
        let members: Vec<&(usize, Vec<f64>)> = residuals_by_step
            .iter()
            .filter(|(k, _)| set.steps[*k].group() == key)
            .collect();
        let all: Vec<f64> = members
            .iter()
            .flat_map(|(_, r)| r.iter().copied())
            .collect();
        groups.push(GroupRmse {
            sign: key.0,
            size: key.1,
            steps: members.len(),
            rmse: stats::rms(&all),
        });
    }

    let trajectory = options.trajectory.then(|| {
        let problem = StepResiduals::trajectory(set, parameters, options.settle);
        lsq::minimize(&problem, &Free::All.theta(&parameters), 50, TOLERANCE, true).map(|fit| {
            let p = Free::All.apply(&parameters, &fit.theta);
            let values = [
                p.gain,
                p.tau_zero,
                p.tau_pole1,
                p.tau_pole2,
                p.ramp_up_limit,
            ];
            let se: [f64; 5] = std::array::from_fn(|i| values[i] * fit.standard_error(i));
            (p, se, fit.rmse())
        })
    });

    Ok(DynamicsFit {
        gain: estimate(0),
        tau_zero: estimate(1),
        tau_pole1: estimate(2),
        tau_pole2: estimate(3),
        ratio_zero_pole2: Estimate {
            value: ratio,
            standard_error: ratio * ratio_se,
        },
        correlation,
        ramp,
        rmse_negative: pooled(Some(Sign::Negative)).unwrap_or(f64::NAN),
        rmse_positive: pooled(Some(Sign::Positive)),
        rmse_total: pooled(None).unwrap_or(f64::NAN),
        groups,
        used: (negative_used.len(), positive_used.len()),
        outliers: (negative_outliers, positive_outliers),
        on_ramp: on_ramp_excluded,
        ramp_binding,
        negative_steps: negative_used,
        termination: linear_fit.termination.clone(),
        evaluations: linear_fit.evaluations,
        trajectory,
        parameters,
    })
}

/// Residuals of the final model, per step.
fn step_residuals(set: &StepSet, steps: &[usize], params: Parameters) -> Vec<(usize, Vec<f64>)> {
    let problem = StepResiduals::steps(set, steps, params, Free::Ramp);
    let mut r = Vec::new();
    if !problem.residuals(&Free::Ramp.theta(&params), &mut r) {
        return Vec::new();
    }
    problem
        .layout()
        .into_iter()
        .map(|(k, range)| (k, r[range].to_vec()))
        .collect()
}

/// The ramp limit from the positive steps with the other parameters fixed: the fit, the
/// steps used and the outliers removed (`None` without positive steps).
fn fit_ramp(
    set: &StepSet,
    positive: &[usize],
    params: Parameters,
    options: &DynamicsOptions,
) -> Result<Option<(Fit, Vec<usize>, usize)>, String> {
    if positive.is_empty() {
        return Ok(None);
    }
    fit_with_outlier_removal(set, positive, params, Free::Ramp, options.outlier_sigmas).map(Some)
}

/// Per segment, the time [s] during which the rate limit binds in the interval ending at
/// each row.
fn ramp_rows(set: &StepSet, params: &Parameters) -> Result<Vec<Vec<f64>>, String> {
    set.segments
        .iter()
        .map(|seg| {
            let mut module = Module::new(*params, seg.setpoint[0]).map_err(|e| e.to_string())?;
            let mut rows = vec![0.0];
            for n in 1..seg.len() {
                let report = module
                    .step(seg.setpoint[n], seg.time[n] - seg.time[n - 1])
                    .map_err(|e| e.to_string())?;
                rows.push(report.ramp_time);
            }
            Ok(rows)
        })
        .collect()
}

/// True if the rate limit binds anywhere in a negative step's pre-window or response, or in
/// a positive step's pre-window.
fn touches_ramp(set: &StepSet, on_ramp: &[Vec<f64>], k: usize) -> bool {
    let step = &set.steps[k];
    let end = if step.sign() == Sign::Negative {
        step.post.end
    } else {
        step.post.start
    };
    on_ramp[step.segment][step.pre.start..end]
        .iter()
        .any(|&seconds| seconds > 0.0)
}

/// Fits loosely, removes steps whose RMSE is an outlier, and fits tightly from the first
/// optimum.
/// Returns the fit, the steps kept and how many were removed.
fn fit_with_outlier_removal(
    set: &StepSet,
    steps: &[usize],
    start: Parameters,
    free: Free,
    sigmas: f64,
) -> Result<(Fit, Vec<usize>, usize), String> {
    let what = match free {
        Free::Ramp => "ramp-limit fit (positive steps)",
        _ => "K, τz, τp1, τp2 fit (negative steps)",
    };
    let problem = StepResiduals::steps(set, steps, start, free);
    let first = lsq::minimize(&problem, &free.theta(&start), 100, LOOSE_TOLERANCE, false)
        .map_err(|e| format!("{what}: {e}"))?;
    let per_step: Vec<(usize, f64)> = problem
        .layout()
        .into_iter()
        .map(|(k, range)| (k, stats::rms(&first.residuals[range])))
        .collect();
    let rmses: Vec<f64> = per_step.iter().map(|(_, r)| *r).collect();
    let limit = stats::median(&rmses) + sigmas * stats::robust_sigma(&rmses);
    let kept: Vec<usize> = per_step
        .iter()
        .filter(|(_, r)| *r <= limit)
        .map(|(k, _)| *k)
        .collect();
    let removed = steps.len() - kept.len();
    let (kept, removed) = if removed == 0 || kept.len() < 2 || rmses.len() < 5 {
        (steps.to_vec(), 0)
    } else {
        (kept, removed)
    };
    let problem = StepResiduals::steps(set, &kept, start, free);
    let second = lsq::minimize(&problem, &first.theta, 100, TOLERANCE, true)
        .map_err(|e| format!("{what} without outliers: {e}"))?;
    Ok((second, kept, removed))
}

/// Start values of K, τz, τp1, τp2: the mean normalised negative-step response
/// g(τ) = (I − mean_W I)/Δu on a 1 s grid up to 600 s, matched by K(1 − a e^(−τ/τp1) − b e^(−τ/τp2))
/// over a logarithmic grid of (τp1, τp2) with the amplitudes solved linearly.
fn initial_guess(set: &StepSet, steps: &[usize], base: Parameters) -> Result<Parameters, String> {
    const HORIZON: usize = 600;
    let mut sum = vec![0.0; HORIZON + 1];
    let mut count = vec![0usize; HORIZON + 1];
    for &k in steps {
        let step = &set.steps[k];
        let seg = &set.segments[step.segment];
        let t0 = seg.time[step.before];
        for i in step.post.clone() {
            let lag = (seg.time[i] - t0).round();
            if lag >= 1.0 && lag <= HORIZON as f64 {
                sum[lag as usize] += (seg.current[i] - step.pre_mean) / step.size();
                count[lag as usize] += 1;
            }
        }
    }
    let points: Vec<(f64, f64)> = (1..=HORIZON)
        .filter(|&l| count[l] > 0)
        .map(|l| (l as f64, sum[l] / count[l] as f64))
        .collect();
    if points.len() < 8 {
        return Err("the negative steps hold too few samples for a start value".into());
    }
    let grid = |lo: f64, hi: f64, n: usize| -> Vec<f64> {
        (0..n)
            .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
            .collect()
    };
    let basis =
        |tau: f64| -> Vec<f64> { points.iter().map(|(t, _)| 1.0 - (-t / tau).exp()).collect() };
    let fast: Vec<(f64, Vec<f64>)> = grid(0.2, 60.0, 25)
        .into_iter()
        .map(|t| (t, basis(t)))
        .collect();
    let slow: Vec<(f64, Vec<f64>)> = grid(5.0, 3000.0, 31)
        .into_iter()
        .map(|t| (t, basis(t)))
        .collect();
    let y: Vec<f64> = points.iter().map(|(_, g)| *g).collect();
    let mut best: Option<(f64, f64, f64, f64, f64)> = None;
    for (t1, f1) in &fast {
        for (t2, f2) in &slow {
            if *t2 < 1.5 * t1 {
                continue;
            }
            let (mut s11, mut s12, mut s22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for i in 0..y.len() {
                s11 += f1[i] * f1[i];
                s12 += f1[i] * f2[i];
                s22 += f2[i] * f2[i];
                b1 += f1[i] * y[i];
                b2 += f2[i] * y[i];
            }
            let det = s11 * s22 - s12 * s12;
            if det.abs() < 1e-12 * s11 * s22 {
                continue;
            }
            let c1 = (b1 * s22 - b2 * s12) / det;
            let c2 = (s11 * b2 - s12 * b1) / det;
            if c1 + c2 <= 0.0 {
                continue;
            }
            let rss: f64 = (0..y.len())
                .map(|i| (y[i] - c1 * f1[i] - c2 * f2[i]).powi(2))
                .sum();
            if best.is_none_or(|b| rss < b.0) {
                best = Some((rss, *t1, *t2, c1, c2));
            }
        }
    }
    let (_, t1, t2, c1, c2) =
        best.ok_or("no start value matches the mean negative-step response")?;
    let gain = c1 + c2;
    let a = c1 / gain;
    let tau_zero = (t1 + a * (t2 - t1)).max(0.05 * t2);
    Ok(Parameters {
        gain,
        tau_zero,
        tau_pole1: t1,
        tau_pole2: t2,
        ..base
    })
}

/// Start value of r: the median initial slope (I(τ) − mean_W I)/τ over the first ≤ 6 s of the
/// larger half of the positive steps [A/s].
fn initial_ramp(set: &StepSet, steps: &[usize], params: &Parameters) -> f64 {
    let sizes: Vec<f64> = steps.iter().map(|&k| set.steps[k].size()).collect();
    let big = stats::median(&sizes);
    let slopes: Vec<f64> = steps
        .iter()
        .filter(|&&k| set.steps[k].size() >= big)
        .filter_map(|&k| {
            let step = &set.steps[k];
            let seg = &set.segments[step.segment];
            let t0 = seg.time[step.before];
            let i = step
                .post
                .clone()
                .take_while(|&i| seg.time[i] - t0 <= 6.0)
                .last()?;
            Some((seg.current[i] - step.pre_mean) / (seg.time[i] - t0))
        })
        .filter(|s| *s > 0.0)
        .collect();
    let r = stats::median(&slopes);
    if r.is_finite() && r > 0.0 {
        r
    } else {
        params.gain
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segments::{find_steps, Segment, StepOptions};
    use crate::synthetic::CampaignSpec;

    /// A noise-free segment: the model itself driven through a schedule of levels
    /// (row n's setpoint acts over (t[n−1], t[n]]).
    fn segment(truth: &Parameters, levels: &[(usize, f64)]) -> Segment {
        let mut module = Module::new(*truth, levels[0].1).unwrap();
        let mut seg = Segment {
            source: "test".into(),
            time: vec![],
            setpoint: vec![],
            current: vec![],
        };
        let mut t = 0.0;
        for &(rows, u) in levels {
            for _ in 0..rows {
                if !seg.time.is_empty() {
                    module.step(u, 1.0).unwrap();
                    t += 1.0;
                }
                seg.time.push(t);
                seg.setpoint.push(u);
                seg.current.push(module.current());
            }
        }
        seg
    }

    fn schedule() -> Vec<(usize, f64)> {
        vec![
            (900, 80.0),
            (700, 65.0),
            (300, 95.0),
            (700, 70.0),
            (500, 60.0),
            (800, 100.0),
            (600, 75.0),
        ]
    }

    #[test]
    fn residuals_vanish_at_the_truth_with_the_timing_convention() {
        let truth = CampaignSpec::test_truth();
        let set = find_steps(vec![segment(&truth, &schedule())], &StepOptions::default());
        assert_eq!(set.steps.len(), 6);
        // Time zero of each step is the sample before the first row with the new setpoint.
        assert_eq!(set.steps[0].before, 899);
        assert_eq!(set.steps[0].post.start, 900);
        let all: Vec<usize> = (0..set.steps.len()).collect();
        let problem = StepResiduals::steps(&set, &all, truth, Free::All);
        let mut r = Vec::new();
        assert!(problem.residuals(&Free::All.theta(&truth), &mut r));
        assert!(
            r.iter().all(|x| x.abs() < 1e-9),
            "max {}",
            r.iter().fold(0.0f64, |m, x| m.max(x.abs()))
        );
    }

    #[test]
    fn exact_jacobian_matches_differences_through_the_model() {
        let truth = CampaignSpec::test_truth();
        let set = find_steps(vec![segment(&truth, &schedule())], &StepOptions::default());
        let negative: Vec<usize> = (0..set.steps.len())
            .filter(|&k| set.steps[k].sign() == Sign::Negative)
            .collect();
        let base = Parameters {
            ramp_up_limit: UNLIMITED_RAMP,
            gain: 0.5,
            tau_zero: 70.0,
            tau_pole1: 3.0,
            tau_pole2: 110.0,
            ..truth
        };
        let problem = StepResiduals::steps(&set, &negative, base, Free::Linear);
        let theta = Free::Linear.theta(&base);
        let exact = problem.exact_jacobian(&theta).unwrap();
        let mut plus = Vec::new();
        let mut minus = Vec::new();
        for j in 0..4 {
            let h = 1e-6;
            let mut t = theta.clone();
            t[j] += h;
            assert!(problem.residuals(&t, &mut plus));
            t[j] -= 2.0 * h;
            assert!(problem.residuals(&t, &mut minus));
            let scale = exact.column(j).amax();
            for i in 0..plus.len() {
                let fd = (plus[i] - minus[i]) / (2.0 * h);
                assert!(
                    (fd - exact[(i, j)]).abs() < 1e-6 * scale.max(1.0),
                    "column {j} row {i}: {fd} vs {}",
                    exact[(i, j)]
                );
            }
        }
    }

    #[test]
    fn noise_free_steps_give_back_the_truth() {
        let truth = CampaignSpec::test_truth();
        let set = find_steps(vec![segment(&truth, &schedule())], &StepOptions::default());
        let start = Parameters {
            gain: 0.45,
            tau_zero: 60.0,
            tau_pole1: 4.0,
            tau_pole2: 140.0,
            ramp_up_limit: 0.3,
            ..truth
        };
        let fit = fit_dynamics(&set, start, &DynamicsOptions::default()).unwrap();
        let p = fit.parameters;
        for (got, want) in [
            (p.gain, truth.gain),
            (p.tau_zero, truth.tau_zero),
            (p.tau_pole1, truth.tau_pole1),
            (p.tau_pole2, truth.tau_pole2),
            (p.ramp_up_limit, truth.ramp_up_limit),
        ] {
            assert!((got / want - 1.0).abs() < 1e-6, "{got} vs {want}");
        }
        assert!(fit.rmse_total < 1e-6);
    }
}
