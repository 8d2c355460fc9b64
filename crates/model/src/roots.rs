//! Root of a function that is monotone on a bracket, to full double precision.

/// Root of `f` on [lo, hi], where `f` is monotone and `f_lo`, `f_hi` (its values at the ends)
/// do not share a sign. `f(t)` returns (value, first derivative, second derivative).
///
/// Halley steps (cubic convergence) inside the shrinking bracket; a step that leaves the
/// bracket is replaced by bisection, so it always converges.
pub fn monotone_root(
    f: impl Fn(f64) -> (f64, f64, f64),
    lo: f64,
    hi: f64,
    f_lo: f64,
    f_hi: f64,
) -> f64 {
    if f_lo == 0.0 {
        return lo;
    }
    if f_hi == 0.0 {
        return hi;
    }
    let (mut a, mut b) = (lo, hi);
    let lo_negative = f_lo < 0.0;
    // Start from the secant between the ends.
    let mut x = a - f_lo * (b - a) / (f_hi - f_lo);
    if !(x > a && x < b) {
        x = 0.5 * (a + b);
    }
    for _ in 0..200 {
        let (fx, d1, d2) = f(x);
        if fx == 0.0 {
            return x;
        }
        if (fx < 0.0) == lo_negative {
            a = x;
        } else {
            b = x;
        }
        if b - a <= 2.0 * f64::EPSILON * a.abs().max(b.abs()) {
            return 0.5 * (a + b);
        }
        // Far from the root (a Newton step would leave the bracket): bisect.
        let newton = x - fx / d1;
        if !(newton > a && newton < b) {
            x = 0.5 * (a + b);
            continue;
        }
        let halley = x - 2.0 * fx * d1 / (2.0 * d1 * d1 - fx * d2);
        let next = if halley > a && halley < b {
            halley
        } else {
            newton
        };
        // Converged when the step is within a few ulps of the iterate.
        if (next - x).abs() <= 4.0 * f64::EPSILON * x.abs() {
            return next;
        }
        x = next;
    }
    x
}

/// The first point of [lo, hi] where `crossed` holds, to within a few ulps, given that it
/// does not hold at `lo` and holds at `hi` (and, between them, changes once): bisection.
pub fn first_crossing(crossed: impl Fn(f64) -> bool, lo: f64, hi: f64) -> f64 {
    let (mut a, mut b) = (lo, hi);
    loop {
        let mid = 0.5 * (a + b);
        if !(mid > a && mid < b) {
            return b;
        }
        if crossed(mid) {
            b = mid;
        } else {
            a = mid;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{first_crossing, monotone_root};

    #[test]
    fn bisection_finds_the_first_crossing_to_the_ulp() {
        let x = first_crossing(|t| t * t >= 2.0, 0.0, 2.0);
        assert!(x * x >= 2.0);
        assert!((x - 2f64.sqrt()).abs() <= 2.0 * f64::EPSILON * 2f64.sqrt());
    }

    #[test]
    fn finds_roots_of_monotone_functions() {
        let r = monotone_root(|t| (t * t - 2.0, 2.0 * t, 2.0), 0.0, 2.0, -2.0, 2.0);
        assert!((r - 2f64.sqrt()).abs() < 4e-16);
        let e = |t: f64| (-t).exp();
        let r = monotone_root(|t| (e(t) - 0.5, -e(t), e(t)), 0.0, 10.0, 0.5, e(10.0) - 0.5);
        assert!((r - 2f64.ln()).abs() < 4e-16);
        // A flat-then-steep function where the local steps overshoot: bisection takes over.
        let r = monotone_root(
            |t| (t.powi(9) - 1e-3, 9.0 * t.powi(8), 72.0 * t.powi(7)),
            0.0,
            3.0,
            -1e-3,
            3f64.powi(9),
        );
        assert!((r - 1e-3f64.powf(1.0 / 9.0)).abs() < 1e-14);
    }
}
