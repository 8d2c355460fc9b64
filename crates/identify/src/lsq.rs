//! Nonlinear least squares: the `levenberg-marquardt` crate (MINPACK's trust-region
//! Levenberg–Marquardt) with a finite-difference Jacobian, and parameter uncertainties from
//! the Jacobian at the optimum.
//!
//! Minimises S(θ) = Σ rᵢ(θ)². At the optimum, with J = ∂r/∂θ (exact or forward differences),
//! the covariance of θ is s²·(JᵀJ)⁻¹ (s² = S/(N − k)) for independent residuals, or the
//! cluster-robust sandwich for residuals correlated within groups (see [`Residuals::clusters`]);
//! standard errors are the square roots of its diagonal and correlations its normalised
//! entries.

use std::ops::Range;

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DMatrix, DVector, Dyn, Owned};

/// A residual function r(θ) of fixed length.
pub trait Residuals: Sync {
    /// Number of parameters k.
    fn parameters(&self) -> usize;
    /// Writes r(θ) into `out` (cleared first); false where θ is not admissible.
    fn residuals(&self, theta: &[f64], out: &mut Vec<f64>) -> bool;
    /// The exact Jacobian ∂r/∂θ, where the problem provides one (`None`: finite differences).
    fn exact_jacobian(&self, _theta: &[f64]) -> Option<DMatrix<f64>> {
        None
    }
    /// Groups of residuals whose errors may be correlated within but not across groups
    /// (e.g. one step response, which shares its pre-step mean); `None`: independent.
    fn clusters(&self) -> Option<Vec<Range<usize>>> {
        None
    }
}

/// Result of a least-squares fit.
#[derive(Clone, Debug)]
pub struct Fit {
    /// Parameters at the optimum.
    pub theta: Vec<f64>,
    /// Residuals at the optimum.
    pub residuals: Vec<f64>,
    /// Sum of squared residuals S.
    pub rss: f64,
    /// Covariance s²(JᵀJ)⁻¹ of θ; `None` when JᵀJ is singular.
    pub covariance: Option<DMatrix<f64>>,
    /// Residual evaluations made by the optimiser.
    pub evaluations: usize,
    /// The optimiser's reason to stop.
    pub termination: String,
}

impl Fit {
    /// Standard error of θᵢ (infinite when the covariance is unknown).
    pub fn standard_error(&self, i: usize) -> f64 {
        self.covariance
            .as_ref()
            .map_or(f64::INFINITY, |c| c[(i, i)].max(0.0).sqrt())
    }

    /// Correlation of θᵢ and θⱼ (NaN when the covariance is unknown).
    pub fn correlation(&self, i: usize, j: usize) -> f64 {
        self.covariance
            .as_ref()
            .map_or(f64::NAN, |c| c[(i, j)] / (c[(i, i)] * c[(j, j)]).sqrt())
    }

    /// Root mean square residual.
    pub fn rmse(&self) -> f64 {
        (self.rss / self.residuals.len().max(1) as f64).sqrt()
    }
}

/// Finite-difference step on θ, relative to max(|θ|, 1): the residuals are exact closed-form
/// simulations, so forward differences are accurate to ~1e-7 relative.
const FORWARD_STEP: f64 = 1e-7;

/// Minimises Σ r(θ)² from `theta0`, with at most `patience`·(k + 1) residual evaluations and
/// relative tolerance `tolerance` on Σ r² and θ (MINPACK's ftol and xtol); the covariance is
/// computed when `with_covariance`.
pub fn minimize<R: Residuals>(
    model: &R,
    theta0: &[f64],
    patience: usize,
    tolerance: f64,
    with_covariance: bool,
) -> Result<Fit, String> {
    let k = model.parameters();
    if theta0.len() != k {
        return Err(format!("{} start values for {k} parameters", theta0.len()));
    }
    let mut start = Vec::new();
    if !model.residuals(theta0, &mut start) {
        return Err(format!("the start point {theta0:?} is not admissible"));
    }
    if start.len() <= k {
        return Err(format!(
            "{} residuals are too few for {k} parameters",
            start.len()
        ));
    }
    let problem = Problem {
        model,
        theta: DVector::from_column_slice(theta0),
        residuals: Some(DVector::from_vec(start)),
    };
    let solver = LevenbergMarquardt::new()
        .with_patience(patience)
        .with_ftol(tolerance)
        .with_xtol(tolerance)
        .with_gtol(1e-14);
    let (problem, report) = solver.minimize(problem);
    let termination = format!("{:?}", report.termination);
    if report.termination.was_usage_issue()
        && !matches!(
            report.termination,
            levenberg_marquardt::TerminationReason::NoImprovementPossible(_)
        )
    {
        return Err(format!(
            "the optimiser stopped: {}",
            describe(&report.termination)
        ));
    }
    let theta: Vec<f64> = problem.theta.iter().copied().collect();
    // The adapter holds the residuals at its current θ, the optimum.
    let residuals: Vec<f64> = match problem.residuals {
        Some(r) => r.iter().copied().collect(),
        None => {
            return Err(format!(
                "optimiser stopped at an inadmissible point ({termination})"
            ))
        }
    };
    let rss: f64 = residuals.iter().map(|r| r * r).sum();
    if !rss.is_finite() {
        return Err(format!(
            "non-finite residuals at the optimum ({termination})"
        ));
    }
    let covariance = if with_covariance {
        jacobian(model, &theta, &residuals)
            .and_then(|j| covariance(&j, &residuals, model.clusters()))
    } else {
        None
    };
    Ok(Fit {
        theta,
        residuals,
        rss,
        covariance,
        evaluations: report.number_of_evaluations,
        termination,
    })
}

