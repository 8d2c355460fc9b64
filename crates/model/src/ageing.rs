//! Ageing: a voltage drift d [V] on top of the polarisation curve, V = V(T, I) + d.
//!
//! d = d_irr + d_rev:
//! - irreversible: d_irr rises by ρ per running hour (linearly while Steady) and by δs per
//!   start, and never falls;
//! - reversible (the paper's consecutive-runtime drift): while Steady τb·dd_rev/dt = A − d_rev
//!   (it builds up toward the amplitude A), otherwise τr·dd_rev/dt = −d_rev (it recovers).
//!
//! Over a running piece from (d_irr0, d_rev0), τ seconds into it,
//!   d(τ) = d_irr0 + A + ρ'·τ + (d_rev0 − A)·e^(−τ/τb),   ρ' = ρ/3600 [V/s],
//! so the energy the drift draws is exact from the current's moments
//! ([`crate::CurrentDynamics::advance_with_moments`] at μ = 1/τb):
//!   ∫d·I dτ = d(0)·∫I + ρ'·∫τ·I + (d_rev0 − A)·(∫e^(−τ/τb)·I − ∫I).
//! The drift does not change the current or the hydrogen (Faraday), only the voltage, the
//! power and, with the thermal model, the heat (V − n·1.481 V)·I. All defaults are zero: no
//! drift, the paper's model bit for bit.

use super::dynamics::CurrentIntegrals;
use super::parameters::ParameterError;

const SECONDS_PER_HOUR: f64 = 3600.0;

/// How a module's voltage drifts with use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AgeingParameters {
    /// ρ: irreversible rise per running hour [V/h].
    pub drift_per_running_hour: f64,
    /// δs: irreversible rise per start [V].
    pub drift_per_start: f64,
    /// A: the reversible drift a long run approaches [V].
    pub reversible_drift: f64,
    /// τb: its build-up time constant while running [s].
    pub drift_build_up_time: f64,
    /// τr: its recovery time constant while not running [s].
    pub drift_recovery_time: f64,
    /// Irreversible drift at the start of the simulation [V] (an aged stack).
    pub initial_drift: f64,
}

impl Default for AgeingParameters {
    /// No drift. The time constants are assumptions used only once an amplitude is set:
    /// 6 h to build up, 12 h to recover.
    fn default() -> Self {
        AgeingParameters {
            drift_per_running_hour: 0.0,
            drift_per_start: 0.0,
            reversible_drift: 0.0,
            drift_build_up_time: 21_600.0,
            drift_recovery_time: 43_200.0,
            initial_drift: 0.0,
        }
    }
}

/// A module's drift now [V].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Drift {
    /// d_irr [V].
    pub irreversible: f64,
    /// d_rev [V].
    pub reversible: f64,
}

impl Drift {
    /// d = d_irr + d_rev [V].
    pub fn total(&self) -> f64 {
        self.irreversible + self.reversible
    }
}

impl AgeingParameters {
    /// Rises and amplitudes finite and ≥ 0, time constants finite and > 0; the error names
    /// the value.
    pub fn validate(&self) -> Result<(), ParameterError> {
        for (name, value) in [
            ("driftPerRunningHour", self.drift_per_running_hour),
            ("driftPerStart", self.drift_per_start),
            ("reversibleDrift", self.reversible_drift),
            ("initialVoltageDrift", self.initial_drift),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ParameterError {
                    name,
                    value,
                    requirement: "must be a finite number >= 0".into(),
                });
            }
        }
        for (name, value) in [
            ("driftBuildUpTime", self.drift_build_up_time),
            ("driftRecoveryTime", self.drift_recovery_time),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(ParameterError {
                    name,
                    value,
                    requirement: "must be a finite number > 0".into(),
                });
            }
        }
        Ok(())
    }

    /// Whether any drift is modelled (off: the paper's voltage).
    pub fn is_on(&self) -> bool {
        self.drift_per_running_hour != 0.0
            || self.drift_per_start != 0.0
            || self.reversible_drift != 0.0
            || self.initial_drift != 0.0
    }

    /// The drift at the start: d_irr = `initialVoltageDrift`, d_rev = 0.
    pub fn initial(&self) -> Drift {
        Drift {
            irreversible: self.initial_drift,
            reversible: 0.0,
        }
    }

    /// μ = 1/τb [1/s], the rate of the running piece's exponential.
    pub fn build_up_rate(&self) -> f64 {
        1.0 / self.drift_build_up_time
    }

    /// How d changes along a running piece that starts at `drift`.
    pub fn change_while_running(&self, drift: Drift) -> DriftChange {
        DriftChange {
            slope: self.drift_per_running_hour / SECONDS_PER_HOUR,
            gap: drift.reversible - self.reversible_drift,
            rate: self.build_up_rate(),
        }
    }

    /// The drift after `length` [s] Steady.
    pub fn after_running(&self, drift: Drift, length: f64) -> Drift {
        let a = self.reversible_drift;
        Drift {
            irreversible: drift.irreversible
                + self.drift_per_running_hour / SECONDS_PER_HOUR * length,
            reversible: a + (drift.reversible - a) * (-length / self.drift_build_up_time).exp(),
        }
    }

    /// The drift after `length` [s] not running: d_rev·e^(−L/τr).
    pub fn after_rest(&self, drift: Drift, length: f64) -> Drift {
        if drift.reversible == 0.0 {
            return drift;
        }
        Drift {
            reversible: drift.reversible * (-length / self.drift_recovery_time).exp(),
            ..drift
        }
    }

    /// The drift after one more start: d_irr + δs.
    pub fn after_start(&self, drift: Drift) -> Drift {
        Drift {
            irreversible: drift.irreversible + self.drift_per_start,
            ..drift
        }
    }

    /// Whether a running piece from `drift` needs the current's moments (the drift moves).
    pub fn moves_while_running(&self, drift: Drift) -> bool {
        self.change_while_running(drift).varies()
    }

    /// ∫d·I dτ over a running piece from `drift` [J], from its integrals (with moments at
    /// [`Self::build_up_rate`] where [`Self::moves_while_running`]).
    pub fn energy(&self, drift: Drift, ints: &CurrentIntegrals) -> f64 {
        drift.total() * ints.charge + self.change_while_running(drift).charge(ints)
    }
}

