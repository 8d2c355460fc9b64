//! Frequency reserves: the change of draw a grid frequency asks of the hub, product by product.
//!
//! Sign convention of a load: the request ΔP [W] is the signed change of the power the hub is
//! asked to draw; under-frequency asks for less (ΔP < 0), over-frequency for more. With
//! capacities C [W] of what the whole FMU draws and the frequency f [Hz] held over a step:
//!
//! | product | activation, capped at 100 % | ΔP |
//! |---|---|---|
//! | Nordic FCR-N | x = (50 − f)/0.1 in [−1, 1] | −C_N·x |
//! | Nordic FCR-D up | x = (49.9 − f)/0.4 in [0, 1] | −C_Dup·x |
//! | Nordic FCR-D down | x = (f − 50.1)/0.4 in [0, 1] | +C_Ddown·x |
//! | Continental FCR | x = (50 − f)/0.2 in [−1, 1] | −C_FCR·x |
//! | Nordic FFR | f ≤ trigger: full for the support duration | −C_FFR |
//!
//! The activations add to the power the hub is asked to draw (its power reference, or in
//! setpoint mode the power its setpoint stands for). FFR is armed until the frequency falls to
//! its trigger level (49.7, 49.6 or 49.5 Hz), then asks for its full capacity for the support
//! duration (an exact event inside a step), and is armed again once the frequency is back
//! above the trigger.

use super::parameters::ParameterError;

/// Nominal grid frequency [Hz].
pub const NOMINAL_FREQUENCY: f64 = 50.0;

/// The reserve products offered, as set through the FMU, before validation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReserveSettings {
    /// `fcrNCapacity` [W]: Nordic FCR-N, linear over 50 ± 0.1 Hz.
    pub fcr_n: f64,
    /// `fcrDUpCapacity` [W]: Nordic FCR-D up, 49.9 → 49.5 Hz.
    pub fcr_d_up: f64,
    /// `fcrDDownCapacity` [W]: Nordic FCR-D down, 50.1 → 50.5 Hz.
    pub fcr_d_down: f64,
    /// `fcrCapacity` [W]: Continental Europe FCR, linear over 50 ± 0.2 Hz.
    pub fcr: f64,
    /// `ffrCapacity` [W]: Nordic FFR.
    pub ffr: f64,
    /// `ffrTriggerFrequency` [Hz]: FFR's activation level.
    pub ffr_trigger: f64,
    /// `ffrSupportDuration` [s]: how long FFR holds its activation.
    pub ffr_duration: f64,
    /// `reserveCompensation`: the setpoint pre-filter that cancels the slow pole.
    pub compensation: bool,
    /// `reserveFilterZero` [s]: the setpoint pre-filter that puts the transfer function's zero
    /// at this time constant, within [τp1, τp2] of every module (0: none).
    pub filter_zero: f64,
}

impl Default for ReserveSettings {
    /// Nothing offered: FFR's trigger 49.7 Hz and support duration 30 s (the option that
    /// allows any deactivation rate).
    fn default() -> Self {
        ReserveSettings {
            fcr_n: 0.0,
            fcr_d_up: 0.0,
            fcr_d_down: 0.0,
            fcr: 0.0,
            ffr: 0.0,
            ffr_trigger: 49.7,
            ffr_duration: 30.0,
            compensation: false,
            filter_zero: 0.0,
        }
    }
}

