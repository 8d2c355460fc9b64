//! Small statistics helpers used by the fits and reports.

/// Root mean square of `values` (0 for none).
pub fn rms(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

/// Arithmetic mean (NaN for none).
pub fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// Median (NaN for none).
pub fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Median absolute deviation from the median, scaled by 1.4826 so that it estimates the
/// standard deviation of normally distributed values.
pub fn robust_sigma(values: &[f64]) -> f64 {
    let m = median(values);
    let deviations: Vec<f64> = values.iter().map(|v| (v - m).abs()).collect();
    1.4826 * median(&deviations)
}

/// Sample standard deviation (n − 1); 0 for fewer than two values.
pub fn sample_std(values: &[f64]) -> f64 {
    if values.len() < 2 {
        return 0.0;
    }
    let m = mean(values);
    (values.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (values.len() - 1) as f64).sqrt()
}

/// Corrected Akaike information criterion of a least-squares fit with Gaussian residuals:
/// AICc = N·ln(RSS/N) + 2k + 2k(k + 1)/(N − k − 1), for N residuals and k parameters.
pub fn aicc(rss: f64, n: usize, k: usize) -> f64 {
    let nf = n as f64;
    let kf = k as f64;
    nf * (rss / nf).ln() + 2.0 * kf + 2.0 * kf * (kf + 1.0) / (nf - kf - 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_values() {
        assert_eq!(rms(&[3.0, 4.0]), (12.5f64).sqrt());
        assert_eq!(median(&[5.0, 1.0, 3.0]), 3.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!((robust_sigma(&[1.0, 2.0, 3.0, 4.0, 100.0]) - 1.4826).abs() < 1e-12);
        assert!((sample_std(&[1.0, 2.0, 3.0]) - 1.0).abs() < 1e-12);
        // N ln(RSS/N) + 2k + 2k(k+1)/(N-k-1) with N = 100, k = 2, RSS = 100.
        assert!((aicc(100.0, 100, 2) - (4.0 + 12.0 / 97.0)).abs() < 1e-12);
    }
}
