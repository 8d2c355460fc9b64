//! The voltage's drift with use (the FMU's ageing), from the voltage against consecutive
//! runtime: on the running samples at nominal temperature and pressure (the polarisation
//! filter),
//!
//!   V = V0 + R·I + ρ·H(t) + δs·S(t) + A·g(t; τb, τr),
//!
//! with H the hours run so far [h], S the starts so far, and g the reversible drift of unit
//! amplitude: g' = (1 − g)/τb while running, g' = −g/τr otherwise, g = 0 at the log's start
//! (taken as rested). Between two rows g moves exactly (an exponential), and so do its
//! sensitivities to ln τb and ln τr, which gives the exact Jacobian. Linear in
//! (V0, R, ρ, δs, A) for given time constants: a grid over ln τb × ln τr with linear least
//! squares picks the start, then Levenberg–Marquardt fits all seven ([`crate::lsq`]); 95 %
//! intervals ±1.96 standard errors. A row runs when its setpoint is above 0 (the model's
//! command; without a setpoint column, when its current exceeds the running current); a row
//! interval counts as running when both rows run and lie in one gap-free block, and a running
//! row after a stopped one or a gap is a start. The fit uses the running rows that carry
//! current at nominal temperature and pressure.
//!
//! Where the log does not allow a parameter the stage says why: too few nominal samples, no
//! restart (then τr and δs cannot be seen), runs too short for the build-up (τb beyond the
//! longest run), no reversible drift at all (A within its own noise).

use nalgebra::{DMatrix, DVector};

use super::columns::Channel;
use super::dynamics::Estimate;
use super::lsq::{self, Residuals};
use super::polarisation::PolarisationOptions;
use super::read::ModuleLog;
use super::temperature::Z95;

const SECONDS_PER_HOUR: f64 = 3600.0;
/// Grid of the start search: τb and τr from 1 min to 100 h, log-spaced.
const GRID: usize = 8;
const GRID_RANGE: (f64, f64) = (60.0, 360_000.0);
/// Fewest nominal running samples.
const MIN_POINTS: usize = 20;
/// Least change of the unit-amplitude drift over the samples for A to be told from V0.
const MIN_BUILD_UP_SEEN: f64 = 0.1;
/// Relative tolerance of the fit on Σ r² and θ. Σ r² ≈ n·σ², and one standard error moves it
/// by σ² (Δχ² = 1): at 1e-10 a step that still counts is below 1e-10·n in χ², under 1e-4 for
/// a year of 1 Hz samples, far inside every interval. A tighter tolerance only walks the flat
/// valley of a log without drift (τr unseen) until the evaluations run out: 800 evaluations
/// and 40 s on ten days at 1 Hz, against 12 and 1 s, for a τr that moved by 0.2 % of itself.
const TOLERANCE: f64 = 1e-10;

/// The fitted drift.
#[derive(Clone, Debug)]
pub struct DriftFit {
    /// A [V] (the FMU's `reversibleDrift`).
    pub amplitude: Estimate,
    /// τb [s] (`driftBuildUpTime`).
    pub build_up_time: Estimate,
    /// τr [s] (`driftRecoveryTime`); None where the log has no restart.
    pub recovery_time: Option<Estimate>,
    /// ρ [V/h] (`driftPerRunningHour`).
    pub per_running_hour: Estimate,
    /// δs [V] (`driftPerStart`); None where the log has no restart.
    pub per_start: Option<Estimate>,
    /// V0 and R of the same fit, the drift taken out [V], [Ω].
    pub voltage_intercept: Estimate,
    pub ohmic_resistance: Estimate,
    /// RMSE of V with the drift [V], and of the same samples with V0 + R·I alone [V].
    pub rmse: f64,
    pub rmse_without_drift: f64,
    /// Samples used, runs seen, the longest run [s].
    pub points: usize,
    pub runs: usize,
    pub longest_run: f64,
    /// Correlation of the estimates of ρ and δs (NaN without δs): near ±1 where runs of one
    /// length make the rise per hour and per start hard to tell apart.
    pub rise_correlation: f64,
    /// What the fit could not do, for the report.
    pub notes: Vec<String>,
}

/// The log walked in time order: for each row, the interval that ends at it.
struct Walk {
    /// Length of the interval before the row [s] and whether the module ran through it.
    length: Vec<f64>,
    running: Vec<bool>,
    /// Rows used in the fit: index, I [A], V [V], H [h], S [1].
    used: Vec<(usize, f64, f64, f64, f64)>,
    runs: usize,
    longest_run: f64,
    rested: bool,
}