impl ReserveSettings {
    /// Refuses negative or non-finite capacities, a trigger outside [49.0, 49.9] Hz and a
    /// support duration that is not positive; the error names the variable.
    pub fn validate(&self) -> Result<(), ParameterError> {
        for (name, value) in [
            ("fcrNCapacity", self.fcr_n),
            ("fcrDUpCapacity", self.fcr_d_up),
            ("fcrDDownCapacity", self.fcr_d_down),
            ("fcrCapacity", self.fcr),
            ("ffrCapacity", self.ffr),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ParameterError {
                    name,
                    value,
                    requirement: "must be a finite number >= 0 W (0: not offered)".into(),
                });
            }
        }
        if !(49.0..=49.9).contains(&self.ffr_trigger) {
            return Err(ParameterError {
                name: "ffrTriggerFrequency",
                value: self.ffr_trigger,
                requirement:
                    "must be within [49.0, 49.9] Hz (the Nordic options are 49.7, 49.6 and 49.5 Hz)"
                        .into(),
            });
        }
        if !(self.ffr_duration.is_finite() && self.ffr_duration > 0.0) {
            return Err(ParameterError {
                name: "ffrSupportDuration",
                value: self.ffr_duration,
                requirement: "must be > 0 s".into(),
            });
        }
        if !(self.filter_zero.is_finite() && self.filter_zero >= 0.0) {
            return Err(ParameterError {
                name: "reserveFilterZero",
                value: self.filter_zero,
                requirement: "must be a finite number >= 0 s (0: no filter)".into(),
            });
        }
        if self.filter_zero > 0.0 && self.compensation {
            return Err(ParameterError {
                name: "reserveFilterZero",
                value: self.filter_zero,
                requirement: "must be 0 with reserveCompensation = true (that is reserveFilterZero = tauPole2): choose one".into(),
            });
        }
        Ok(())
    }

    /// Whether any product is offered or the setpoint is pre-filtered (the plant then holds
    /// its inputs over a step, as a hub does).
    pub fn offered(&self) -> bool {
        self.fcr_n > 0.0
            || self.fcr_d_up > 0.0
            || self.fcr_d_down > 0.0
            || self.fcr > 0.0
            || self.ffr > 0.0
            || self.compensation
            || self.filter_zero > 0.0
    }

    /// ΔP [W] of the proportional products (all but FFR) at frequency `f` [Hz].
    pub fn proportional(&self, f: f64) -> f64 {
        let n = ((NOMINAL_FREQUENCY - f) / 0.1).clamp(-1.0, 1.0);
        let d_up = ((49.9 - f) / 0.4).clamp(0.0, 1.0);
        let d_down = ((f - 50.1) / 0.4).clamp(0.0, 1.0);
        let ce = ((NOMINAL_FREQUENCY - f) / 0.2).clamp(-1.0, 1.0);
        // Products not offered add an exact 0, so nothing offered asks for exactly nothing.
        -self.fcr_n * n - self.fcr_d_up * d_up + self.fcr_d_down * d_down - self.fcr * ce
    }

    /// The largest reduction of draw the products can ask for together [W].
    pub fn reduction_offered(&self) -> f64 {
        self.fcr_n + self.fcr_d_up + self.fcr + self.ffr
    }

    /// The largest increase of draw the products can ask for together [W].
    pub fn increase_offered(&self) -> f64 {
        self.fcr_n + self.fcr_d_down + self.fcr
    }
}

/// Where FFR is: armed, active until a time [s], or spent until the frequency recovers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FastReserve {
    /// Waiting for the frequency to fall to the trigger.
    Armed,
    /// Asking for its capacity until this time [s].
    Active { until: f64 },
    /// Delivered; armed again once the frequency is above the trigger.
    Spent,
}

/// The reserve products' controller: settings and FFR's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrequencyResponse {
    /// The products offered.
    pub settings: ReserveSettings,
    /// FFR's state.
    pub fast: FastReserve,
}

impl FrequencyResponse {
    /// An armed controller.
    pub fn new(settings: ReserveSettings) -> Self {
        FrequencyResponse {
            settings,
            fast: FastReserve::Armed,
        }
    }

    /// At a step's start `t` [s] with frequency `f` [Hz]: FFR triggers, or re-arms.
    pub fn begin_step(&mut self, t: f64, f: f64) {
        let trigger = self.settings.ffr_trigger;
        self.fast = match self.fast {
            FastReserve::Armed if self.settings.ffr > 0.0 && f <= trigger => FastReserve::Active {
                until: t + self.settings.ffr_duration,
            },
            FastReserve::Spent if f > trigger => FastReserve::Armed,
            other => other,
        };
    }

    /// The request ΔP [W] at frequency `f` [Hz] now.
    pub fn request(&self, f: f64) -> f64 {
        let fast = match self.fast {
            FastReserve::Active { .. } => -self.settings.ffr,
            FastReserve::Armed | FastReserve::Spent => 0.0,
        };
        self.settings.proportional(f) + fast
    }

    /// When the request changes by itself (FFR's end) [s], if it does.
    pub fn next_event(&self) -> Option<f64> {
        match self.fast {
            FastReserve::Active { until } => Some(until),
            FastReserve::Armed | FastReserve::Spent => None,
        }
    }

