//! Stack temperature (optional, off by default): a lumped heat balance with an ideal thermostat.
//!
//! - Voltage: V = V0 + kV·(T − Tn) + (R + kR·(T − Tn))·I [V]
//! - Heat balance: C·dT/dt = (V − n·1.481 V)·I − (T − Ta)/Rth − Qc [W]
//!   (1.481 V: the thermoneutral voltage of one cell; n cells in series)
//! - Thermostat with setpoint Ts: Qc = 0 below Ts; Qc = Qmax above Ts; at Ts it holds the
//!   temperature (Qc = the surplus heat s = (V(Ts) − n·1.481 V)·I − (Ts − Ta)/Rth) while
//!   0 ≤ s ≤ Qmax.
//! - In standby a heater of at most Qh (`standbyHeaterPower`) takes the thermostat's other
//!   side: Qc = −Qh below Ts, and at Ts it holds the temperature while −Qh ≤ s ≤ Qmax
//!   (Qc = s < 0: the heater makes up the loss). With Qh = 0 (the default) a module in
//!   standby cools like a stopped one.
//!
//! The balance is linear in T for a given current: C·dT/dt = α·T + β with
//!   α = (kV + kR·I)·I − 1/Rth,  β = (V0 − kV·Tn + (R − kR·Tn)·I − n·1.481 V)·I + Ta/Rth − Qc,
//! so at constant current it is solved in closed form ([`step`]); while the current moves it
//! is integrated with error control, and the instants where the thermostat's regime changes
//! are located inside the step.

use super::parameters::ParameterError;

mod collocation;
mod path;
pub mod step;

/// Ambient temperature a stack sees until it is told another [K] (15 °C, the FMU's start value
/// of `ambientTemperature`).
pub const AMBIENT_START: f64 = 288.15;

/// Thermoneutral voltage of one water-electrolysis cell (higher heating value) [V].
pub const THERMONEUTRAL_CELL_VOLTAGE: f64 = 1.481;

/// Parameters of the stack's heat balance and of the temperature dependence of its voltage.
///
/// Defaults: see [`ThermalParameters::default`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThermalParameters {
    /// Stack temperature at t = 0 [K].
    pub initial_temperature: f64,
    /// C: heat capacity of the stack with its electrolyte [J/K].
    pub heat_capacity: f64,
    /// Rth: thermal resistance from the stack to ambient [K/W].
    pub thermal_resistance: f64,
    /// Ts: temperature the thermostat holds [K].
    pub cooling_setpoint: f64,
    /// Qmax: largest heat the cooling removes [W].
    pub max_cooling_power: f64,
    /// n: cells in series [1].
    pub n_cells: i32,
    /// Tn: temperature of the identified polarisation curve (V0, R) [K].
    pub nominal_temperature: f64,
    /// kV: change of the voltage intercept per kelvin [V/K].
    pub voltage_temperature_coefficient: f64,
    /// kR: change of the ohmic resistance per kelvin [Ω/K].
    pub resistance_temperature_coefficient: f64,
    /// A module whose stack is at least this warm starts warm (warmStartTime), else cold
    /// (coldStartTime), whatever its state [K].
    pub warm_start_temperature: f64,
    /// Qh: largest heat the standby heater supplies, drawn as electric power on top of
    /// standbyPower [W]; 0: no heater.
    pub standby_heater_power: f64,
}

/// Shortest thermal time constant Rth·C accepted [s]: a stack's is minutes to hours; a
/// shorter one would only make the heat balance stiff.
pub const MIN_TIME_CONSTANT: f64 = 1.0;