fn walk(log: &ModuleLog, options: &PolarisationOptions) -> Walk {
    let mut blocks: Vec<_> = log
        .blocks
        .iter()
        .filter(|b| !b.is_empty() && b.channel(Channel::Current).is_some())
        .collect();
    blocks.sort_by(|a, b| a.time[0].total_cmp(&b.time[0]));
    let mut w = Walk {
        length: Vec::new(),
        running: Vec::new(),
        used: Vec::new(),
        runs: 0,
        longest_run: 0.0,
        rested: false,
    };
    let (mut hours, mut starts, mut run) = (0.0, 0.0, 0.0);
    let mut previous: Option<(f64, bool)> = None; // (time, running) of the row before
    for block in blocks {
        let (Some(current), voltage) = (
            block.channel(Channel::Current),
            block.channel(Channel::Voltage),
        ) else {
            continue;
        };
        let temperature = block.channel(Channel::Temperature);
        let pressure = block.channel(Channel::Pressure);
        let setpoint = block.channel(Channel::Setpoint);
        for r in 0..block.len() {
            let t = block.time[r];
            let carries = current[r] > options.running_current;
            let on = setpoint.map_or(carries, |u| u[r] > 0.0);
            let (length, through) = match previous {
                // The first row of a block follows a gap: a rest of unknown content.
                Some((t0, was_on)) => (t - t0, was_on && on && r > 0),
                None => (0.0, false),
            };
            if previous.is_some() && !through {
                w.rested = true;
            }
            if through {
                hours += length / SECONDS_PER_HOUR;
                run += length;
                w.longest_run = w.longest_run.max(run);
            } else if on {
                starts += f64::from(u8::from(previous.is_some()));
                w.runs += 1;
                run = 0.0;
            }
            w.length.push(length);
            w.running.push(through);
            let nominal = options.is_nominal(temperature, pressure, r);
            if let (true, true, Some(v)) = (on && carries, nominal, voltage) {
                w.used
                    .push((w.length.len() - 1, current[r], v[r], hours, starts));
            }
            previous = Some((t, on));
        }
    }
    w
}

/// g and its sensitivities to θb = ln τb and θr = ln τr at every row.
fn unit_drift(w: &Walk, tau_b: f64, tau_r: f64) -> Vec<[f64; 3]> {
    let (mut g, mut gb, mut gr) = (0.0, 0.0, 0.0);
    let mut out = Vec::with_capacity(w.length.len());
    for (&length, &running) in w.length.iter().zip(&w.running) {
        if length > 0.0 {
            if running {
                // g1 = 1 + (g0 − 1)·e, e = e^(−L/τb); ∂e/∂θb = e·L/τb.
                let e = (-length / tau_b).exp();
                let de = e * length / tau_b;
                gb = gb * e + (g - 1.0) * de;
                gr *= e;
                g = 1.0 + (g - 1.0) * e;
            } else {
                let e = (-length / tau_r).exp();
                let de = e * length / tau_r;
                gb *= e;
                gr = gr * e + g * de;
                g *= e;
            }
        }
        out.push([g, gb, gr]);
    }
    out
}

/// Which of ρ, δs and τr the fit carries.
#[derive(Clone, Copy)]
struct Terms {
    starts: bool,
    recovery: bool,
}

/// Residuals of θ = [V0, R, ρ, (δs), A, ln τb, (ln τr)].
struct DriftResiduals<'a> {
    walk: &'a Walk,
    terms: Terms,
    /// τr where it is not fitted (no rest: it does not matter) [s].
    fixed_recovery: f64,
}

impl DriftResiduals<'_> {
    fn unpack(&self, theta: &[f64]) -> (f64, f64, f64, f64, f64, f64, f64) {
        let mut k = 3;
        let per_start = if self.terms.starts {
            k += 1;
            theta[k - 1]
        } else {
            0.0
        };
        let amplitude = theta[k];
        let tau_b = theta[k + 1].exp();
        let tau_r = if self.terms.recovery {
            theta[k + 2].exp()
        } else {
            self.fixed_recovery
        };
        (
            theta[0], theta[1], theta[2], per_start, amplitude, tau_b, tau_r,
        )
    }
}

