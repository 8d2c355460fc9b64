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
    pub fn residuals(
        &self,
        set: &StepSet,
        plan: &[PlanEntry],
        out: &mut Vec<f64>,
        jac: Option<&mut [Vec<f64>]>,
    ) -> bool {
        out.clear();
        let n = self.taus.len();
        if !(1..=3).contains(&n)
            || self.weights.len() != n
            || !(self.gain.is_finite()
                && self.taus.iter().all(|t| t.is_finite() && *t > 0.0)
                && self.weights.iter().all(|w| w.is_finite()))
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
                scope.spawn(|| {
                    self.pass(set, tail, &mut tail_out, want.then_some(&mut tail_jac[..]))
                });
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

    /// One thread's share, dispatched on the order so that the per-row loops unroll.
    fn pass(
        &self,
        set: &StepSet,
        plan: &[PlanEntry],
        out: &mut Vec<f64>,
        jac: Option<&mut [Vec<f64>]>,
    ) {
        match self.taus.len() {
            1 => self.pass_n::<1>(set, plan, out, jac),
            2 => self.pass_n::<2>(set, plan, out, jac),
            _ => self.pass_n::<3>(set, plan, out, jac),
        }
    }

    /// Simulates each segment once and streams the residuals (and derivative columns) of its
    /// steps, whose pre-step windows and responses are each disjoint and ordered in time, so
    /// no per-row buffer is kept.
    fn pass_n<const N: usize>(
        &self,
        set: &StepSet,
        plan: &[PlanEntry],
        out: &mut Vec<f64>,
        mut jac: Option<&mut [Vec<f64>]>,
    ) {
        let (lo, hi) = self.window;
        let taus: [f64; N] = std::array::from_fn(|i| self.taus[i]);
        let w: [f64; N] = std::array::from_fn(|i| self.weights[i]);
        let want = jac.is_some();
        let mut decay = [0.0; N];
        let mut growth = [0.0; N];
        for (seg_index, len, list) in plan {
            let seg = &set.segments[*seg_index];
            // Window bounds of the segment's steps, in time order.
            let bounds: Vec<[usize; 4]> = list
                .iter()
                .map(|&k| {
                    let s = &set.steps[k];
                    [s.pre.start, s.pre.end, s.post.start, s.post.end]
                })
                .collect();
            let y0 = self.gain * seg.setpoint[0].clamp(lo, hi);
            let mut z = [y0; N];
            let mut sens = [0.0f64; N];
            // Pre-window sums of I and of its 2N derivatives, per step.
            let mut pre_sum = vec![[0.0f64; 7]; list.len()];
            let (mut next_pre, mut next_post) = (0usize, 0usize);
            let mut last_h = f64::NAN;
            let mut row = [0.0f64; 7];
            for r in 0..*len {
                if r > 0 {
                    let h = seg.time[r] - seg.time[r - 1];
                    if h != last_h {
                        for i in 0..N {
                            decay[i] = (-h / taus[i]).exp();
                            growth[i] = decay[i] * h / (taus[i] * taus[i]);
                        }
                        last_h = h;
                    }
                    let y = self.gain * seg.setpoint[r].clamp(lo, hi);
                    for i in 0..N {
                        let dev = z[i] - y;
                        sens[i] = sens[i] * decay[i] + dev * growth[i];
                        z[i] = y + dev * decay[i];
                    }
                }
                let mut current = 0.0;
                for i in 0..N {
                    current += w[i] * z[i];
                }
                // row: ∂I/∂ln K, ∂I/∂ln τᵢ, ∂I/∂wⱼ, then I itself.
                row[6] = current;
                if want {
                    row[0] = current;
                    for i in 0..N {
                        row[1 + i] = w[i] * taus[i] * sens[i];
                    }
                    for j in 0..N - 1 {
                        row[N + 1 + j] = z[j] - z[N - 1];
                    }
                }
                while next_pre < bounds.len() && bounds[next_pre][1] <= r {
                    next_pre += 1;
                }
                if next_pre < bounds.len() && bounds[next_pre][0] <= r {
                    let sums = &mut pre_sum[next_pre];
                    for c in 0..7 {
                        sums[c] += row[c];
                    }
                }
                while next_post < bounds.len() && bounds[next_post][3] <= r {
                    next_post += 1;
                }
                if next_post < bounds.len() && bounds[next_post][2] <= r {
                    let step = &set.steps[list[next_post]];
                    let count = (bounds[next_post][1] - bounds[next_post][0]) as f64;
                    let sums = &pre_sum[next_post];
                    out.push((seg.current[r] - step.pre_mean) - (current - sums[6] / count));
                    if let Some(jac) = jac.as_deref_mut() {
                        for (c, column) in jac.iter_mut().enumerate() {
                            column.push(sums[c] / count - row[c]);
                        }
                    }
                }
            }
        }
    }
}