impl Default for ThermalParameters {
    /// Assumed values for the paper's module (Enapter EL 4.0, 2.4 kW, 23 cells), reasoned in
    /// the documentation's model page:
    /// - C = 25 kJ/K: about 3 l of electrolyte (12.6 kJ/K) and 25 kg of stack metal
    ///   (≈ 0.5 kJ/(kg·K));
    /// - Rth = 0.2 K/W: an insulated enclosure that loses 200 W at 40 K above ambient, so a
    ///   module at the bottom of the window (≈ 210 W of heat) still reaches 55 °C at 15 °C
    ///   ambient, and full load (≈ 530 W) needs the cooling;
    /// - Ts = Tn = 328.15 K (55 °C, the temperature of Table I's polarisation curve);
    ///   Qmax = 1 kW; start at 15 °C;
    /// - kV = −0.046 V/K (−2 mV/K per cell) and kR = −1.5 mΩ/K (−1 %/K of R): the few mV/K
    ///   per cell, negative, of alkaline and AEM cells in the literature;
    /// - a warm start from 40 °C up (half-way between a cold stack and the setpoint).
    fn default() -> Self {
        ThermalParameters {
            initial_temperature: 288.15,
            heat_capacity: 25_000.0,
            thermal_resistance: 0.2,
            cooling_setpoint: 328.15,
            max_cooling_power: 1000.0,
            n_cells: 23,
            nominal_temperature: 328.15,
            voltage_temperature_coefficient: -0.046,
            resistance_temperature_coefficient: -0.0015,
            warm_start_temperature: 313.15,
            standby_heater_power: 0.0,
        }
    }
}

impl ThermalParameters {
    /// Refuses values that cannot describe a stack; the error names the first bad one.
    pub fn validate(&self) -> Result<(), ParameterError> {
        let positive = [
            ("initialTemperature", self.initial_temperature, "K"),
            ("heatCapacity", self.heat_capacity, "J/K"),
            ("thermalResistance", self.thermal_resistance, "K/W"),
            ("coolingSetpoint", self.cooling_setpoint, "K"),
            ("nominalTemperature", self.nominal_temperature, "K"),
            ("warmStartTemperature", self.warm_start_temperature, "K"),
        ];
        for (name, value, unit) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(ParameterError {
                    name,
                    value,
                    requirement: format!("must be a finite number > 0 {unit}"),
                });
            }
        }
        for (name, value) in [
            ("maxCoolingPower", self.max_cooling_power),
            ("standbyHeaterPower", self.standby_heater_power),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ParameterError {
                    name,
                    value,
                    requirement: "must be a finite number >= 0 W".into(),
                });
            }
        }
        if !(1..=100_000).contains(&self.n_cells) {
            return Err(ParameterError {
                name: "nCells",
                value: self.n_cells as f64,
                requirement: "must be within [1, 100000]".into(),
            });
        }
        for (name, value) in [
            (
                "voltageTemperatureCoefficient",
                self.voltage_temperature_coefficient,
            ),
            (
                "resistanceTemperatureCoefficient",
                self.resistance_temperature_coefficient,
            ),
        ] {
            if !value.is_finite() {
                return Err(ParameterError {
                    name,
                    value,
                    requirement: "must be a finite number".into(),
                });
            }
        }
        let tau = self.thermal_resistance * self.heat_capacity;
        if !(tau >= MIN_TIME_CONSTANT) {
            return Err(ParameterError {
                name: "heatCapacity",
                value: self.heat_capacity,
                requirement: format!(
                    "thermalResistance·heatCapacity = {} s must be >= {MIN_TIME_CONSTANT} s (a stack's thermal time constant is minutes to hours)",
                    super::shown(tau)
                ),
            });
        }
        Ok(())
    }

    /// n·1.481 V: the stack's thermoneutral voltage [V].
    pub fn thermoneutral_voltage(&self) -> f64 {
        f64::from(self.n_cells) * THERMONEUTRAL_CELL_VOLTAGE
    }
}

/// What the thermostat does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Regime {
    /// Below the setpoint (or at it with too little heat to stay): no cooling.
    Below,
    /// At the setpoint, cooling exactly the surplus heat.
    Held,
    /// Above the setpoint (or at it with more surplus than the cooling removes): full cooling.
    Above,
}

/// The heat balance of one stack with its polarisation curve (V0 [V], R [Ω]) and ambient
/// temperature Ta [K].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeatBalance {
    /// The stack's thermal parameters.
    pub thermal: ThermalParameters,
    /// V0 at Tn [V].
    pub voltage_intercept: f64,
    /// R at Tn [Ω].
    pub ohmic_resistance: f64,
    /// Ta [K].
    pub ambient: f64,
    /// Heat the thermostat may supply now [W]: the standby heater's Qh in standby, else 0.
    pub heater: f64,
}

