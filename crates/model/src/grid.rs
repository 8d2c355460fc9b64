//! The grid side of a module: what it draws besides its stack (optional; zero by default).
//!
//! A module's power supply turns grid power into the stack's DC current with a loss
//! P_loss = P0 + Vs·I + Rs·I² [W] while the stack carries current I [A] (a converter's
//! no-load, forward-voltage and resistive losses), and its balance of plant (dryer, pumps,
//! control, ventilation) draws the auxiliary power P_aux [W] while the module starts or runs.
//! The grid sees
//!
//! P_ac = P + P_loss + P_aux,
//!
//! P being the model's electric power (the stack's (V0 + R·I)·I while running, startPower
//! while starting, standbyPower in standby and while stopping). Both terms are linear in the
//! current's moments, so their energies are exact: P0·t_run + Vs·∫I dt + Rs·∫I² dt and
//! P_aux·(t_run + t_start). With every term zero (the default) the grid sees P.

use super::parameters::ParameterError;

/// Supply losses and auxiliary power of one module, and which side a power reference means.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GridParameters {
    /// auxiliaryPower: balance of plant while a module starts or runs [W].
    pub auxiliary_power: f64,
    /// supplyNoLoadLoss: the supply's loss P0 while it carries stack current [W].
    pub supply_no_load_loss: f64,
    /// supplyLossVoltage: the supply's loss per ampere of stack current, Vs [V].
    pub supply_loss_voltage: f64,
    /// supplyLossResistance: the supply's loss per ampere squared, Rs [Ω].
    pub supply_loss_resistance: f64,
    /// gridSideReference: a power reference and the reserves' requests are grid power
    /// (P_ac), not the model's electric power P.
    pub grid_side_reference: bool,
}

impl GridParameters {
    /// Every loss and power must be finite and ≥ 0; the error names the value.
    pub fn validate(&self) -> Result<(), ParameterError> {
        for (name, value, unit) in [
            ("auxiliaryPower", self.auxiliary_power, "W"),
            ("supplyNoLoadLoss", self.supply_no_load_loss, "W"),
            ("supplyLossVoltage", self.supply_loss_voltage, "V"),
            ("supplyLossResistance", self.supply_loss_resistance, "Ohm"),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ParameterError {
                    name,
                    value,
                    requirement: format!("must be a finite number >= 0 {unit}"),
                });
            }
        }
        Ok(())
    }

    /// What a running module draws besides its stack at current `i` [A]:
    /// P0 + Vs·I + Rs·I² + P_aux [W].
    #[inline]
    pub fn running_extra(&self, i: f64) -> f64 {
        self.supply_no_load_loss
            + (self.supply_loss_voltage + self.supply_loss_resistance * i) * i
            + self.auxiliary_power
    }

    /// Grid power [W] of `sums` (modules in some states, summed) whose electric power is
    /// `power` [W]: P + Σ(P0 + Vs·I + Rs·I²) over the running + P_aux·(running + starting).
    pub fn ac_power(&self, power: f64, sums: &CurrentSums) -> f64 {
        power + self.supply_loss(sums) + self.auxiliary_power * (sums.running + sums.starting)
    }

    /// The supply's loss [W or J] of `sums`: P0·running + Vs·∫I + Rs·∫I² (instantaneous
    /// sums give a power, time integrals an energy).
    pub fn supply_loss(&self, sums: &CurrentSums) -> f64 {
        self.supply_no_load_loss * sums.running
            + self.supply_loss_voltage * sums.current
            + self.supply_loss_resistance * sums.current_squared
    }

    /// The auxiliaries' energy [J] over `sums` (time integrals): P_aux·(t_run + t_start).
    pub fn auxiliary_energy(&self, sums: &CurrentSums) -> f64 {
        self.auxiliary_power * (sums.running + sums.starting)
    }

    /// Grid energy [J] of modules whose electric energy is `energy` [J], over `sums`.
    pub fn ac_energy(&self, energy: f64, sums: &CurrentSums) -> f64 {
        energy + self.supply_loss(sums) + self.auxiliary_energy(sums)
    }
}

