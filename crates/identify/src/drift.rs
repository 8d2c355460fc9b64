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
use super::temperature::{TemperatureFit, TemperatureOptions, Z95};

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
    /// Rows used in the fit: index, I [A], V [V], H [h], S [1], T − Tn [K].
    used: Vec<(usize, f64, f64, f64, f64, f64)>,
    runs: usize,
    longest_run: f64,
    /// The length of each run [s].
    run_lengths: Vec<f64>,
    rested: bool,
}

/// Which rows a fit uses: Some(T − Tn) for a row to use (0 without a temperature column), from
/// the temperature and pressure columns and the row.
type Select<'a> = dyn Fn(Option<&[f64]>, Option<&[f64]>, usize) -> Option<f64> + 'a;

/// The drift stage's rows: running at nominal temperature and pressure (the polarisation
/// filter).
fn nominal(
    options: &PolarisationOptions,
) -> impl Fn(Option<&[f64]>, Option<&[f64]>, usize) -> Option<f64> + '_ {
    move |temperature, pressure, r| {
        options
            .is_nominal(temperature, pressure, r)
            .then(|| temperature.map_or(0.0, |t| t[r] - options.temperature))
    }
}

fn walk(log: &ModuleLog, running_current: f64, select: &Select) -> Walk {
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
        run_lengths: Vec::new(),
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
            let carries = current[r] > running_current;
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
                if let Some(last) = w.run_lengths.last_mut() {
                    *last = run;
                }
            } else if on {
                starts += f64::from(u8::from(previous.is_some()));
                w.runs += 1;
                w.run_lengths.push(0.0);
                run = 0.0;
            }
            w.length.push(length);
            w.running.push(through);
            if let (true, Some(dt), Some(v)) =
                (on && carries, select(temperature, pressure, r), voltage)
            {
                w.used
                    .push((w.length.len() - 1, current[r], v[r], hours, starts, dt));
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

/// Which of δs, τr and the temperature terms kV, kR (0, kV alone, or both) the fit carries.
#[derive(Clone, Copy)]
struct Terms {
    starts: bool,
    recovery: bool,
    temperature: usize,
}

impl Terms {
    /// Index of A in θ.
    fn amplitude(&self) -> usize {
        3 + usize::from(self.starts)
    }

    /// Index of kV in θ (kR follows).
    fn temperature_index(&self) -> usize {
        self.amplitude() + 2 + usize::from(self.recovery)
    }
}

/// Residuals of θ = [V0, R, ρ, (δs), A, ln τb, (ln τr), (kV, (kR))].
struct DriftResiduals<'a> {
    walk: &'a Walk,
    terms: Terms,
    /// τr where it is not fitted (no rest: it does not matter) [s].
    fixed_recovery: f64,
}

impl DriftResiduals<'_> {
    /// kV and kR from θ (0 where the fit does not carry them).
    fn temperature_terms(&self, theta: &[f64]) -> (f64, f64) {
        let k = self.terms.temperature_index();
        match self.terms.temperature {
            0 => (0.0, 0.0),
            1 => (theta[k], 0.0),
            _ => (theta[k], theta[k + 1]),
        }
    }

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
        5 + usize::from(self.terms.starts)
            + usize::from(self.terms.recovery)
            + self.terms.temperature
    }

    fn residuals(&self, theta: &[f64], out: &mut Vec<f64>) -> bool {
        out.clear();
        let (v0, r, rho, ds, a, tau_b, tau_r) = self.unpack(theta);
        if !(tau_b.is_finite() && tau_r.is_finite() && tau_b > 0.0 && tau_r > 0.0) {
            return false;
        }
        let (kv, kr) = self.temperature_terms(theta);
        let g = unit_drift(self.walk, tau_b, tau_r);
        out.extend(self.walk.used.iter().map(|&(k, i, v, h, s, dt)| {
            v - (v0 + r * i + rho * h + ds * s + a * g[k][0] + kv * dt + kr * dt * i)
        }));
        true
    }

    fn exact_jacobian(&self, theta: &[f64]) -> Option<DMatrix<f64>> {
        let (_, _, _, _, a, tau_b, tau_r) = self.unpack(theta);
        let g = unit_drift(self.walk, tau_b, tau_r);
        let k = self.parameters();
        let mut j = DMatrix::zeros(self.walk.used.len(), k);
        for (row, &(index, i, _, h, s, dt)) in self.walk.used.iter().enumerate() {
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
            if self.terms.temperature >= 1 {
                put(dt);
            }
            if self.terms.temperature >= 2 {
                put(dt * i);
            }
        }
        Some(j)
    }
}

