//! Linear modal responses and their exact parameter sensitivities over step windows.
//!
//! A transfer function with distinct real poles and unit static gain, in modal form
//!   G(s) = K · Σᵢ wᵢ/(τᵢ s + 1),  Σ wᵢ = 1,
//! is simulated exactly for a setpoint held over each sample interval (as the model does):
//!   zᵢ ← K·u + (zᵢ − K·u)·dᵢ,  dᵢ = e^(−h/τᵢ),  I = Σ wᵢ zᵢ,
//! from steady state at the segment's first setpoint, with the sensitivities
//!   sᵢ = ∂zᵢ/∂τᵢ ← sᵢ·dᵢ + (zᵢ − K·u)·dᵢ·h/τᵢ²,  sᵢ(0) = 0,
//! so that ∂I/∂ln K = I, ∂I/∂ln τᵢ = wᵢ τᵢ sᵢ and ∂I/∂wⱼ = zⱼ − zₙ (wₙ = 1 − Σⱼ wⱼ).
//! Step residuals are rᵢ = (I_meas − mean_W I_meas) − (I − mean_W I) as in [`super::dynamics`],
//! so ∂r = −(∂I − mean_W ∂I).
//!
//! The paper's G(s) is the case n = 2 with w₁ = (τz − τp1)/(τp2 − τp1): without the rate
//! limit, [`crate::model::Module`] computes exactly this response, which gives the dynamics
//! fit its exact Jacobian. The structure check uses orders 1 and 3.

use super::segments::StepSet;
use super::stats;

/// One segment to simulate: (segment, rows to simulate, steps in it).
pub type PlanEntry = (usize, usize, Vec<usize>);

/// Segments to simulate, in order.
pub type Plan = Vec<PlanEntry>;

/// The plan for `steps`: grouped by segment, in segment and time order.
pub fn plan(set: &StepSet, steps: &[usize]) -> Plan {
    let mut sorted = steps.to_vec();
    sorted.sort_by_key(|&k| (set.steps[k].segment, set.steps[k].before));
    let mut plan: Plan = Vec::new();
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
    plan
}

/// Splits a plan where the simulated rows reach half, for two threads.
pub fn halves(plan: &[PlanEntry]) -> (&[PlanEntry], &[PlanEntry]) {
    let rows: usize = plan.iter().map(|(_, len, _)| len).sum();
    let mut split = 0;
    let mut acc = 0;
    while split < plan.len() && 2 * acc < rows {
        acc += plan[split].1;
        split += 1;
    }
    plan.split_at(split)
}

/// A modal response: gain K [A/%], time constants τᵢ [s] (at most 3), weights wᵢ summing to 1,
/// and the setpoint window [%] that clamps u.
pub struct Modal<'p> {
    /// K [A/%].
    pub gain: f64,
    /// τᵢ [s].
    pub taus: &'p [f64],
    /// wᵢ.
    pub weights: &'p [f64],
    /// Setpoint clamp (min, max) [%].
    pub window: (f64, f64),
}

impl Modal<'_> {
    /// Appends the residuals of the plan's steps to `out` (cleared first) and, if `jac` holds
    /// 2n vectors, their derivatives with respect to (ln K, ln τ₁…ln τₙ, w₁…wₙ₋₁). Segments
    /// are split over two threads. False for a non-finite or non-positive parameter.
    pub fn residuals(&self, set: &StepSet, plan: &[PlanEntry], out: &mut Vec<f64>, jac: Option<&mut [Vec<f64>]>) -> bool {
        out.clear();
        let n = self.taus.len();
        if !(1..=3).contains(&n)
            || self.weights.len() != n
            || !(self.gain.is_finite() && self.taus.iter().all(|t| t.is_finite() && *t > 0.0) && self.weights.iter().all(|w| w.is_finite()))
        {
            return false;
        }
        let (head, tail) = halves(plan);
        let want = jac.is_some();
        let mut tail_out = Vec::new();
        let mut tail_jac: Vec<Vec<f64>> = vec![Vec::new(); 2 * n];
        let mut head_jac: Vec<Vec<f64>> = vec![Vec::new(); 2 * n];
        std::thread::scope(|scope| {
            if tail.is_empty() {
                self.pass(set, head, out, want.then_some(&mut head_jac[..]));
            } else {
                scope.spawn(|| self.pass(set, tail, &mut tail_out, want.then_some(&mut tail_jac[..])));
                self.pass(set, head, out, want.then_some(&mut head_jac[..]));
            }
        });
        out.extend_from_slice(&tail_out);
        if let Some(jac) = jac {
            for ((column, h), t) in jac.iter_mut().zip(head_jac).zip(&tail_jac) {
                *column = h;
                column.extend_from_slice(t);
            }
        }
        true
    }

    fn pass(&self, set: &StepSet, plan: &[PlanEntry], out: &mut Vec<f64>, mut jac: Option<&mut [Vec<f64>]>) {
        let n = self.taus.len();
        let k = 2 * n;
        let want = jac.is_some();
        let (lo, hi) = self.window;
        let (taus, w) = (self.taus, self.weights);
        let longest = plan.iter().map(|(_, len, _)| *len).max().unwrap_or(0);
        let mut model = Vec::with_capacity(longest);
        // Derivatives of I, row-major with stride k (one store per row).
        let mut deriv: Vec<f64> = Vec::with_capacity(if want { longest * k } else { 0 });
        let mut row = [0.0; 6];
        let mut z: [f64; 3];
        let mut sens: [f64; 3];
        let mut decay = [0.0; 3];
        let mut growth = [0.0; 3];
        for (seg_index, len, list) in plan {
            let seg = &set.segments[*seg_index];
            let y0 = self.gain * seg.setpoint[0].clamp(lo, hi);
            z = [y0; 3];
            sens = [0.0; 3];
            model.clear();
            deriv.clear();
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
                    let y = self.gain * seg.setpoint[r].clamp(lo, hi);
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
                    row[0] = current;
                    for i in 0..n {
                        row[1 + i] = w[i] * taus[i] * sens[i];
                    }
                    for j in 0..n - 1 {
                        row[n + 1 + j] = z[j] - z[n - 1];
                    }
                    deriv.extend_from_slice(&row[..k]);
                }
            }
            for &s in list {
                let step = &set.steps[s];
                let model_pre = stats::mean(&model[step.pre.clone()]);
                out.extend(step.post.clone().map(|i| (seg.current[i] - step.pre_mean) - (model[i] - model_pre)));
                if let Some(jac) = jac.as_deref_mut() {
                    let mut pre = [0.0; 6];
                    for i in step.pre.clone() {
                        for c in 0..k {
                            pre[c] += deriv[i * k + c];
                        }
                    }
                    let count = step.pre.len() as f64;
                    pre.iter_mut().for_each(|p| *p /= count);
                    for row in deriv[step.post.start * k..step.post.end * k].chunks_exact(k) {
                        for (c, column) in jac.iter_mut().enumerate() {
                            column.push(pre[c] - row[c]);
                        }
                    }
                }
            }
        }
    }
}
