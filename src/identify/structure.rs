//! Structure check: first- and third-order candidates beside the paper's second order, fitted
//! to the same negative-step residuals, compared by RMSE and AICc (see [`stats::aicc`]).
//!
//! Candidate of order n (relative degree one, n − 1 zeros, unit static gain), in modal form:
//!   G_n(s) = K · Σᵢ wᵢ/(τᵢ s + 1),  Σ wᵢ = 1,
//! parameters ln K, ln τ₁…ln τₙ, w₁…wₙ₋₁ (k = 2n). For n = 2 this is the paper's G(s) with
//! w₁ = (τz − τp1)/(τp2 − τp1); the second-order row is the model's own fit. The candidates
//! are simulated exactly for a setpoint held over each sample interval (as the model is):
//!   zᵢ ← K·u + (zᵢ − K·u)·e^(−h/τᵢ),  I = Σ wᵢ zᵢ,
//! from steady state at the segment's first setpoint. They are never used as the model.

use nalgebra::DMatrix;

use crate::model::Parameters;

use super::dynamics::DynamicsFit;
use super::lsq::{self, Residuals};
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
        self.candidates.iter().min_by(|a, b| a.aicc.total_cmp(&b.aicc)).map(|c| c.order)
    }
}

/// Residuals of a modal candidate over the chosen negative steps.
struct ModalResiduals<'a> {
    set: &'a StepSet,
    order: usize,
    window: (f64, f64),
    plan: Vec<(usize, usize, Vec<usize>)>,
}

impl<'a> ModalResiduals<'a> {
    fn new(set: &'a StepSet, steps: &[usize], order: usize, window: (f64, f64)) -> Self {
        let mut sorted = steps.to_vec();
        sorted.sort_by_key(|&k| (set.steps[k].segment, set.steps[k].before));
        let mut plan: Vec<(usize, usize, Vec<usize>)> = Vec::new();
        for k in sorted {
            let s = &set.steps[k];
            match plan.last_mut() {
                Some((seg, len, list)) if *seg == s.segment => {
                    *len = (*len).max(s.post.end);
                    list.push(k);
                }
                _ => plan.push((s.segment, s.post.end, vec![k])),
            }
        }
        ModalResiduals { set, order, window, plan }
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

impl ModalResiduals<'_> {
    /// Residuals and, if `jac` is given, their derivatives (one vector per parameter) for
    /// the segments of `plan`. Sensitivities follow the exact update: with d = e^(−h/τ),
    ///   ∂zᵢ/∂τᵢ ← ∂zᵢ/∂τᵢ·d + (zᵢ − K·u)·d·h/τᵢ²,
    /// ∂I/∂ln K = I, ∂I/∂ln τᵢ = wᵢ τᵢ ∂zᵢ/∂τᵢ, ∂I/∂wⱼ = zⱼ − zₙ; and ∂r = −(∂I − mean_W ∂I).
    fn evaluate(&self, plan: &[(usize, usize, Vec<usize>)], theta: &[f64], out: &mut Vec<f64>, mut jac: Option<&mut [Vec<f64>]>) -> bool {
        let (gain, taus, w) = self.unpack(theta);
        if !(gain.is_finite() && taus.iter().all(|t| t.is_finite() && *t > 0.0) && w.iter().all(|x| x.is_finite())) {
            return false;
        }
        let n = self.order;
        let k = 2 * n;
        let want = jac.is_some();
        let (lo, hi) = self.window;
        let longest = plan.iter().map(|(_, len, _)| *len).max().unwrap_or(0);
        let mut model = Vec::with_capacity(longest);
        let mut deriv: Vec<Vec<f64>> = (0..if want { k } else { 0 }).map(|_| Vec::with_capacity(longest)).collect();
        let mut z = [0.0; 3];
        let mut sens: [f64; 3];
        let mut decay = [0.0; 3];
        let mut growth = [0.0; 3];
        for (seg_index, len, list) in plan {
            let seg = &self.set.segments[*seg_index];
            let y0 = gain * seg.setpoint[0].clamp(lo, hi);
            z[..n].iter_mut().for_each(|zi| *zi = y0);
            sens = [0.0; 3];
            model.clear();
            deriv.iter_mut().for_each(Vec::clear);
            let mut last_h = f64::NAN;
            for r in 0..*len {
                if r > 0 {
                    let h = seg.time[r] - seg.time[r - 1];
                    if h != last_h {
                        for i in 0..n {
                            decay[i] = (-h / taus[i]).exp();
                            growth[i] = decay[i] * h / (taus[i] * taus[i]);
                        }
                        last_h = h;
                    }
                    let y = gain * seg.setpoint[r].clamp(lo, hi);
                    for i in 0..n {
                        let dev = z[i] - y;
                        sens[i] = sens[i] * decay[i] + dev * growth[i];
                        z[i] = y + dev * decay[i];
                    }
                }
                let mut current = 0.0;
                for i in 0..n {
                    current += w[i] * z[i];
                }
                model.push(current);
                if want {
                    deriv[0].push(current);
                    for i in 0..n {
                        deriv[1 + i].push(w[i] * taus[i] * sens[i]);
                    }
                    for j in 0..n - 1 {
                        deriv[n + 1 + j].push(z[j] - z[n - 1]);
                    }
                }
            }
            for &s in list {
                let step = &self.set.steps[s];
                let model_pre = stats::mean(&model[step.pre.clone()]);
                out.extend(step.post.clone().map(|i| (seg.current[i] - step.pre_mean) - (model[i] - model_pre)));
                if let Some(jac) = jac.as_deref_mut() {
                    for (column, d) in jac.iter_mut().zip(&deriv) {
                        let pre = stats::mean(&d[step.pre.clone()]);
                        column.extend(d[step.post.clone()].iter().map(|x| pre - x));
                    }
                }
            }
        }
        true
    }

    /// [`ModalResiduals::evaluate`] over the whole plan, the segments split over two threads.
    fn evaluate_all(&self, theta: &[f64], out: &mut Vec<f64>, jac: Option<&mut [Vec<f64>]>) -> bool {
        out.clear();
        let split = self.plan.len() / 2;
        let k = 2 * self.order;
        if split == 0 {
            return self.evaluate(&self.plan, theta, out, jac);
        }
        let (head, tail) = self.plan.split_at(split);
        let want = jac.is_some();
        let mut tail_out = Vec::new();
        let mut tail_jac: Vec<Vec<f64>> = vec![Vec::new(); k];
        let (ok_head, ok_tail, head_jac) = std::thread::scope(|scope| {
            let handle = scope.spawn(|| self.evaluate(tail, theta, &mut tail_out, want.then_some(&mut tail_jac[..])));
            let mut head_jac: Vec<Vec<f64>> = vec![Vec::new(); k];
            let ok = self.evaluate(head, theta, out, want.then_some(&mut head_jac[..]));
            (ok, handle.join().unwrap_or(false), head_jac)
        });
        out.extend_from_slice(&tail_out);
        if let Some(jac) = jac {
            for ((column, h), t) in jac.iter_mut().zip(head_jac).zip(&tail_jac) {
                *column = h;
                column.extend_from_slice(t);
            }
        }
        ok_head && ok_tail
    }
}

impl Residuals for ModalResiduals<'_> {
    fn parameters(&self) -> usize {
        2 * self.order
    }