/// Most columns of a linear fit.
const MAX_COLUMNS: usize = 8;

/// A linear least-squares solution: θ, RSS, and (XᵀX)⁻¹ of the unscaled columns (the
/// covariance of θ is s²·(XᵀX)⁻¹).
struct Linear {
    theta: Vec<f64>,
    rss: f64,
    inverse: DMatrix<f64>,
}

/// Linear least squares of V on the first `k` of `columns(sample)`, by the normal equations
/// (each column scaled by its largest magnitude) and Cholesky; None where they are singular.
fn linear(
    w: &Walk,
    k: usize,
    columns: impl Fn(&(usize, f64, f64, f64, f64, f64)) -> [f64; MAX_COLUMNS],
) -> Option<Linear> {
    let mut scale = [0.0f64; MAX_COLUMNS];
    for u in &w.used {
        for (s, x) in scale.iter_mut().zip(columns(u)) {
            *s = s.max(x.abs());
        }
    }
    if scale[..k].iter().any(|s| !(*s > 0.0 && s.is_finite())) {
        return None;
    }
    let mut xtx = DMatrix::<f64>::zeros(k, k);
    let mut xty = DVector::<f64>::zeros(k);
    let mut yy = 0.0;
    for u in &w.used {
        let x = columns(u);
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
    let cholesky = xtx.clone().cholesky()?;
    let beta = cholesky.solve(&xty);
    // RSS = yᵀy − 2βᵀXᵀy + βᵀXᵀXβ.
    let rss = yy - 2.0 * beta.dot(&xty) + beta.dot(&(&xtx * &beta));
    let scaled_inverse = cholesky.inverse();
    let inverse = DMatrix::from_fn(k, k, |a, b| scaled_inverse[(a, b)] / (scale[a] * scale[b]));
    let theta: Vec<f64> = (0..k).map(|a| beta[a] / scale[a]).collect();
    (rss.is_finite() && theta.iter().all(|t| t.is_finite())).then_some(Linear {
        theta,
        rss: rss.max(0.0),
        inverse,
    })
}

/// The fit's linear part for fixed time constants: θ = [V0, R, ρ, (δs), A, (kV, (kR))] and
/// RSS; the start of the search only, which Levenberg–Marquardt then refines on the residuals
/// themselves.
fn linear_fit(w: &Walk, terms: Terms, tau_b: f64, tau_r: f64) -> Option<(Vec<f64>, f64)> {
    let g = unit_drift(w, tau_b, tau_r);
    let k = 4 + usize::from(terms.starts) + terms.temperature;
    let fit = linear(w, k, |&(index, i, _, h, s, dt)| {
        let mut row = [0.0; MAX_COLUMNS];
        for (slot, x) in row.iter_mut().zip(
            [1.0, i, h]
                .into_iter()
                .chain(terms.starts.then_some(s))
                .chain([g[index][0]])
                .chain((terms.temperature >= 1).then_some(dt))
                .chain((terms.temperature >= 2).then_some(dt * i)),
        ) {
            *slot = x;
        }
        row
    })?;
    Some((fit.theta, fit.rss))
}

/// θ of Levenberg–Marquardt from the linear part's and the time constants.
fn start_point(terms: Terms, linear: &[f64], tau_b: f64, tau_r: f64) -> Vec<f64> {
    let k = terms.amplitude() + 1;
    let mut theta = linear[..k].to_vec();
    theta.push(tau_b.ln());
    if terms.recovery {
        theta.push(tau_r.ln());
    }
    theta.extend_from_slice(&linear[k..]);
    theta
}

/// Grid of the start search: τb and τr from 1 min to 100 h, log-spaced.
fn grid(k: usize) -> f64 {
    let (lo, hi) = (GRID_RANGE.0.ln(), GRID_RANGE.1.ln());
    (lo + (hi - lo) * k as f64 / (GRID - 1) as f64).exp()
}

/// The best linear fit over the grid of time constants and the `extra` pairs (τb, τr):
/// (τb, τr, linear θ, RSS).
fn best_start(
    w: &Walk,
    terms: Terms,
    fixed_recovery: f64,
    extra: &[(f64, f64)],
) -> Option<(f64, f64, Vec<f64>, f64)> {
    let recovery_grid: Vec<f64> = if terms.recovery {
        (0..GRID).map(grid).collect()
    } else {
        vec![fixed_recovery]
    };
    let mut candidates: Vec<(f64, f64)> = (0..GRID)
        .map(grid)
        .flat_map(|tb| recovery_grid.iter().map(move |&tr| (tb, tr)))
        .collect();
    candidates.extend(
        extra
            .iter()
            .map(|&(tb, tr)| (tb, if terms.recovery { tr } else { fixed_recovery }))
            .filter(|(tb, tr)| tb.is_finite() && tr.is_finite() && *tb > 0.0 && *tr > 0.0),
    );
    let mut best: Option<(f64, f64, Vec<f64>, f64)> = None;
    for (tb, tr) in candidates {
        if let Some((beta, rss)) = linear_fit(w, terms, tb, tr) {
            if best.as_ref().is_none_or(|b| rss < b.3) {
                best = Some((tb, tr, beta, rss));
            }
        }
    }
    best
}

/// Fits the drift; needs current, voltage, and restarts for τr and δs.
pub fn fit_drift(log: &ModuleLog, options: &PolarisationOptions) -> Result<DriftFit, String> {
    fit_drift_without(log, options, (0.0, 0.0))
}

/// Fits the drift to the voltage with the temperature terms (kV [V/K], kR [Ω/K]) taken out,
/// kV·(T − Tn) + kR·(T − Tn)·I with Tn the nominal temperature of `options`.
pub fn fit_drift_without(
    log: &ModuleLog,
    options: &PolarisationOptions,
    (kv, kr): (f64, f64),
) -> Result<DriftFit, String> {
    if !log.has(Channel::Voltage) {
        return Err("no voltage column".into());
    }
    let mut w = walk(log, options.running_current, &nominal(options));
    for u in &mut w.used {
        u.2 -= kv * u.5 + kr * u.5 * u.1;
    }
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
        temperature: 0,
    };
    let fixed_recovery = GRID_RANGE.1;
    // Start: the best linear fit over the grid of time constants.
    let Some((tb, tr, beta, _)) = best_start(&w, terms, fixed_recovery, &[]) else {
        return Err("not identifiable from this log: the design is singular".into());
    };
    let theta0 = start_point(terms, &beta, tb, tr);
    let problem = DriftResiduals {
        walk: &w,
        terms,
        fixed_recovery,
    };
    let fit = lsq::minimize(&problem, &theta0, 100, TOLERANCE, true).map_err(|_| {
        "not identifiable from this log: the drift's fit did not settle (its time constants ran out of range without a better fit), as where the log shows no reversible drift".to_string()
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
        let (shortest, longest) = w
            .run_lengths
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), &l| {
                (lo.min(l), hi.max(l))
            });
        let hours = |s: f64| s / SECONDS_PER_HOUR;
        let why = if runs_alike(&w.run_lengths) {
            format!(
                "the runs are much alike in length ({:.1}…{:.1} h)",
                hours(shortest),
                hours(longest)
            )
        } else {
            format!(
                "over {} runs of {:.1}…{:.1} h the hours run and the starts still grow too nearly in step to part them",
                w.runs,
                hours(shortest),
                hours(longest)
            )
        };
        notes.push(format!(
            "ρ and δs correlate ({rise_correlation:.2}): {why}, so the rise per run is better known than how it splits into hours and starts"
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

/// Whether runs are much alike in length: their lengths' coefficient of variation is below
/// 0.2 (e.g. every run within about a third of the mean's length).
fn runs_alike(lengths: &[f64]) -> bool {
    let n = lengths.len() as f64;
    if lengths.len() < 2 {
        return true;
    }
    let mean = lengths.iter().sum::<f64>() / n;
    let sd = (lengths.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    mean > 0.0 && sd < 0.2 * mean
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

/// Evidence for a model's extra terms: the fall of the RSS in units of the larger model's
/// residual variance (a likelihood ratio, χ² with as many degrees of freedom as terms, a few
/// of them searched over): 30 is far beyond what noise gives with the time constants free.
const EVIDENCE: f64 = 30.0;
/// Largest correlation of the temperature's and the reversible drift's regressors, and of the
/// estimates of kV and A, at which the two are still told apart.
const MAX_REGRESSOR_CORRELATION: f64 = 0.99;
const MAX_ESTIMATE_CORRELATION: f64 = 0.995;

/// The temperature stage with the drift in it: on the temperature stage's samples (running,
/// within its window of the nominal temperature and pressure),
///
///   V = V0 + kV·ΔT + (R + kR·ΔT)·I + ρ·H + δs·S + A·g(τb, τr),
///
/// all fitted together (Levenberg–Marquardt from the best start of a grid over τb, τr and the
/// drift stage's estimates), so that a warm-up while the reversible drift builds up is not
/// taken for temperature. `plain` is the temperature stage's fit without the drift (which of kV
/// and kR it carries); `drift` the drift stage's on the nominal samples. Ok(None) where the log
/// shows no drift (the drift stage finds no reversible drift and neither the drift's terms nor
/// the rise per hour and per start lower the RSS here by [`EVIDENCE`]): `plain` stands. Err
/// where the temperature and the drift cannot be told apart (their regressors, or kV's and
/// A's estimates, correlate nearly fully, or the joint design is singular).
pub fn fit_temperature_with_drift(
    log: &ModuleLog,
    options: &TemperatureOptions,
    plain: &TemperatureFit,
    drift: Option<&DriftFit>,
) -> Result<Option<TemperatureFit>, String> {
    let temperature = match (&plain.resistance_coefficient, &plain.ohmic_resistance) {
        (Some(_), _) => 2,
        (None, Some(_)) => 1,
        // A current that does not vary: R·I is V0, and the drift stage has no R either.
        (None, None) => return Ok(None),
    };
    let select = |t: Option<&[f64]>, p: Option<&[f64]>, r: usize| {
        let dt = t?[r] - options.nominal;
        let (p0, tolerance) = options.pressure;
        (dt.abs() <= options.window && !p.is_some_and(|p| (p[r] - p0).abs() > tolerance))
            .then_some(dt)
    };
    let w = walk(log, options.running_current, &select);
    let n = w.used.len();
    if n < MIN_POINTS {
        return Ok(None);
    }
    let restarts = w.runs >= 2 && w.rested;
    let terms = Terms {
        starts: restarts,
        recovery: restarts,
        temperature,
    };
    // The nested fits without the reversible drift: the temperature terms alone, then with the
    // rise per running hour and per start.
    let plain_columns = |with_rise: bool| {
        move |&(_, i, _, h, s, dt): &(usize, f64, f64, f64, f64, f64)| {
            let mut row = [0.0; MAX_COLUMNS];
            for (slot, x) in row.iter_mut().zip(
                [1.0, i]
                    .into_iter()
                    .chain(with_rise.then_some(h))
                    .chain((with_rise && restarts).then_some(s))
                    .chain([dt])
                    .chain((temperature >= 2).then_some(dt * i)),
            ) {
                *slot = x;
            }
            row
        }
    };
    let k0 = 3 + usize::from(temperature >= 2);
    let k1 = k0 + 1 + usize::from(restarts);
    let (Some(m0), Some(m1)) = (
        linear(&w, k0, plain_columns(false)),
        linear(&w, k1, plain_columns(true)),
    ) else {
        return Ok(None);
    };
    let fixed_recovery = GRID_RANGE.1;
    let stage = drift.map(|d| {
        (
            d.build_up_time.value,
            d.recovery_time.map_or(fixed_recovery, |e| e.value),
        )
    });
    let reversible = drift.is_some_and(|d| {
        d.amplitude.value.abs() >= Z95 * d.amplitude.standard_error
            && d.amplitude.standard_error.is_finite()
    });
    let joint = best_start(
        &w,
        terms,
        fixed_recovery,
        &stage.into_iter().collect::<Vec<_>>(),
    )
    .and_then(|(tb, tr, beta, _)| {
        let problem = DriftResiduals {
            walk: &w,
            terms,
            fixed_recovery,
        };
        lsq::minimize(
            &problem,
            &start_point(terms, &beta, tb, tr),
            100,
            TOLERANCE,
            true,
        )
        .ok()
    });
    let p = |k: usize| (n - k) as f64;
    let k2 = terms.amplitude() + 2 + usize::from(terms.recovery) + temperature;
    let reversible_evident = reversible
        || joint
            .as_ref()
            .is_some_and(|f| (m1.rss - f.rss) / (f.rss / p(k2)) > EVIDENCE);
    let rise_evident = (m0.rss - m1.rss) / (m1.rss / p(k1)) > EVIDENCE;
    let plain_note = format!(
        "without the drift's terms kV would be {:.4} V/K{}",
        plain.voltage_coefficient.value,
        plain
            .resistance_coefficient
            .map_or(String::new(), |kr| format!(" and kR {:.3e} Ω/K", kr.value))
    );
    let range = w
        .used
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), u| {
            (lo.min(u.5), hi.max(u.5))
        });
    let mean_t = w.used.iter().map(|u| u.5).sum::<f64>() / n as f64;
    let spread =
        (w.used.iter().map(|u| (u.5 - mean_t).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
    let mut notes = plain.notes.clone();
    let result = |theta: &dyn Fn(usize) -> Estimate, kv: usize, rmse: f64, notes: Vec<String>| {
        TemperatureFit {
            voltage_coefficient: theta(kv),
            resistance_coefficient: (temperature >= 2).then(|| theta(kv + 1)),
            voltage_intercept: theta(0),
            ohmic_resistance: Some(theta(1)),
            rmse,
            points: n,
            temperature_range: (range.0 + options.nominal, range.1 + options.nominal),
            temperature_spread: spread,
            drift_terms: true,
            notes,
        }
    };
    if reversible_evident {
        let not_apart = |why: String| {
            format!(
                "not identifiable from this log: the temperature and the voltage drift's build-up move together ({why}), so kV and kR cannot be told from the reversible drift; temperature changes late in long runs (refills, a cooling setpoint) part them"
            )
        };
        let Some(fit) = joint else {
            return Err(not_apart(
                "the joint fit of both did not settle".to_string(),
            ));
        };
        let (ka, kv) = (terms.amplitude(), terms.temperature_index());
        let tau_r = if terms.recovery {
            fit.theta[ka + 2].exp()
        } else {
            fixed_recovery
        };
        let tau_b = fit.theta[ka + 1].exp();
        let g = unit_drift(&w, tau_b, tau_r);
        let regressors = correlation(w.used.iter().map(|u| (u.5, g[u.0][0])));
        let estimates = fit.correlation(kv, ka);
        let determined = (0..fit.theta.len())
            .all(|k| fit.standard_error(k).is_finite() && fit.standard_error(k) > 0.0);
        if fit.covariance.is_none() || !determined {
            return Err(not_apart(format!(
                "the joint design is singular; correlation {regressors:.3} of their regressors over {n} samples"
            )));
        }
        if !(regressors.abs() < MAX_REGRESSOR_CORRELATION)
            || !(estimates.abs() < MAX_ESTIMATE_CORRELATION)
        {
            return Err(not_apart(format!(
                "correlation {regressors:.3} of their regressors over {n} samples, {estimates:.3} of the estimates of kV and A"
            )));
        }
        notes.push(format!(
            "fitted jointly with the voltage drift (A = {:.3} V, τb = {:.0} s; correlation of kV with A {estimates:.2}); {plain_note}",
            fit.theta[ka], tau_b
        ));
        if estimates.abs() > 0.9 {
            notes.push(format!(
                "kV and the reversible drift correlate ({estimates:.2}): the log parts them only weakly, and kV's interval is wide for it"
            ));
        }
        let estimate = |k: usize| Estimate {
            value: fit.theta[k],
            standard_error: fit.standard_error(k),
        };
        return Ok(Some(result(&estimate, kv, fit.rmse(), notes)));
    }
    if rise_evident {
        // No reversible drift seen, but a drift is: one that moved with the temperature would
        // hide in kV, unseen. Where some build-up time makes g follow the temperature, the two
        // cannot be told apart.
        if let Some((tb, correlation)) = hidden_build_up(&w, terms, fixed_recovery) {
            return Err(format!(
                "not identifiable from this log: the temperature and the voltage drift's build-up move together (a reversible drift building up in {tb:.0} s would follow the temperature, correlation {correlation:.3} of their regressors over {n} samples; the log shows a drift per running hour and per start), so kV and kR cannot be told from the reversible drift; temperature changes late in long runs (refills, a cooling setpoint) part them"
            ));
        }
        let s2 = m1.rss / p(k1);
        let estimate = |k: usize| Estimate {
            value: m1.theta[k],
            standard_error: (s2 * m1.inverse[(k, k)]).max(0.0).sqrt(),
        };
        notes.push(format!(
            "fitted jointly with the drift's rise per running hour and per start (no reversible drift found); {plain_note}"
        ));
        let kv = 3 + usize::from(restarts);
        return Ok(Some(result(
            &estimate,
            kv,
            (m1.rss / n as f64).sqrt(),
            notes,
        )));
    }
    Ok(None)
}

/// A build-up time (τb, over a grid fine enough that a neighbour's correlation exceeds 0.995,
/// and τr over the coarse grid) at which the reversible drift's g follows the temperature on
/// the samples: (τb, correlation) at the largest |correlation| where it reaches
/// [`MAX_REGRESSOR_CORRELATION`].
fn hidden_build_up(w: &Walk, terms: Terms, fixed_recovery: f64) -> Option<(f64, f64)> {
    const FINE: usize = 24;
    let (lo, hi) = (GRID_RANGE.0.ln(), GRID_RANGE.1.ln());
    let recovery: Vec<f64> = if terms.recovery {
        (0..GRID).map(grid).collect()
    } else {
        vec![fixed_recovery]
    };
    let mut worst: Option<(f64, f64)> = None;
    for k in 0..FINE {
        let tb = (lo + (hi - lo) * k as f64 / (FINE - 1) as f64).exp();
        for &tr in &recovery {
            let g = unit_drift(w, tb, tr);
            let c = correlation(w.used.iter().map(|u| (u.5, g[u.0][0])));
            if c.abs() >= MAX_REGRESSOR_CORRELATION && worst.is_none_or(|(_, b)| c.abs() > b.abs())
            {
                worst = Some((tb, c));
            }
        }
    }
    worst
}

/// Pearson correlation of the pairs (NaN where either does not vary).
fn correlation(pairs: impl Iterator<Item = (f64, f64)> + Clone) -> f64 {
    let n = pairs.clone().count() as f64;
    let (mx, my) = pairs
        .clone()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let (sxy, sxx, syy) = pairs.fold((0.0, 0.0, 0.0), |(a, b, c), (x, y)| {
        (
            a + (x - mx) * (y - my),
            b + (x - mx).powi(2),
            c + (y - my).powi(2),
        )
    });
    sxy / (sxx * syy).sqrt()
}
