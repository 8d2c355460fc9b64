//! The temperature along a moving current by Gauss–Legendre collocation, with an embedded
//! error estimate.
//!
//! Below or above the setpoint the balance is linear in T: dT/dt = a(t)·T + b(t) with
//! a = α(I)/C and b = β(I)/C ([`HeatBalance::linear`]), I(t) the exact current. The s-stage
//! Gauss method (order 2s) gives its stage values from the linear system
//! (1 − h·A·diag(a)) T = T0 + h·A·b, and the quadratures the energy needs
//! (∫(T − Tn)·I^k dt) from the same stages: as extra components of the ODE they are order 2s
//! too. The 5-stage result (order 10) is taken where it agrees with the 4-stage one (order 8)
//! within the integrator's tolerance (the same per-step tolerance as the integrator's, whose
//! estimate is also that of the lower order); a piece where they disagree is halved, down to
//! a sixteenth of the step. Where that is not enough, and wherever the temperature comes within
//! reach of the setpoint (a regime change to locate), the caller integrates with error control.

use std::sync::OnceLock;

use nalgebra::{Const, DimMin, SMatrix, SVector, ToTypenum};

use super::path::{CurrentPath, ThermalStep, ABSOLUTE_TOLERANCE, RELATIVE_TOLERANCE};
use super::{HeatBalance, Regime};

/// A Gauss–Legendre collocation rule with S stages on [0, 1]: nodes c, weights w and the
/// coefficients A[i][j] = ∫₀^cᵢ Lⱼ(τ) dτ (Lⱼ the Lagrange basis on the nodes).
struct Rule<const S: usize> {
    c: [f64; S],
    w: [f64; S],
    a: SMatrix<f64, S, S>,
    /// The largest gap between consecutive nodes, 0 and 1 included [1].
    gap: f64,
}

impl<const S: usize> Rule<S> {
    /// The rule on `nodes` (ascending, in (0, 1)), its coefficients by integrating the
    /// Lagrange basis exactly (polynomial coefficients).
    fn new(nodes: [f64; S]) -> Self {
        let mut a = SMatrix::<f64, S, S>::zeros();
        let mut w = [0.0; S];
        for j in 0..S {
            // Lⱼ(τ) = Π_{k≠j} (τ − c_k)/(c_j − c_k) as coefficients of τ^0..τ^(S−1).
            let mut poly = [0.0; S];
            poly[0] = 1.0;
            for (degree, k) in (0..S).filter(|&k| k != j).enumerate() {
                let scale = 1.0 / (nodes[j] - nodes[k]);
                for d in (0..=degree).rev() {
                    poly[d + 1] += poly[d] * scale;
                    poly[d] *= -nodes[k] * scale;
                }
            }
            let integral = |x: f64| {
                (0..S)
                    .rev()
                    .fold(0.0, |acc, d| acc * x + poly[d] / (d + 1) as f64)
                    * x
            };
            for i in 0..S {
                a[(i, j)] = integral(nodes[i]);
            }
            w[j] = integral(1.0);
        }
        let gap = (0..=S)
            .map(|k| {
                let lo = if k == 0 { 0.0 } else { nodes[k - 1] };
                let hi = if k == S { 1.0 } else { nodes[k] };
                hi - lo
            })
            .fold(0.0, f64::max);
        Rule {
            c: nodes,
            w,
            a,
            gap,
        }
    }
}

/// 5-stage Gauss nodes: 1/2, 1/2 ∓ (1/6)·√(5 ∓ 2·√(10/7)).
fn gauss5() -> Rule<5> {
    let root = 2.0 * (10.0f64 / 7.0).sqrt();
    let near = (5.0 - root).sqrt() / 6.0;
    let far = (5.0 + root).sqrt() / 6.0;
    Rule::new([0.5 - far, 0.5 - near, 0.5, 0.5 + near, 0.5 + far])
}

/// 4-stage Gauss nodes: 1/2 ∓ ½·√(3/7 ± (2/7)·√(6/5)).
fn gauss4() -> Rule<4> {
    let inner = 2.0 / 7.0 * (6.0f64 / 5.0).sqrt();
    let near = 0.5 * (3.0 / 7.0 - inner).sqrt();
    let far = 0.5 * (3.0 / 7.0 + inner).sqrt();
    Rule::new([0.5 - far, 0.5 - near, 0.5 + near, 0.5 + far])
}

/// What one rule gives over a piece: T at its end, ∫(T − Tn), ∫(T − Tn)·I, ∫(T − Tn)·I²,
/// and bounds of the temperature over the piece: the largest and smallest of the stage and end
/// values, widened by twice the largest stage slope |dT/dt| times the largest gap between them
/// (the temperature cannot pass the setpoint between the nodes unseen).
#[derive(Clone, Copy)]
struct Outcome {
    end: f64,
    integrals: [f64; 3],
    highest: f64,
    lowest: f64,
}