    /// At time `t` [s]: FFR's support ends if it is due.
    pub fn end_due(&mut self, t: f64) {
        if let FastReserve::Active { until } = self.fast {
            if t >= until {
                self.fast = FastReserve::Spent;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn offering(fcr_n: f64, fcr_d_up: f64, fcr_d_down: f64, fcr: f64) -> ReserveSettings {
        ReserveSettings {
            fcr_n,
            fcr_d_up,
            fcr_d_down,
            fcr,
            ..ReserveSettings::default()
        }
    }

    #[test]
    fn each_product_activates_linearly_over_its_band_and_caps_at_full() {
        let n = offering(1.0, 0.0, 0.0, 0.0);
        for (f, want) in [
            (50.0, 0.0),
            (49.95, -0.5),
            (49.9, -1.0),
            (49.0, -1.0),
            (50.05, 0.5),
            (50.1, 1.0),
            (51.0, 1.0),
        ] {
            assert!(
                (n.proportional(f) - want).abs() < 1e-12,
                "FCR-N at {f}: {}",
                n.proportional(f)
            );
        }
        let up = offering(0.0, 1.0, 0.0, 0.0);
        for (f, want) in [
            (50.0, 0.0),
            (49.9, 0.0),
            (49.8, -0.25),
            (49.5, -1.0),
            (49.0, -1.0),
            (50.3, 0.0),
        ] {
            assert!((up.proportional(f) - want).abs() < 1e-12, "FCR-D up at {f}");
        }
        let down = offering(0.0, 0.0, 1.0, 0.0);
        for (f, want) in [
            (50.0, 0.0),
            (50.1, 0.0),
            (50.3, 0.5),
            (50.5, 1.0),
            (51.0, 1.0),
            (49.5, 0.0),
        ] {
            assert!(
                (down.proportional(f) - want).abs() < 1e-12,
                "FCR-D down at {f}"
            );
        }
        let ce = offering(0.0, 0.0, 0.0, 1.0);
        for (f, want) in [
            (50.0, 0.0),
            (49.9, -0.5),
            (49.8, -1.0),
            (49.0, -1.0),
            (50.2, 1.0),
        ] {
            assert!((ce.proportional(f) - want).abs() < 1e-12, "FCR at {f}");
        }
        assert_eq!(ReserveSettings::default().proportional(47.0), 0.0);
        let all = offering(2.0, 3.0, 5.0, 7.0);
        assert_eq!(
            (all.reduction_offered(), all.increase_offered()),
            (12.0, 14.0)
        );
        assert!((all.proportional(49.5) - (-2.0 - 3.0 - 7.0)).abs() < 1e-12);
    }

    #[test]
    fn ffr_triggers_holds_for_its_duration_and_rearms_above_the_trigger() {
        let settings = ReserveSettings {
            ffr: 10.0,
            ffr_trigger: 49.6,
            ffr_duration: 5.0,
            ..ReserveSettings::default()
        };
        let mut r = FrequencyResponse::new(settings);
        r.begin_step(0.0, 49.61);
        assert_eq!((r.request(49.61), r.next_event()), (0.0, None));
        r.begin_step(1.0, 49.6);
        assert_eq!((r.request(49.6), r.next_event()), (-10.0, Some(6.0)));
        r.begin_step(2.0, 50.0); // recovered, still held
        assert_eq!(r.request(50.0), -10.0);
        r.end_due(5.9);
        assert_eq!(r.request(50.0), -10.0);
        r.end_due(6.0);
        assert_eq!((r.fast, r.request(49.0)), (FastReserve::Spent, 0.0));
        r.begin_step(7.0, 49.0); // still low: no second activation
        assert_eq!(r.fast, FastReserve::Spent);
        r.begin_step(8.0, 49.65);
        r.begin_step(9.0, 49.5);
        assert_eq!(r.fast, FastReserve::Active { until: 14.0 });
    }

    #[test]
    fn bad_settings_are_named() {
        let bad = |s: ReserveSettings| s.validate().unwrap_err().to_string();
        assert!(bad(ReserveSettings {
            fcr_d_up: -1.0,
            ..Default::default()
        })
        .contains("fcrDUpCapacity"));
        assert!(bad(ReserveSettings {
            ffr: f64::NAN,
            ..Default::default()
        })
        .contains("ffrCapacity"));
        assert!(bad(ReserveSettings {
            ffr_trigger: 49.95,
            ..Default::default()
        })
        .contains("ffrTriggerFrequency"));
        assert!(bad(ReserveSettings {
            ffr_duration: 0.0,
            ..Default::default()
        })
        .contains("ffrSupportDuration"));
        assert!(
            ReserveSettings::default().validate().is_ok() && !ReserveSettings::default().offered()
        );
    }
}