    fn residuals(&self, theta: &[f64], out: &mut Vec<f64>) -> bool {
        self.evaluate_all(theta, out, None)
    }

    fn exact_jacobian(&self, theta: &[f64]) -> Option<DMatrix<f64>> {
        let mut out = Vec::new();
        let mut columns: Vec<Vec<f64>> = vec![Vec::new(); 2 * self.order];
        if !self.evaluate_all(theta, &mut out, Some(&mut columns[..])) {
            return None;
        }
        Some(DMatrix::from_iterator(out.len(), 2 * self.order, columns.into_iter().flatten()))
    }
}

/// Relative tolerance of the candidates' fits: AICc differences of one unit correspond to
/// relative changes of the sum of squares of ~1/N, far above this (the sum of squares is converged to ~1e-6 relative, AICc to ~0.1 for N = 1e5).
const TOLERANCE: f64 = 1e-6;

/// Fits orders 1 and 3 on the negative steps used by `dynamics` and lists them with its
/// second order.
pub fn check_structure(set: &StepSet, dynamics: &DynamicsFit, params: &Parameters) -> StructureCheck {
    let steps = &dynamics.negative_steps;
    let window = (params.min_setpoint, params.max_setpoint);
    let p = &dynamics.parameters;
    let a = (p.tau_zero - p.tau_pole1) / (p.tau_pole2 - p.tau_pole1);
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
        // One pole at the response's mean time constant a·τp1 + (1 − a)·τp2.
        (1, vec![p.gain.ln(), (a * p.tau_pole1 + (1.0 - a) * p.tau_pole2).ln()]),
        // The second order plus a small third mode between the two poles.
        (
            3,
            vec![
                p.gain.ln(),
                p.tau_pole1.ln(),
                p.tau_pole2.ln(),
                (p.tau_pole1 * p.tau_pole2).sqrt().ln(),
                0.95 * a,
                0.95 * (1.0 - a),
            ],
        ),
    ];
    for (order, theta0) in starts {
        let problem = ModalResiduals::new(set, steps, order, window);
        match lsq::minimize(&problem, &theta0, 30, TOLERANCE) {
            Ok(fit) => {
                let (_, mut taus, _) = problem.unpack(&fit.theta);
                taus.sort_by(f64::total_cmp);
                candidates.push(Candidate {
                    order,
                    parameters: 2 * order,
                    rmse: fit.rmse(),
                    aicc: stats::aicc(fit.rss, fit.residuals.len(), 2 * order),
                    time_constants: taus,
                });
            }
            Err(e) => failures.push((order, e)),
        }
    }
    candidates.sort_by_key(|c| c.order);
    StructureCheck { candidates, residuals: n_residuals, failures }
}
