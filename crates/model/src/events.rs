//! Plant events: what the plant reports while it runs. The model decides when an event begins
//! and ends and what is only rounding noise; a host (the FMU) only logs them.
//!
//! - a single module's setpoint outside its operating window, and back in it;
//! - reserve capacities offered beyond what the window allows at the initial operating point;
//! - a reserve request that the window keeps the plant from delivering, and when it fits again;
//! - a request for more draw, which the rising-current limit slows.

use std::fmt;

use crate::{Parameters, Plant, PlantConfig, ReserveStep};

/// Relative distance outside the setpoint window below which no event is reported: rounding
/// noise from a master's interpolation (100.00000000000001 %) is clamped silently.
const WINDOW_TOLERANCE: f64 = 1e-9;

/// Shortfall of a reserve request, relative to the plant's largest steady power, below which
/// none is reported.
const RESERVE_TOLERANCE: f64 = 1e-9;

/// Which way reserves move the plant's draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Draw less (the frequency is low: FCR-N, FCR-D up, FCR, FFR).
    Less,
    /// Draw more (the frequency is high: FCR-N, FCR-D down, FCR).
    More,
}

/// One event of the plant. Powers in W, setpoints in %, frequencies in Hz.
#[derive(Clone, Debug, PartialEq)]
pub enum PlantEvent {
    /// A single module's setpoint left the window; the module runs at `runs_at` until it returns.
    SetpointOutsideWindow {
        setpoint: f64,
        window: (f64, f64),
        runs_at: f64,
    },
    /// The setpoint is back in the window.
    SetpointInWindow { setpoint: f64 },
    /// The capacities of `products`, offered together, ask for more than the window allows at
    /// the initial operating point (`baseline`): `shortfall` of `offered` cannot be delivered.
    CapacityBeyondWindow {
        products: Vec<&'static str>,
        direction: Direction,
        offered: f64,
        baseline: f64,
        range: (f64, f64),
        shortfall: f64,
    },
    /// The reserves' request at `frequency` does not fit the window: `shortfall` is missing.
    ReserveShortfall {
        frequency: f64,
        request: f64,
        baseline: f64,
        range: (f64, f64),
        shortfall: f64,
    },
    /// The reserves' request fits the window again.
    ReserveFits { frequency: f64 },
    /// The reserves ask for `request` more draw, which follows each module's rising-current
    /// limit [A/s].
    RampLimitedIncrease {
        frequency: f64,
        request: f64,
        ramp_up_limit: f64,
    },
}

impl PlantEvent {
    /// Whether the plant does not do what it was asked (a warning), rather than news.
    pub fn is_warning(&self) -> bool {
        !matches!(
            self,
            PlantEvent::SetpointInWindow { .. } | PlantEvent::ReserveFits { .. }
        )
    }
}

/// A power for messages, to four significant digits: 999.0 W, 1.043 kW, 12.40 kW, 59.87 MW.
pub fn watts(x: f64) -> String {
    let (value, unit) = match x.abs() {
        a if a >= 1e6 => (x / 1e6, "MW"),
        a if a >= 1e3 => (x / 1e3, "kW"),
        _ => (x, "W"),
    };
    let decimals = if value.abs() >= 100.0 {
        1
    } else if value.abs() >= 10.0 {
        2
    } else {
        3
    };
    format!("{value:.decimals$} {unit}")
}