impl Residuals for DriftResiduals<'_> {
    fn parameters(&self) -> usize {
        5 + usize::from(self.terms.starts) + usize::from(self.terms.recovery)
    }

    fn residuals(&self, theta: &[f64], out: &mut Vec<f64>) -> bool {
        out.clear();
        let (v0, r, rho, ds, a, tau_b, tau_r) = self.unpack(theta);
        if !(tau_b.is_finite() && tau_r.is_finite() && tau_b > 0.0 && tau_r > 0.0) {
            return false;
        }
        let g = unit_drift(self.walk, tau_b, tau_r);
        out.extend(
            self.walk
                .used
                .iter()
                .map(|&(k, i, v, h, s)| v - (v0 + r * i + rho * h + ds * s + a * g[k][0])),
        );
        true
    }

    fn exact_jacobian(&self, theta: &[f64]) -> Option<DMatrix<f64>> {
        let (_, _, _, _, a, tau_b, tau_r) = self.unpack(theta);
        let g = unit_drift(self.walk, tau_b, tau_r);
        let k = self.parameters();
        let mut j = DMatrix::zeros(self.walk.used.len(), k);
        for (row, &(index, i, _, h, s)) in self.walk.used.iter().enumerate() {
            let [gv, gb, gr] = g[index];
            let mut col = 0;
            let mut put = |x: f64| {
                j[(row, col)] = -x;
                col += 1;
            };
            put(1.0);
            put(i);
            put(h);
            if self.terms.starts {
                put(s);
            }
            put(gv);
            put(a * gb);
            if self.terms.recovery {
                put(a * gr);
            }
        }
        Some(j)
    }
}

/// Linear least squares of the fit for fixed time constants: (θ, RSS), by the normal
/// equations (k ≤ 5 columns, each scaled by its largest magnitude) and Cholesky: the start of
/// the search only, which Levenberg–Marquardt then refines on the residuals themselves.
fn linear_fit(w: &Walk, terms: Terms, tau_b: f64, tau_r: f64) -> Option<(Vec<f64>, f64)> {
    let g = unit_drift(w, tau_b, tau_r);
    let k = 4 + usize::from(terms.starts);
    let row = |u: &(usize, f64, f64, f64, f64)| -> [f64; 5] {
        let (index, i, _, h, s) = *u;
        if terms.starts {
            [1.0, i, h, s, g[index][0]]
        } else {
            [1.0, i, h, g[index][0], 0.0]
        }
    };
    let mut scale = [0.0f64; 5];
    for u in &w.used {
        for (s, x) in scale.iter_mut().zip(row(u)) {
            *s = s.max(x.abs());
        }
    }
    if scale[..k].iter().any(|s| !(*s > 0.0)) {
        return None;
    }
    let mut xtx = DMatrix::<f64>::zeros(k, k);
    let mut xty = DVector::<f64>::zeros(k);
    let mut yy = 0.0;
    for u in &w.used {
        let x = row(u);
        let y = u.2;
        yy += y * y;
        for a in 0..k {
            let xa = x[a] / scale[a];
            xty[a] += xa * y;
            for b in 0..=a {
                xtx[(a, b)] += xa * x[b] / scale[b];
            }
        }
    }
    for a in 0..k {
        for b in 0..a {
            xtx[(b, a)] = xtx[(a, b)];
        }
    }
    let beta = xtx.clone().cholesky()?.solve(&xty);
    // RSS = yᵀy − 2βᵀXᵀy + βᵀXᵀXβ.
    let rss = yy - 2.0 * beta.dot(&xty) + beta.dot(&(&xtx * &beta));
    let theta = (0..k).map(|a| beta[a] / scale[a]).collect();
    rss.is_finite().then_some((theta, rss.max(0.0)))
}

