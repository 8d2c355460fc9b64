//! Root of a function that is monotone on a bracket, to full double precision.

/// Root of `f` on [lo, hi], where `f` is monotone and `f_lo`, `f_hi` (its values at the ends)
/// do not share a sign. `f(t)` returns (value, derivative). Newton steps that leave the
/// shrinking bracket are replaced by bisection, so it always converges.
pub fn monotone_root(f: impl Fn(f64) -> (f64, f64), lo: f64, hi: f64, f_lo: f64, f_hi: f64) -> f64 {
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
        let (fx, dfx) = f(x);
        if fx == 0.0 {
            return x;
        }
        if (fx < 0.0) == lo_negative {
            a = x;
        } else {
            b = x;
        }
        let newton = x - fx / dfx;
        // Newton converges quadratically: once its step is below 1e-9 of the bracket, the
        // step itself lands within rounding of the root.
        if (newton - x).abs() <= 1e-9 * (hi - lo) && newton >= a && newton <= b {
            return newton;
        }
        if b - a <= 2.0 * f64::EPSILON * a.abs().max(b.abs()) {
            return 0.5 * (a + b);
        }
        x = if newton > a && newton < b { newton } else { 0.5 * (a + b) };
    }
    x
}

#[cfg(test)]
mod tests {
    use super::monotone_root;

    #[test]
    fn finds_roots_of_monotone_functions() {
        let r = monotone_root(|t| (t * t - 2.0, 2.0 * t), 0.0, 2.0, -2.0, 2.0);
        assert!((r - 2f64.sqrt()).abs() < 4e-16);
        let r = monotone_root(|t| ((-t).exp() - 0.5, -(-t).exp()), 0.0, 10.0, 0.5, (-10f64).exp() - 0.5);
        assert!((r - 2f64.ln()).abs() < 4e-16);
        // A flat-then-steep function where Newton overshoots: bisection takes over.
        let r = monotone_root(|t| (t.powi(9) - 1e-3, 9.0 * t.powi(8)), 0.0, 3.0, -1e-3, 3f64.powi(9));
        assert!((r - 1e-3f64.powf(1.0 / 9.0)).abs() < 1e-14);
    }
}
