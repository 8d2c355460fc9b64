//! Maximum and clamp written as one comparison each, so that the lanes' vector code gets one
//! max or min instruction per operation. Each gives the same value as the `f64` method it
//! stands for (NaN handling included), so the scalar path and the lanes may use either.

/// max(x, floor) for a number `floor`: x if x > floor, else floor (a NaN x gives floor, as
/// `f64::max` does).
#[inline(always)]
pub fn at_least(x: f64, floor: f64) -> f64 {
    if x > floor {
        x
    } else {
        floor
    }
}

/// x limited to [lo, hi] for numbers lo ≤ hi: `f64::clamp` (a NaN x stays NaN) without its
/// check of the bounds.
#[inline(always)]
pub fn clamped(x: f64, lo: f64, hi: f64) -> f64 {
    let x = if x < lo { lo } else { x };
    if x > hi {
        hi
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn they_give_what_the_f64_methods_give() {
        let xs = [
            f64::NAN,
            f64::NEG_INFINITY,
            -3.0,
            -0.0,
            0.0,
            0.5,
            60.0,
            99.9,
            100.0,
            1e300,
            f64::INFINITY,
        ];
        for x in xs {
            for floor in [0.0, 1.0, -2.0] {
                assert_eq!(
                    at_least(x, floor).to_bits(),
                    x.max(floor).to_bits(),
                    "max({x}, {floor})"
                );
            }
            let (got, want) = (clamped(x, 60.0, 100.0), x.clamp(60.0, 100.0));
            assert!(
                got.to_bits() == want.to_bits(),
                "clamp({x}): {got} vs {want}"
            );
        }
    }
}