/// The drift's change along a running piece, Δd(τ) = d(τ) − d(0) = ρ'·τ + g·(e^(−μτ) − 1) [V]
/// with g = d_rev0 − A and μ = 1/τb.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriftChange {
    /// ρ' [V/s].
    pub slope: f64,
    /// g [V].
    pub gap: f64,
    /// μ [1/s].
    pub rate: f64,
}

impl DriftChange {
    /// No change at all.
    pub const NONE: DriftChange = DriftChange {
        slope: 0.0,
        gap: 0.0,
        rate: 0.0,
    };

    /// Whether the drift moves along the piece.
    pub fn varies(&self) -> bool {
        self.slope != 0.0 || self.gap != 0.0
    }

    /// Δd(τ) [V].
    pub fn at(&self, tau: f64) -> f64 {
        self.slope * tau + self.gap * (-self.rate * tau).exp_m1()
    }

    /// The smallest and largest Δd over [0, h] [V]: the ends, and where Δd' = ρ' − μ·g·e^(−μτ)
    /// vanishes if that lies inside.
    pub fn bounds(&self, h: f64) -> (f64, f64) {
        let end = self.at(h);
        let (mut lo, mut hi) = (end.min(0.0), end.max(0.0));
        let ratio = self.rate * self.gap / self.slope;
        if ratio > 0.0 && ratio.is_finite() {
            let tau = ratio.ln() / self.rate;
            if tau > 0.0 && tau < h {
                let v = self.at(tau);
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        (lo, hi)
    }

    /// ∫Δd·I dτ [J] from a piece's integrals with moments at μ:
    /// ρ'·∫τ·I + g·(∫e^(−μτ)·I − ∫I).
    pub fn charge(&self, ints: &CurrentIntegrals) -> f64 {
        if !self.varies() {
            return 0.0;
        }
        self.slope * ints.time_moment + self.gap * (ints.decay_moment - ints.charge)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn aged() -> AgeingParameters {
        AgeingParameters {
            drift_per_running_hour: 3.6e-3,
            drift_per_start: 2e-3,
            reversible_drift: 0.5,
            drift_build_up_time: 7200.0,
            drift_recovery_time: 3600.0,
            initial_drift: 0.1,
        }
    }

    #[test]
    fn the_reversible_drift_builds_up_and_recovers_first_order() {
        let p = aged();
        let d = p.after_running(p.initial(), 7200.0);
        // One time constant: A·(1 − 1/e); the irreversible part 1 mV/s·… = 3.6 mV/h · 2 h.
        assert!((d.reversible - 0.5 * (1.0 - (-1.0f64).exp())).abs() < 1e-15);
        assert!((d.irreversible - (0.1 + 7.2e-3)).abs() < 1e-15);
        let rested = p.after_rest(d, 3600.0);
        assert!((rested.reversible - d.reversible * (-1.0f64).exp()).abs() < 1e-15);
        assert_eq!(rested.irreversible, d.irreversible);
        assert_eq!(p.after_start(rested).irreversible, d.irreversible + 2e-3);
    }

    #[test]
    fn the_change_along_a_piece_is_the_state_difference() {
        let p = aged();
        let d0 = Drift {
            irreversible: 0.2,
            reversible: 0.1,
        };
        let change = p.change_while_running(d0);
        for tau in [0.0, 1.0, 600.0, 9000.0] {
            let want = p.after_running(d0, tau).total() - d0.total();
            assert!((change.at(tau) - want).abs() < 1e-14, "{tau}");
        }
    }

    #[test]
    fn the_bounds_hold_the_drift_where_it_turns() {
        // Above its amplitude the reversible part falls while the irreversible one rises:
        // Δd first falls, then rises.
        let change = DriftChange {
            slope: 1e-4,
            gap: 0.5,
            rate: 1e-3,
        };
        let (lo, hi) = change.bounds(20_000.0);
        let samples = (0..=20_000).map(|k| change.at(k as f64));
        let (min, max) = samples.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
        assert!(lo <= min + 1e-15 && lo > min - 1e-7);
        assert!(hi >= max - 1e-15 && hi < max + 1e-7);
    }

    #[test]
    fn bad_values_are_named() {
        for (set, name) in [
            (
                AgeingParameters {
                    drift_per_running_hour: -1.0,
                    ..aged()
                },
                "driftPerRunningHour",
            ),
            (
                AgeingParameters {
                    drift_build_up_time: 0.0,
                    ..aged()
                },
                "driftBuildUpTime",
            ),
            (
                AgeingParameters {
                    drift_recovery_time: f64::NAN,
                    ..aged()
                },
                "driftRecoveryTime",
            ),
            (
                AgeingParameters {
                    initial_drift: f64::INFINITY,
                    ..aged()
                },
                "initialVoltageDrift",
            ),
        ] {
            assert_eq!(set.validate().unwrap_err().name, name);
        }
        assert!(!AgeingParameters::default().is_on());
        assert!(aged().validate().is_ok());
    }
}