impl fmt::Display for PlantEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlantEvent::SetpointOutsideWindow {
                setpoint,
                window: (lo, hi),
                runs_at,
            } => write!(
                f,
                "setpoint = {setpoint} % is outside the operating window [{lo}, {hi}] %; the module runs at \
                 {runs_at} % until it returns"
            ),
            PlantEvent::SetpointInWindow { setpoint } => {
                write!(f, "setpoint = {setpoint} % is back in the operating window")
            }
            PlantEvent::CapacityBeyondWindow {
                products,
                direction,
                offered,
                baseline,
                range: (lo, hi),
                shortfall,
            } => write!(
                f,
                "{} = {} asks the hub to draw up to that much {} than {} at the initial operating point; the \
                 operating window ({} to {}) allows {} of it: {} short",
                products.join(" + "),
                watts(*offered),
                match direction {
                    Direction::Less => "less",
                    Direction::More => "more",
                },
                watts(*baseline),
                watts(*lo),
                watts(*hi),
                watts(offered - shortfall),
                watts(*shortfall)
            ),
            PlantEvent::ReserveShortfall {
                frequency,
                request,
                baseline,
                range: (lo, hi),
                shortfall,
            } => write!(
                f,
                "frequency = {frequency} Hz: reserveRequest = {} on {}; the operating window ({} to {}) keeps the \
                 hub {} short until the request fits again",
                watts(*request),
                watts(*baseline),
                watts(*lo),
                watts(*hi),
                watts(*shortfall)
            ),
            PlantEvent::ReserveFits { frequency } => write!(
                f,
                "frequency = {frequency} Hz: the reserve request fits the operating window again"
            ),
            PlantEvent::RampLimitedIncrease {
                frequency,
                request,
                ramp_up_limit,
            } => write!(
                f,
                "frequency = {frequency} Hz asks the hub to draw {} more: each module's current rises at most \
                 rampUpLimit = {ramp_up_limit} A/s, so the increase follows that ramp",
                watts(*request)
            ),
        }
    }
}

/// The events under way, so that each is reported once when it begins and once when it ends.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EventState {
    /// A single module's setpoint is outside its window.
    pub setpoint_outside: bool,
    /// The window keeps the plant from delivering the reserves' request.
    pub reserve_shortfall: bool,
    /// The reserves ask for more draw, which the ramp limit slows.
    pub reserve_increase: bool,
}

impl EventState {
    /// A single module's `setpoint` [%] against its window: the event where it leaves or
    /// returns, else None.
    pub fn setpoint(&mut self, params: &Parameters, setpoint: f64) -> Option<PlantEvent> {
        let (lo, hi) = (params.min_setpoint, params.max_setpoint);
        let slack = WINDOW_TOLERANCE * lo.abs().max(hi.abs()).max(1.0);
        let outside = setpoint < lo - slack || setpoint > hi + slack;
        let event = match (outside, self.setpoint_outside) {
            (true, false) => Some(PlantEvent::SetpointOutsideWindow {
                setpoint,
                window: (lo, hi),
                runs_at: params.clamp_setpoint(setpoint),
            }),
            (false, true) => Some(PlantEvent::SetpointInWindow { setpoint }),
            _ => None,
        };
        self.setpoint_outside = outside;
        event
    }

    /// A step with reserves at `frequency` [Hz]: where the window's shortfall begins or ends, and
    /// where a request for more draw begins (it follows `ramp_up_limit` [A/s]).
    pub fn reserve_step(
        &mut self,
        step: &ReserveStep,
        frequency: f64,
        ramp_up_limit: f64,
    ) -> Vec<PlantEvent> {
        let mut events = Vec::new();
        let short = beyond_tolerance(step);
        if short && !self.reserve_shortfall {
            events.push(PlantEvent::ReserveShortfall {
                frequency,
                request: step.request,
                baseline: step.baseline,
                range: step.range,
                shortfall: step.shortfall.abs(),
            });
        }
        if !short && self.reserve_shortfall {
            events.push(PlantEvent::ReserveFits { frequency });
        }
        self.reserve_shortfall = short;
        let increase = step.request > 0.0;
        if increase && !self.reserve_increase {
            events.push(PlantEvent::RampLimitedIncrease {
                frequency,
                request: step.request,
                ramp_up_limit,
            });
        }
        self.reserve_increase = increase;
        events
    }

    /// No reserve event under way (a plant just initialised).
    pub fn reset_reserves(&mut self) {
        self.reserve_shortfall = false;
        self.reserve_increase = false;
    }
}

/// Whether the step's shortfall is more than rounding noise.
fn beyond_tolerance(step: &ReserveStep) -> bool {
    step.shortfall.abs() > RESERVE_TOLERANCE * step.range.1.max(1.0)
}