/// The optimiser's reason to stop early, as a sentence.
fn describe(reason: &levenberg_marquardt::TerminationReason) -> String {
    use levenberg_marquardt::TerminationReason as T;
    match reason {
        T::User(what) => format!("the {what} could not be evaluated at a point it tried"),
        T::Numerical(what) => format!("the {what} became infinite or undefined"),
        T::LostPatience => "it ran out of evaluations".into(),
        T::NoParameters => "there are no parameters".into(),
        T::NoResiduals => "there are no residuals".into(),
        T::WrongDimensions(what) => format!("the {what} had the wrong dimensions"),
        other => format!("{other:?}"),
    }
}

/// Covariance of θ at the optimum from the Jacobian J and residuals r.
///
/// Independent residuals: s²(JᵀJ)⁻¹ with s² = Σr²/(N − k). With clusters c (G of them) whose
/// errors may be correlated inside (a step's response shares the noise of its pre-step mean),
/// the cluster-robust sandwich (JᵀJ)⁻¹ (Σ_c g_c g_cᵀ) (JᵀJ)⁻¹ · G/(G − 1), g_c = J_cᵀ r_c.
fn covariance(
    j: &DMatrix<f64>,
    r: &[f64],
    clusters: Option<Vec<Range<usize>>>,
) -> Option<DMatrix<f64>> {
    let k = j.ncols();
    let bread = (j.transpose() * j).try_inverse()?;
    match clusters {
        Some(groups) if groups.len() > k => {
            let mut meat = DMatrix::zeros(k, k);
            for g in &groups {
                let jc = j.rows(g.start, g.len());
                let gc = jc.transpose() * DVector::from_column_slice(&r[g.clone()]);
                meat += &gc * gc.transpose();
            }
            let n = groups.len() as f64;
            Some(&bread * meat * &bread * (n / (n - 1.0)))
        }
        _ => {
            let rss: f64 = r.iter().map(|x| x * x).sum();
            Some(bread * (rss / (r.len() - k) as f64))
        }
    }
}

/// Jacobian ∂r/∂θ: the problem's exact one, or forward differences.
fn jacobian<R: Residuals>(model: &R, theta: &[f64], base: &[f64]) -> Option<DMatrix<f64>> {
    if let Some(j) = model.exact_jacobian(theta) {
        return (j.nrows() == base.len() && j.ncols() == theta.len()).then_some(j);
    }
    let k = theta.len();
    let m = base.len();
    let mut jac = DMatrix::zeros(m, k);
    let mut shifted = theta.to_vec();
    let mut plus = Vec::with_capacity(m);
    for j in 0..k {
        let h = FORWARD_STEP * theta[j].abs().max(1.0);
        shifted[j] = theta[j] + h;
        if !model.residuals(&shifted, &mut plus) || plus.len() != m {
            return None;
        }
        shifted[j] = theta[j];
        for (i, (p, r)) in plus.iter().zip(base).enumerate() {
            jac[(i, j)] = (p - r) / h;
        }
    }
    Some(jac)
}

/// The adapter to `levenberg-marquardt`: caches r(θ) at the current θ, which is also the
/// base point of the forward differences.
struct Problem<'a, R: Residuals> {
    model: &'a R,
    theta: DVector<f64>,
    residuals: Option<DVector<f64>>,
}

impl<R: Residuals> LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_, R> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.theta.copy_from(x);
        let mut out = Vec::new();
        self.residuals = self
            .model
            .residuals(x.as_slice(), &mut out)
            .then(|| DVector::from_vec(out));
    }

    fn params(&self) -> DVector<f64> {
        self.theta.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        self.residuals.clone()
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let base = self.residuals.as_ref()?;
        jacobian(self.model, self.theta.as_slice(), base.as_slice())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y = A·e^(−t/τ) sampled at t = 0..50 with a fixed ±0.01 pattern as noise.
    struct Decay {
        t: Vec<f64>,
        y: Vec<f64>,
    }

    impl Residuals for Decay {
        fn parameters(&self) -> usize {
            2
        }
        fn residuals(&self, theta: &[f64], out: &mut Vec<f64>) -> bool {
            out.clear();
            out.extend(
                self.t
                    .iter()
                    .zip(&self.y)
                    .map(|(t, y)| y - theta[0] * (-t / theta[1]).exp()),
            );
            true
        }
    }

    #[test]
    fn recovers_an_exponential_and_its_uncertainty() {
        let t: Vec<f64> = (0..50).map(f64::from).collect();
        let y = t
            .iter()
            .enumerate()
            .map(|(i, t)| 3.0 * (-t / 7.0).exp() + if i % 2 == 0 { 0.01 } else { -0.01 })
            .collect();
        let fit = minimize(&Decay { t, y }, &[1.0, 2.0], 200, 1e-12, true).unwrap();
        assert!((fit.theta[0] - 3.0).abs() < 0.01, "{:?}", fit.theta);
        assert!((fit.theta[1] - 7.0).abs() < 0.05, "{:?}", fit.theta);
        assert!((fit.rmse() - 0.01).abs() < 0.002);
        let se = fit.standard_error(1);
        assert!(se > 0.0 && se < 0.05, "{se}");
        assert!(fit.correlation(0, 1).abs() < 1.0);
    }
}