/// Assumed losses of a 2.4 kW module's supply and balance of plant, for the tests.
#[cfg(test)]
pub(crate) const TEST_LOSSES: GridParameters = GridParameters {
    auxiliary_power: 150.0,
    supply_no_load_loss: 40.0,
    supply_loss_voltage: 0.8,
    supply_loss_resistance: 0.002,
    grid_side_reference: false,
};

/// The current's moments over some modules: either now (counts [1], ΣI [A], ΣI² [A²]) or
/// integrated over time (module-seconds [s], ∫ΣI dt [A·s], ∫ΣI² dt [A²·s]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CurrentSums {
    /// Running modules (carrying current), or their running time.
    pub running: f64,
    /// Starting modules, or their starting time.
    pub starting: f64,
    /// ΣI, or the charge ∫ΣI dt.
    pub current: f64,
    /// ΣI², or ∫ΣI² dt.
    pub current_squared: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    const LOSSY: GridParameters = TEST_LOSSES;

    #[test]
    fn a_running_module_draws_its_losses_and_auxiliaries() {
        let i = 50.0;
        let sums = CurrentSums {
            running: 1.0,
            starting: 0.0,
            current: i,
            current_squared: i * i,
        };
        let extra = 40.0 + 0.8 * 50.0 + 0.002 * 2500.0 + 150.0;
        assert_eq!(LOSSY.ac_power(2000.0, &sums), 2000.0 + extra);
        assert_eq!(LOSSY.running_extra(i), extra);
    }

    #[test]
    fn a_starting_module_draws_only_its_auxiliaries() {
        let sums = CurrentSums {
            starting: 3.0,
            ..CurrentSums::default()
        };
        assert_eq!(LOSSY.ac_power(900.0, &sums), 900.0 + 3.0 * 150.0);
    }

    #[test]
    fn energies_over_an_hour_at_constant_current() {
        let (i, t) = (40.0, 3600.0);
        let sums = CurrentSums {
            running: t,
            starting: 300.0,
            current: i * t,
            current_squared: i * i * t,
        };
        let loss = (40.0 + 0.8 * i + 0.002 * i * i) * t;
        assert!((LOSSY.supply_loss(&sums) - loss).abs() < 1e-9 * loss);
        assert_eq!(LOSSY.auxiliary_energy(&sums), 150.0 * 3900.0);
        assert!((LOSSY.ac_energy(1e6, &sums) - (1e6 + loss + 150.0 * 3900.0)).abs() < 1e-6);
    }

    #[test]
    fn the_default_adds_nothing() {
        let sums = CurrentSums {
            running: 2.0,
            starting: 1.0,
            current: 80.0,
            current_squared: 3200.0,
        };
        assert_eq!(GridParameters::default().ac_power(4321.5, &sums), 4321.5);
        assert_eq!(GridParameters::default().ac_energy(1e7, &sums), 1e7);
    }

    #[test]
    fn bad_values_are_named() {
        for (name, g) in [
            (
                "auxiliaryPower",
                GridParameters {
                    auxiliary_power: -1.0,
                    ..LOSSY
                },
            ),
            (
                "supplyNoLoadLoss",
                GridParameters {
                    supply_no_load_loss: f64::NAN,
                    ..LOSSY
                },
            ),
            (
                "supplyLossVoltage",
                GridParameters {
                    supply_loss_voltage: f64::INFINITY,
                    ..LOSSY
                },
            ),
            (
                "supplyLossResistance",
                GridParameters {
                    supply_loss_resistance: -1e-3,
                    ..LOSSY
                },
            ),
        ] {
            assert_eq!(g.validate().unwrap_err().name, name);
        }
        assert!(LOSSY.validate().is_ok());
    }
}
