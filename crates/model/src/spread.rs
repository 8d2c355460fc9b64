//! Per-module parameter sets: a documented, seeded random spread around one set.
//!
//! Each of K, τz, τp1, τp2, r, V0, R and c is multiplied by its own factor 1 + s·(2U − 1),
//! U uniform on [0, 1) from a xorshift64* generator seeded with `seed`; the operating window
//! (minSetpoint, maxSetpoint) and the nominal current are kept. Same seed, same sets.

use super::parameters::Parameters;

/// `n` parameter sets spread by ±`relative` (e.g. 0.03 for ±3 %) around `base`.
pub fn spread_parameters(base: &Parameters, n: usize, relative: f64, seed: u64) -> Vec<Parameters> {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut factor = move || {
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        let u = (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64;
        1.0 + relative * (2.0 * u - 1.0)
    };
    (0..n)
        .map(|_| Parameters {
            gain: base.gain * factor(),
            tau_zero: base.tau_zero * factor(),
            tau_pole1: base.tau_pole1 * factor(),
            tau_pole2: base.tau_pole2 * factor(),
            ramp_up_limit: base.ramp_up_limit * factor(),
            voltage_intercept: base.voltage_intercept * factor(),
            ohmic_resistance: base.ohmic_resistance * factor(),
            h2_coefficient: base.h2_coefficient * factor(),
            ..*base
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_is_seeded_bounded_and_valid() {
        let base = Parameters::default();
        let a = spread_parameters(&base, 200, 0.05, 1);
        assert_eq!(a, spread_parameters(&base, 200, 0.05, 1));
        assert_ne!(a, spread_parameters(&base, 200, 0.05, 2));
        for p in &a {
            assert!(p.validate().is_ok());
            assert!((p.gain / base.gain - 1.0).abs() <= 0.05);
            assert!((p.tau_pole2 / base.tau_pole2 - 1.0).abs() <= 0.05);
        }
    }
}