impl HeatBalance {
    /// V = V0 + kV·(T − Tn) + (R + kR·(T − Tn))·I [V].
    pub fn voltage(&self, temperature: f64, current: f64) -> f64 {
        let p = &self.thermal;
        let dt = temperature - p.nominal_temperature;
        self.voltage_intercept
            + p.voltage_temperature_coefficient * dt
            + (self.ohmic_resistance + p.resistance_temperature_coefficient * dt) * current
    }

    /// Heat the stack's losses produce: (V − n·1.481 V)·I [W].
    pub fn heat(&self, temperature: f64, current: f64) -> f64 {
        (self.voltage(temperature, current) - self.thermal.thermoneutral_voltage()) * current
    }

    /// Heat left to cool away at the setpoint: heat(Ts) − (Ts − Ta)/Rth [W].
    pub fn surplus(&self, current: f64) -> f64 {
        let p = &self.thermal;
        self.heat(p.cooling_setpoint, current)
            - (p.cooling_setpoint - self.ambient) / p.thermal_resistance
    }

    /// The same balance with the voltage drifted by `drift` [V]: V0 + d.
    pub fn drifted(&self, drift: f64) -> HeatBalance {
        HeatBalance {
            voltage_intercept: self.voltage_intercept + drift,
            ..*self
        }
    }

    /// The same balance in standby: the heater (`standbyHeaterPower`) on the thermostat.
    pub fn in_standby(&self) -> HeatBalance {
        HeatBalance {
            heater: self.thermal.standby_heater_power,
            ..*self
        }
    }

    /// The thermostat's regime at temperature T [K] and current I [A].
    pub fn regime(&self, temperature: f64, current: f64) -> Regime {
        let p = &self.thermal;
        if temperature < p.cooling_setpoint {
            Regime::Below
        } else if temperature > p.cooling_setpoint {
            Regime::Above
        } else {
            let s = self.surplus(current);
            if s < -self.heater {
                Regime::Below
            } else if s > p.max_cooling_power {
                Regime::Above
            } else {
                Regime::Held
            }
        }
    }

    /// What the thermostat takes away in `regime` at current I [A], Qc [W]: the cooling's
    /// heat, or minus the heater's.
    pub fn thermostat_power(&self, current: f64, regime: Regime) -> f64 {
        match regime {
            Regime::Below if self.heater > 0.0 => -self.heater,
            Regime::Below => 0.0,
            Regime::Held => self.surplus(current),
            Regime::Above => self.thermal.max_cooling_power,
        }
    }

    /// Cooling power max(Qc, 0) [W] at temperature T [K] and current I [A].
    pub fn cooling_power(&self, temperature: f64, current: f64) -> f64 {
        let q = self.thermostat_power(current, self.regime(temperature, current));
        if q < 0.0 {
            0.0
        } else {
            q
        }
    }

    /// The heater's power max(−Qc, 0) [W] at temperature T [K] and current I [A].
    pub fn heating_power(&self, temperature: f64, current: f64) -> f64 {
        let q = self.thermostat_power(current, self.regime(temperature, current));
        if q < 0.0 {
            -q
        } else {
            0.0
        }
    }

    /// (α, β) of C·dT/dt = α·T + β at current I [A] in a regime that is not `Held`:
    /// α [W/K], β [W].
    pub fn linear(&self, current: f64, regime: Regime) -> (f64, f64) {
        let p = &self.thermal;
        let (kv, kr, tn) = (
            p.voltage_temperature_coefficient,
            p.resistance_temperature_coefficient,
            p.nominal_temperature,
        );
        let alpha = (kv + kr * current) * current - 1.0 / p.thermal_resistance;
        let cooling = self.thermostat_power(current, regime);
        let beta = (self.voltage_intercept - kv * tn + (self.ohmic_resistance - kr * tn) * current
            - p.thermoneutral_voltage())
            * current
            + self.ambient / p.thermal_resistance
            - cooling;
        (alpha, beta)
    }

    /// dT/dt [K/s] at temperature T [K] and current I [A] in `regime`.
    pub fn rate(&self, temperature: f64, current: f64, regime: Regime) -> f64 {
        if regime == Regime::Held {
            return 0.0;
        }
        let (alpha, beta) = self.linear(current, regime);
        (alpha * temperature + beta) / self.thermal.heat_capacity
    }
}

#[cfg(test)]
mod tests;
