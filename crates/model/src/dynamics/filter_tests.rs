//! The reserve control's pre-filter against its transfer function
//! K(τn s + 1)/((τp1 s + 1)(τp2 s + 1)): closed-form step responses, the frequency response,
//! a monotone response inside the window, and its two ends bit for bit (τz: the paper's model;
//! τp2: the slow pole cancelled).

use super::*;

fn paper() -> (Parameters, CurrentDynamics) {
    let p = Parameters::default();
    (p, CurrentDynamics::new(&p))
}

/// a' = (τn − τp1)/(τp2 − τp1), b' = 1 − a'.
fn weights(p: &Parameters, tau_n: f64) -> (f64, f64) {
    let a = (tau_n - p.tau_pole1) / (p.tau_pole2 - p.tau_pole1);
    (a, 1.0 - a)
}

#[test]
fn a_falling_step_follows_the_filtered_transfer_function() {
    let (p, plain) = paper();
    for tau_n in [p.tau_pole1, 10.0, 50.0, p.tau_zero, 105.0] {
        let d = plain.with_filter_zero(tau_n);
        let (a, b) = weights(&p, tau_n);
        let (u0, u1) = (95.0, 65.0);
        let mut state = d.steady_state(u0);
        assert!((state.current - p.gain * u0).abs() < 1e-12);
        let mut t = 0.0;
        for h in [0.5, 2.0, 7.5, 30.0, 100.0, 300.0] {
            d.advance(&mut state, u1, h, &mut StepFactors::default());
            t += h;
            // Falling: the rate limit never binds, I = I_tf.
            let want = p.gain * u1
                + p.gain
                    * (u0 - u1)
                    * (a * (-t / p.tau_pole1).exp() + b * (-t / p.tau_pole2).exp());
            assert!(
                (state.current - want).abs() < 1e-10,
                "τn = {tau_n} s, t = {t} s: {} A vs {want} A",
                state.current
            );
        }
    }
}

#[test]
fn the_frequency_response_is_the_filtered_transfer_functions() {
    let (p, plain) = paper();
    // A 0.5 % sine about 80 % with a 20 s period: slow enough for the rate limit (the current's
    // slope stays below 0.22 A/s), fast enough for both poles and the zero to show.
    let (u0, amplitude, period) = (80.0, 0.5, 20.0);
    let omega = 2.0 * std::f64::consts::PI / period;
    let h = 0.005;
    for tau_n in [p.tau_pole1, 30.0, p.tau_zero, p.tau_pole2] {
        let d = plain.with_filter_zero(tau_n);
        let mut state = d.steady_state(u0);
        let steps = (30.0 * period / h) as usize;
        let (mut c, mut s, mut n) = (0.0, 0.0, 0.0);
        for k in 0..steps {
            // The setpoint held over each step at its mid-step value (second order in h).
            let t = (k as f64 + 0.5) * h;
            d.advance(
                &mut state,
                u0 + amplitude * (omega * t).sin(),
                h,
                &mut StepFactors::default(),
            );
            let t_end = (k + 1) as f64 * h;
            if t_end > 20.0 * period {
                // Fourier coefficients over the last ten periods.
                let y = state.current - p.gain * u0;
                c += y * (omega * t_end).cos();
                s += y * (omega * t_end).sin();
                n += 1.0;
            }
        }
        let got = (2.0 * s / n, 2.0 * c / n); // in phase, quadrature
                                              // G(jω)F(jω) = K(1 + jωτn)/((1 + jωτp1)(1 + jωτp2)), times the sine's amplitude.
        let (re, im) = {
            let num = (1.0, omega * tau_n);
            let den = {
                let (x, y) = ((1.0, omega * p.tau_pole1), (1.0, omega * p.tau_pole2));
                (x.0 * y.0 - x.1 * y.1, x.0 * y.1 + x.1 * y.0)
            };
            let m = den.0 * den.0 + den.1 * den.1;
            (
                (num.0 * den.0 + num.1 * den.1) / m,
                (num.1 * den.0 - num.0 * den.1) / m,
            )
        };
        let want = (p.gain * amplitude * re, p.gain * amplitude * im);
        let scale = p.gain * amplitude;
        assert!(
            (got.0 - want.0).abs() < 2e-3 * scale && (got.1 - want.1).abs() < 2e-3 * scale,
            "τn = {tau_n} s: {got:?} vs {want:?}"
        );
    }
}

#[test]
fn a_rising_step_stays_inside_the_window_and_under_the_rate_limit() {
    let (p, plain) = paper();
    for tau_n in [p.tau_pole1, 40.0, p.tau_pole2] {
        let d = plain.with_filter_zero(tau_n);
        let mut state = d.steady_state(60.0);
        let mut last = state.current;
        // 3000 s: the slow pole (114 s) settles to 1e-11 of the step.
        for _ in 0..3000 {
            d.advance(&mut state, 100.0, 1.0, &mut StepFactors::default());
            assert!(
                state.current <= p.gain * 100.0 * (1.0 + 1e-12),
                "τn = {tau_n}"
            );
            assert!(state.current - last <= p.ramp_up_limit * (1.0 + 1e-12));
            assert!(state.current >= last - 1e-9, "monotone rise");
            last = state.current;
        }
        assert!((state.current - p.gain * 100.0).abs() < 1e-6);
    }
}

#[test]
fn the_ends_of_the_family_are_the_plain_and_the_compensated_dynamics_bit_for_bit() {
    let (p, plain) = paper();
    let compensated = plain.with_compensation(true);
    for (filtered, reference) in [
        (plain.with_filter_zero(p.tau_zero), plain),
        (plain.with_filter_zero(p.tau_pole2), compensated),
    ] {
        assert_eq!(filtered, reference);
        let (mut x, mut y) = (filtered.steady_state(70.0), reference.steady_state(70.0));
        for (k, u) in [100.0, 62.0, 85.0, 60.0, 99.0]
            .iter()
            .cycle()
            .take(40)
            .enumerate()
        {
            let h = 0.3 + (k % 7) as f64 * 11.0;
            let a = filtered.advance(&mut x, *u, h, &mut StepFactors::default());
            let b = reference.advance(&mut y, *u, h, &mut StepFactors::default());
            assert_eq!(x, y);
            assert_eq!(a, b);
        }
    }
}