fn solve<const S: usize>(
    rule: &Rule<S>,
    balance: &HeatBalance,
    path: &impl CurrentPath,
    regime: Regime,
    t0: f64,
    start: f64,
    h: f64,
) -> Option<Outcome>
where
    Const<S>: DimMin<Const<S>, Output = Const<S>> + ToTypenum,
{
    let p = &balance.thermal;
    let c = p.heat_capacity;
    let mut current = [0.0; S];
    let mut a_diag = SVector::<f64, S>::zeros();
    let mut b = SVector::<f64, S>::zeros();
    for j in 0..S {
        let tau = start + rule.c[j] * h;
        let i = path.current(tau);
        let (alpha, beta) = balance.drifted(path.drift(tau)).linear(i, regime);
        current[j] = i;
        a_diag[j] = alpha / c;
        b[j] = beta / c;
    }
    // (1 − N)·T = T0·1 + h·A·b with N = h·A·diag(a): ‖N‖ is about h/(Rth·C), tiny for a
    // stack (1e-4 for a second), so T = Σ Nᵏ·rhs converges in a few terms; where it would
    // not (a long step of a fast stack), the LU decomposition.
    let n = rule.a * SMatrix::<f64, S, S>::from_diagonal(&a_diag) * h;
    let rhs = SVector::<f64, S>::repeat(t0) + rule.a * b * h;
    let mut stages = rhs;
    let mut term = rhs;
    let mut converged = false;
    for _ in 0..NEUMANN_TERMS {
        term = n * term;
        stages += term;
        if term.amax() <= f64::EPSILON * 0.25 * stages.amax() {
            converged = true;
            break;
        }
    }
    if !converged {
        stages = (SMatrix::<f64, S, S>::identity() - n).lu().solve(&rhs)?;
    }
    let tn = p.nominal_temperature;
    let (mut end, mut integrals) = (t0, [0.0; 3]);
    let (mut highest, mut lowest, mut slope) = (t0, t0, 0.0f64);
    for j in 0..S {
        let t = stages[j];
        let weight = rule.w[j] * h;
        let rate = a_diag[j] * t + b[j];
        slope = slope.max(rate.abs());
        end += weight * rate;
        let deviation = t - tn;
        integrals[0] += weight * deviation;
        integrals[1] += weight * deviation * current[j];
        integrals[2] += weight * deviation * current[j] * current[j];
        highest = highest.max(t);
        lowest = lowest.min(t);
    }
    let reach = 2.0 * slope * rule.gap * h;
    Some(Outcome {
        end,
        integrals,
        highest: highest.max(end) + reach,
        lowest: lowest.min(end) - reach,
    })
}

/// Terms of the Neumann series before the stage equations are solved by LU instead.
const NEUMANN_TERMS: usize = 8;

/// Most halvings of a step (pieces of h/16 at the shortest).
const MAX_HALVINGS: u32 = 4;

/// The piece [start, start + length] from `t0` [K]: the 5-stage result where the 4-stage one
/// agrees with it within the tolerance, else its two halves in turn (None when halving is
/// exhausted).
fn piece(
    balance: &HeatBalance,
    path: &impl CurrentPath,
    regime: Regime,
    t0: f64,
    start: f64,
    length: f64,
    halvings: u32,
) -> Option<Outcome> {
    static GAUSS4: OnceLock<Rule<4>> = OnceLock::new();
    static GAUSS5: OnceLock<Rule<5>> = OnceLock::new();
    let fine = solve(
        GAUSS5.get_or_init(gauss5),
        balance,
        path,
        regime,
        t0,
        start,
        length,
    )?;
    let coarse = solve(
        GAUSS4.get_or_init(gauss4),
        balance,
        path,
        regime,
        t0,
        start,
        length,
    )?;
    let scale = |x: f64, y: f64| ABSOLUTE_TOLERANCE + RELATIVE_TOLERANCE * x.abs().max(y.abs());
    let agrees = (fine.end - coarse.end).abs() <= scale(fine.end, coarse.end)
        && fine
            .integrals
            .iter()
            .zip(coarse.integrals)
            .all(|(x, y)| (x - y).abs() <= scale(*x, y));
    if agrees {
        return Some(Outcome {
            highest: fine.highest.max(coarse.highest),
            lowest: fine.lowest.min(coarse.lowest),
            ..fine
        });
    }
    if halvings == 0 {
        return None;
    }
    let half = 0.5 * length;
    let first = piece(balance, path, regime, t0, start, half, halvings - 1)?;
    let second = piece(
        balance,
        path,
        regime,
        first.end,
        start + half,
        length - half,
        halvings - 1,
    )?;
    Some(Outcome {
        end: second.end,
        integrals: [0, 1, 2].map(|k| first.integrals[k] + second.integrals[k]),
        highest: first.highest.max(second.highest),
        lowest: first.lowest.min(second.lowest),
    })
}

/// Distance from the setpoint [K] within which the regime may change inside the step: such a
/// step goes to the integrator, which locates the change.
const SETPOINT_MARGIN: f64 = 1e-6;

/// The step of `h` [s] from `t0` [K] along `path` in `regime` (Below or Above), where the
/// temperature stays clear of the setpoint and the two rules agree within the tolerance;
/// None otherwise.
pub(super) fn step(
    balance: &HeatBalance,
    path: &impl CurrentPath,
    regime: Regime,
    t0: f64,
    h: f64,
) -> Option<ThermalStep> {
    if regime == Regime::Held {
        return None;
    }
    let whole = piece(balance, path, regime, t0, 0.0, h, MAX_HALVINGS)?;
    let p = &balance.thermal;
    let clear = match regime {
        Regime::Below => whole.highest < p.cooling_setpoint - SETPOINT_MARGIN,
        _ => whole.lowest > p.cooling_setpoint + SETPOINT_MARGIN,
    };
    if !(clear && whole.end.is_finite()) {
        return None;
    }
    let fine = whole;
    let cooling = balance.thermostat_power(0.0, regime);
    let (cooling_energy, heating_energy) = if cooling < 0.0 && balance.heater > 0.0 {
        (0.0, -cooling * h)
    } else {
        (cooling * h, 0.0)
    };
    Some(ThermalStep {
        temperature: fine.end,
        temperature_integral: fine.integrals[0],
        heat_charge: fine.integrals[1],
        heat_squared: fine.integrals[2],
        cooling_energy,
        heating_energy,
        regime_changes: 0,
    })
}
