//! Structure check: first- and third-order candidates beside the paper's second order, fitted
//! to the same negative-step residuals, compared by RMSE and AICc (see [`stats::aicc`]). Those
//! are the negative steps the dynamics fit used: clear of the rate limit, so the unlimited
//! candidates and the limited model are compared on equal terms.
//!
//! Candidate of order n (relative degree one, n − 1 zeros, unit static gain), in modal form:
//!   G_n(s) = K · Σᵢ wᵢ/(τᵢ s + 1),  Σ wᵢ = 1,
//! parameters ln K, ln τ₁…ln τₙ, w₁…wₙ₋₁ (k = 2n). For n = 2 this is the paper's G(s) with
//! w₁ = (τz − τp1)/(τp2 − τp1); the second-order row is the model's own fit. The candidates
//! are simulated exactly for a setpoint held over each sample interval (as the model is):
//!   zᵢ ← K·u + (zᵢ − K·u)·e^(−h/τᵢ),  I = Σ wᵢ zᵢ,
//! from steady state at the segment's first setpoint. They are never used as the model.

use nalgebra::DMatrix;

use aem_model::Parameters;

use super::dynamics::DynamicsFit;
use super::lsq::{self, Residuals};
use super::modal::{self, Plan};
use super::segments::StepSet;
use super::stats;

/// One candidate's figures.
#[derive(Clone, Debug)]
pub struct Candidate {
    /// Model order n.
    pub order: usize,
    /// Parameters k.
    pub parameters: usize,
    /// RMSE over the negative steps [A].
    pub rmse: f64,
    /// AICc.
    pub aicc: f64,
    /// Fitted pole time constants [s], ascending.
    pub time_constants: Vec<f64>,
}

/// The candidates of orders 1, 2, 3 (those that could be fitted) on N residuals.
#[derive(Clone, Debug)]
pub struct StructureCheck {
    /// The candidates, by order.
    pub candidates: Vec<Candidate>,
    /// Residuals N.
    pub residuals: usize,
    /// Candidates that could not be fitted, with the reason.
    pub failures: Vec<(usize, String)>,
}

impl StructureCheck {
    /// Order with the lowest AICc.
    pub fn best_order(&self) -> Option<usize> {
        self.candidates
            .iter()
            .min_by(|a, b| a.aicc.total_cmp(&b.aicc))
            .map(|c| c.order)
    }
}

/// Residuals of a modal candidate over the chosen negative steps.
struct ModalResiduals<'a> {
    set: &'a StepSet,
    order: usize,
    window: (f64, f64),
    plan: Plan,
}

impl<'a> ModalResiduals<'a> {
    fn new(set: &'a StepSet, steps: &[usize], order: usize, window: (f64, f64)) -> Self {
        ModalResiduals {
            set,
            order,
            window,
            plan: modal::plan(set, steps),
        }
    }

    /// (K, τ, w) from θ.
    fn unpack(&self, theta: &[f64]) -> (f64, Vec<f64>, Vec<f64>) {
        let n = self.order;
        let taus: Vec<f64> = theta[1..=n].iter().map(|t| t.exp()).collect();
        let mut w: Vec<f64> = theta[n + 1..].to_vec();
        w.push(1.0 - w.iter().sum::<f64>());
        (theta[0].exp(), taus, w)
    }
}

impl Residuals for ModalResiduals<'_> {
    fn parameters(&self) -> usize {
        2 * self.order
    }

    fn residuals(&self, theta: &[f64], out: &mut Vec<f64>) -> bool {
        let (gain, taus, w) = self.unpack(theta);
        let modal = modal::Modal {
            gain,
            taus: &taus,
            weights: &w,
            window: self.window,
        };
        modal.residuals(self.set, &self.plan, out, None)
    }

    fn exact_jacobian(&self, theta: &[f64]) -> Option<DMatrix<f64>> {
        let (gain, taus, w) = self.unpack(theta);
        let modal = modal::Modal {
            gain,
            taus: &taus,
            weights: &w,
            window: self.window,
        };
        let mut out = Vec::new();
        let mut columns: Vec<Vec<f64>> = vec![Vec::new(); 2 * self.order];
        if !modal.residuals(self.set, &self.plan, &mut out, Some(&mut columns[..])) {
            return None;
        }
        Some(DMatrix::from_iterator(
            out.len(),
            2 * self.order,
            columns.into_iter().flatten(),
        ))
    }
}