/// Fits the drift; needs current, voltage, and restarts for τr and δs.
pub fn fit_drift(log: &ModuleLog, options: &PolarisationOptions) -> Result<DriftFit, String> {
    if !log.has(Channel::Voltage) {
        return Err("no voltage column".into());
    }
    let w = walk(log, options);
    let n = w.used.len();
    if n < MIN_POINTS {
        return Err(format!(
            "not identifiable from this log: {n} running samples at nominal temperature and pressure; at least {MIN_POINTS} are needed"
        ));
    }
    let mut notes = Vec::new();
    let restarts = w.runs >= 2 && w.rested;
    if !restarts {
        notes.push(
            "τr and the rise per start not identifiable from this log: it has no restart"
                .to_string(),
        );
    }
    let terms = Terms {
        starts: restarts,
        recovery: restarts,
    };
    let fixed_recovery = GRID_RANGE.1;
    // Start: the best linear fit over the grid of time constants.
    let grid = |k: usize| {
        let (lo, hi) = (GRID_RANGE.0.ln(), GRID_RANGE.1.ln());
        (lo + (hi - lo) * k as f64 / (GRID - 1) as f64).exp()
    };
    let recovery_grid: Vec<f64> = if terms.recovery {
        (0..GRID).map(grid).collect()
    } else {
        vec![fixed_recovery]
    };
    let mut best: Option<(f64, f64, Vec<f64>, f64)> = None;
    for tb in (0..GRID).map(grid) {
        for &tr in &recovery_grid {
            if let Some((beta, rss)) = linear_fit(&w, terms, tb, tr) {
                if best.as_ref().is_none_or(|b| rss < b.3) {
                    best = Some((tb, tr, beta, rss));
                }
            }
        }
    }
    let Some((tb, tr, beta, _)) = best else {
        return Err("not identifiable from this log: the design is singular".into());
    };
    let mut theta0 = beta;
    theta0.push(tb.ln());
    if terms.recovery {
        theta0.push(tr.ln());
    }
    let problem = DriftResiduals {
        walk: &w,
        terms,
        fixed_recovery,
    };
    let fit = lsq::minimize(&problem, &theta0, 100, TOLERANCE, true).map_err(|e| {
        format!("not identifiable from this log: the drift's fit did not settle ({e}); the log may show no drift")
    })?;
    let estimate = |k: usize| Estimate {
        value: fit.theta[k],
        standard_error: fit.standard_error(k),
    };
    // Time constants from their logarithms: SE(τ) = τ·SE(ln τ).
    let time_constant = |k: usize| {
        let value = fit.theta[k].exp();
        Estimate {
            value,
            standard_error: value * fit.standard_error(k),
        }
    };
    let k_amplitude = 3 + usize::from(terms.starts);
    let amplitude = estimate(k_amplitude);
    let build_up_time = time_constant(k_amplitude + 1);
    // The build-up must show in the samples: g (unit amplitude) must change over them, or A
    // is V0 under another name.
    let tau_r = if terms.recovery {
        fit.theta[k_amplitude + 2].exp()
    } else {
        fixed_recovery
    };
    let g = unit_drift(&w, build_up_time.value, tau_r);
    let (g_lo, g_hi) = w
        .used
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), u| {
            (lo.min(g[u.0][0]), hi.max(g[u.0][0]))
        });
    if !(g_hi - g_lo >= MIN_BUILD_UP_SEEN) {
        return Err(format!(
            "not identifiable from this log: the fitted build-up (τb = {:.0} s) is over before the samples at nominal conditions begin; the reversible drift cannot be told from V0",
            build_up_time.value
        ));
    }
    let determined = |e: &Estimate| e.standard_error.is_finite() && e.standard_error > 0.0;
    if !(determined(&amplitude) && determined(&build_up_time)) {
        return Err(
            "not identifiable from this log: the drift's terms cannot be told apart (singular design)"
                .into(),
        );
    }
    let rise_correlation = if terms.starts {
        fit.correlation(2, 3)
    } else {
        f64::NAN
    };
    if rise_correlation.abs() > 0.9 {
        notes.push(format!(
            "ρ and δs correlate ({rise_correlation:.2}): the runs are much alike in length, so the rise per run is better known than how it splits into hours and starts"
        ));
    }
    if build_up_time.value > 3.0 * w.longest_run {
        notes.push(format!(
            "τb = {:.0} s exceeds the longest run ({:.0} s) threefold: the runs are too short to see the build-up settle",
            build_up_time.value, w.longest_run
        ));
    }
    if amplitude.value.abs() < Z95 * amplitude.standard_error {
        notes.push(
            "no reversible drift found in this log: A is within its 95 % interval of 0".to_string(),
        );
    }
    let plain = linear_fit_plain(&w);
    Ok(DriftFit {
        amplitude,
        build_up_time,
        recovery_time: terms.recovery.then(|| time_constant(k_amplitude + 2)),
        per_running_hour: estimate(2),
        per_start: terms.starts.then(|| estimate(3)),
        voltage_intercept: estimate(0),
        ohmic_resistance: estimate(1),
        rmse: fit.rmse(),
        rmse_without_drift: plain,
        points: n,
        runs: w.runs,
        longest_run: w.longest_run,
        rise_correlation,
        notes,
    })
}

/// RMSE of V = V0 + R·I alone on the same samples [V].
fn linear_fit_plain(w: &Walk) -> f64 {
    let n = w.used.len();
    let x = DMatrix::from_fn(n, 2, |row, col| if col == 0 { 1.0 } else { w.used[row].1 });
    let y = DVector::from_iterator(n, w.used.iter().map(|u| u.2));
    x.clone()
        .svd(true, true)
        .solve(&y, 1e-12)
        .map_or(f64::NAN, |beta| {
            ((&y - &x * &beta).norm_squared() / n as f64).sqrt()
        })
}