/// The reserves offered together, in each direction, that the window cannot deliver from the
/// initial operating point (`setpoint` [%] or `power` [W], as the plant takes its reference).
pub fn capacities_beyond_window(
    config: &PlantConfig,
    plant: &Plant,
    setpoint: f64,
    power: f64,
) -> Vec<PlantEvent> {
    let r = &config.reserve;
    let less = [
        ("fcrNCapacity", r.fcr_n),
        ("fcrDUpCapacity", r.fcr_d_up),
        ("fcrCapacity", r.fcr),
        ("ffrCapacity", r.ffr),
    ];
    let more = [
        ("fcrNCapacity", r.fcr_n),
        ("fcrDDownCapacity", r.fcr_d_down),
        ("fcrCapacity", r.fcr),
    ];
    let mut events = Vec::new();
    for (products, direction, sign) in [
        (&less[..], Direction::Less, -1.0),
        (&more[..], Direction::More, 1.0),
    ] {
        let offered: f64 = products.iter().map(|(_, c)| c).sum();
        if offered <= 0.0 {
            continue;
        }
        let step = plant.reserve_step(config, setpoint, power, sign * offered);
        if beyond_tolerance(&step) {
            events.push(PlantEvent::CapacityBeyondWindow {
                products: products
                    .iter()
                    .filter(|(_, c)| *c > 0.0)
                    .map(|(n, _)| *n)
                    .collect(),
                direction,
                offered,
                baseline: step.baseline,
                range: step.range,
                shortfall: step.shortfall.abs(),
            });
        }
    }
    events
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(request: f64, shortfall: f64) -> ReserveStep {
        ReserveStep {
            request,
            baseline: 40e6,
            range: (36e6, 60e6),
            shortfall,
        }
    }

    #[test]
    fn a_setpoint_excursion_is_reported_once_when_it_begins_and_once_when_it_ends() {
        let params = Parameters::default();
        let mut state = EventState::default();
        assert_eq!(state.setpoint(&params, 80.0), None);
        let left = state.setpoint(&params, 30.0).expect("leaves the window");
        assert!(left.is_warning());
        assert_eq!(
            left,
            PlantEvent::SetpointOutsideWindow {
                setpoint: 30.0,
                window: (params.min_setpoint, params.max_setpoint),
                runs_at: params.min_setpoint
            }
        );
        assert_eq!(state.setpoint(&params, 20.0), None);
        let back = state.setpoint(&params, 70.0).expect("returns");
        assert!(!back.is_warning());
        assert_eq!(
            back.to_string(),
            "setpoint = 70 % is back in the operating window"
        );
    }

    #[test]
    fn rounding_noise_at_the_window_edge_is_no_excursion() {
        let params = Parameters::default();
        let mut state = EventState::default();
        let noisy = params.max_setpoint * (1.0 + 1e-15);
        assert_eq!(state.setpoint(&params, noisy), None);
        assert!(!state.setpoint_outside);
    }

    #[test]
    fn a_reserve_shortfall_and_an_increase_are_reported_when_they_begin() {
        let mut state = EventState::default();
        let events = state.reserve_step(&step(30e6, 10e6), 49.5, 0.22);
        assert_eq!(events.len(), 2);
        assert!(
            matches!(events[0], PlantEvent::ReserveShortfall { shortfall, .. } if shortfall == 10e6)
        );
        assert!(
            matches!(events[1], PlantEvent::RampLimitedIncrease { ramp_up_limit, .. } if ramp_up_limit == 0.22)
        );
        assert!(state.reserve_step(&step(30e6, 10e6), 49.5, 0.22).is_empty());
        let fits = state.reserve_step(&step(-1e6, 0.0), 50.1, 0.22);
        assert_eq!(fits, vec![PlantEvent::ReserveFits { frequency: 50.1 }]);
        assert!(!state.reserve_shortfall && !state.reserve_increase);
    }

    #[test]
    fn powers_are_shown_to_four_significant_digits() {
        assert_eq!(watts(999.0), "999.0 W");
        assert_eq!(watts(1042.66), "1.043 kW");
        assert_eq!(watts(12_400.0), "12.40 kW");
        assert_eq!(watts(59_870_000.0), "59.87 MW");
    }
}