/// Relative tolerance of the candidates' fits: AICc differences of one unit correspond to
/// relative changes of the sum of squares of ~1/N, far above this (the sum of squares is converged to ~1e-6 relative, AICc to ~0.1 for N = 1e5).
const TOLERANCE: f64 = 1e-6;

/// Fits orders 1 and 3 on the negative steps used by `dynamics` and lists them with its
/// second order.
pub fn check_structure(
    set: &StepSet,
    dynamics: &DynamicsFit,
    params: &Parameters,
) -> StructureCheck {
    let steps = &dynamics.negative_steps;
    let window = (params.min_setpoint, params.max_setpoint);
    let p = &dynamics.parameters;
    let (a, b) = p.modal_weights();
    let n_residuals: usize = steps.iter().map(|&k| set.steps[k].post.len()).sum();
    let mut candidates = Vec::new();
    let mut failures = Vec::new();
    // Second order: the model's own fit.
    let rss2 = dynamics.rmse_negative.powi(2) * n_residuals as f64;
    candidates.push(Candidate {
        order: 2,
        parameters: 4,
        rmse: dynamics.rmse_negative,
        aicc: stats::aicc(rss2, n_residuals, 4),
        time_constants: vec![p.tau_pole1.min(p.tau_pole2), p.tau_pole1.max(p.tau_pole2)],
    });
    let starts: [(usize, Vec<f64>); 2] = [
        // The single pole whose step response is closest to the second order's.
        (1, vec![p.gain.ln(), closest_first_order(p).ln()]),
        // The second order plus a small third mode between the two poles.
        (
            3,
            vec![
                p.gain.ln(),
                p.tau_pole1.ln(),
                p.tau_pole2.ln(),
                (p.tau_pole1 * p.tau_pole2).sqrt().ln(),
                0.95 * a,
                0.95 * b,
            ],
        ),
    ];
    // The two candidates are independent: fit them side by side.
    let results: Vec<(usize, Result<Candidate, String>)> = std::thread::scope(|scope| {
        let handles: Vec<_> = starts
            .into_iter()
            .map(|(order, theta0)| {
                scope.spawn(move || {
                    let problem = ModalResiduals::new(set, steps, order, window);
                    let fit = lsq::minimize(&problem, &theta0, 30, TOLERANCE, false)?;
                    let (_, mut taus, _) = problem.unpack(&fit.theta);
                    taus.sort_by(f64::total_cmp);
                    Ok(Candidate {
                        order,
                        parameters: 2 * order,
                        rmse: fit.rmse(),
                        aicc: stats::aicc(fit.rss, fit.residuals.len(), 2 * order),
                        time_constants: taus,
                    })
                })
            })
            .collect();
        handles
            .into_iter()
            .zip([1, 3])
            .map(|(h, order)| {
                (
                    order,
                    h.join()
                        .unwrap_or_else(|_| Err("the fit's thread failed".into())),
                )
            })
            .collect()
    });
    for (order, result) in results {
        match result {
            Ok(c) => candidates.push(c),
            Err(e) => failures.push((order, e)),
        }
    }
    candidates.sort_by_key(|c| c.order);
    StructureCheck {
        candidates,
        residuals: n_residuals,
        failures,
    }
}

/// τ [s] of the first-order step response 1 − e^(−t/τ) closest (least squares over
/// t = 1…600 s) to the second order's 1 − a e^(−t/τp1) − (1 − a) e^(−t/τp2).
fn closest_first_order(p: &Parameters) -> f64 {
    let (a, b) = p.modal_weights();
    let target: Vec<f64> = (1..=600)
        .map(f64::from)
        .map(|t| a * (-t / p.tau_pole1).exp() + b * (-t / p.tau_pole2).exp())
        .collect();
    (0..80)
        .map(|i| 0.5 * 1000f64.powf(f64::from(i) / 79.0))
        .map(|tau| {
            let err: f64 = target
                .iter()
                .enumerate()
                .map(|(t, g)| (g - (-(t as f64 + 1.0) / tau).exp()).powi(2))
                .sum();
            (err, tau)
        })
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map_or(p.tau_pole2, |(_, tau)| tau)
}
