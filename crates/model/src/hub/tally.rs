//! Sums over the groups, in one order whichever path stepped a group.
//!
//! Groups go in chunks of [`super::CHUNK`]; group j of a chunk adds to lane j mod 4 of the
//! chunk's [`Tally`], the lanes are folded in order, ((l0 + l1) + l2) + l3, into the chunk's
//! [`Part`], and the parts are added in chunk order into the hub's totals, survey and
//! readings. The scalar path, the lanes (four groups with one vector instruction), several
//! threads and a fresh survey all sum in that order, so each gives the same bits.

use super::super::lanes::{Lane, Outcomes, LANES};
use super::super::operation::{OperatingState, OperationParameters};
use super::super::parameters::Parameters;
use super::super::thermal::step::ThermalError;
use super::super::thermal::HeatBalance;
use super::{Group, HubReadings};

/// A chunk's sums while its groups are stepped or observed, lane k for group j ≡ k (mod 4).
#[derive(Clone, Copy, Debug)]
pub(super) struct Tally {
    /// Electric energy [J], hydrogen [Nl], running time [s], charge [A·s], ∫I² dt [A²·s]
    /// and starting time [s] over the piece.
    pub energy: Lane,
    pub h2_produced: Lane,
    pub running: Lane,
    pub charge: Lane,
    pub current_squared_time: Lane,
    pub starting: Lane,
    /// Power of the modules that carry no current share [W].
    pub others: Lane,
    /// Outputs after the piece: power [W], hydrogen flow [Nl/h], current [A], and the
    /// voltage [V] summed over Steady modules.
    pub power: Lane,
    pub h2_flow: Lane,
    pub current: Lane,
    pub current_squared: Lane,
    pub voltage: Lane,
    /// With the thermal model: stack temperatures [K] and cooling powers [W], summed.
    pub temperature: Lane,
    pub cooling: Lane,
    pub starts: u64,
    pub warm_starts: u64,
    /// Modules dispatched and Steady.
    pub carrying: u32,
    /// Modules Steady, and in each operating state.
    pub steady: u64,
    pub counts: [u32; 5],
    /// Time to the next end of a start, standby or stop [s]; infinite if none.
    pub next_event: f64,
    /// The first failure of the stack temperature's step in the chunk.
    pub failure: Option<ThermalError>,
}

impl Default for Tally {
    fn default() -> Self {
        let zero = [0.0; LANES];
        Tally {
            energy: zero,
            h2_produced: zero,
            running: zero,
            charge: zero,
            current_squared_time: zero,
            starting: zero,
            others: zero,
            power: zero,
            h2_flow: zero,
            current: zero,
            current_squared: zero,
            voltage: zero,
            temperature: zero,
            cooling: zero,
            starts: 0,
            warm_starts: 0,
            carrying: 0,
            steady: 0,
            counts: [0; 5],
            next_event: f64::INFINITY,
            failure: None,
        }
    }
}

impl Tally {
    /// Counts group `g` (lane k) as it is now: its outputs and its part in the survey.
    #[inline(always)]
    pub fn observe(
        &mut self,
        k: usize,
        g: &Group,
        p: &Parameters,
        thermal: Option<&HeatBalance>,
        op: &OperationParameters,
    ) {
        use OperatingState::*;
        let i = g.unit.stack_current();
        let c = g.count as f64;
        if let Some(balance) = thermal {
            self.temperature[k] += c * g.unit.temperature;
            let drifted = balance.drifted(g.unit.drift.total());
            self.cooling[k] += c * drifted.cooling_power(g.unit.temperature, i);
        }
        let grid = &op.grid;
        if g.unit.state == Steady {
            let v = g.unit.voltage(p, thermal);
            self.observe_steady(k, g.count, i, v * i, p.h2_coefficient * i, v);
            if g.active {
                self.carrying += g.count;
            } else if grid.grid_side_reference {
                self.others[k] += c * (v * i + grid.running_extra(i));
            } else {
                self.others[k] += c * (v * i);
            }
            return;
        }
        let power = c * g.unit.power(p, op, thermal);
        self.power[k] += power;
        self.h2_flow[k] += c * (p.h2_coefficient * i);
        self.current[k] += c * i;
        self.counts[g.unit.state.code() as usize] += g.count;
        if grid.grid_side_reference && g.unit.state == Curve {
            self.others[k] += power + c * grid.auxiliary_power;
        } else {
            self.others[k] += power;
        }
        if matches!(g.unit.state, Curve | Standby | Blowdown) {
            self.next_event = self.next_event.min(g.unit.timer);
        }
    }

    /// `count` Steady modules (lane k) at current `i` [A], power (V0 + R·I)·I [W], hydrogen
    /// c·I [Nl/h] and voltage V0 + R·I [V] each.
    #[inline(always)]
    fn observe_steady(
        &mut self,
        k: usize,
        count: u32,
        i: f64,
        power: f64,
        h2_flow: f64,
        voltage: f64,
    ) {
        let c = count as f64;
        self.power[k] += c * power;
        self.h2_flow[k] += c * h2_flow;
        self.current[k] += c * i;
        self.current_squared[k] += c * (i * i);
        self.voltage[k] += c * voltage;
        self.steady += count as u64;
        self.counts[OperatingState::Steady.code() as usize] += count;
    }

    /// Lane k's step of a dispatched Steady group of `count` modules whose current tracked
    /// over a piece of `piece` seconds: its sums and its outputs after it.
    #[inline(always)]
    pub fn tracked(&mut self, k: usize, count: u32, o: &Outcomes, piece: f64) {
        let c = count as f64;
        self.energy[k] += c * o.energy[k];
        self.h2_produced[k] += c * o.hydrogen[k];
        self.running[k] += c * piece;
        self.charge[k] += c * o.charge[k];
        self.current_squared_time[k] += c * o.current_squared[k];
        self.carrying += count;
        self.observe_steady(
            k,
            count,
            o.current[k],
            o.power[k],
            o.h2_flow[k],
            o.voltage[k],
        );
    }

    /// [`Self::tracked`] for a whole block of four groups of `counts` modules (the same
    /// arithmetic, lane by lane, as vector instructions).
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // lane k of every field: one vector instruction each
    pub fn tracked_block(&mut self, counts: [u32; LANES], o: &Outcomes, piece: f64) {
        let c: Lane = counts.map(f64::from);
        for k in 0..LANES {
            self.energy[k] += c[k] * o.energy[k];
            self.h2_produced[k] += c[k] * o.hydrogen[k];
            self.running[k] += c[k] * piece;
            self.charge[k] += c[k] * o.charge[k];
            self.current_squared_time[k] += c[k] * o.current_squared[k];
            self.power[k] += c[k] * o.power[k];
            self.h2_flow[k] += c[k] * o.h2_flow[k];
            self.current[k] += c[k] * o.current[k];
            self.current_squared[k] += c[k] * (o.current[k] * o.current[k]);
            self.voltage[k] += c[k] * o.voltage[k];
        }
        let n: u32 = counts.iter().sum();
        self.carrying += n;
        self.steady += n as u64;
        self.counts[OperatingState::Steady.code() as usize] += n;
    }

    /// The chunk's sums, lanes folded in order.
    pub fn fold(&self) -> Part {
        let fold = |l: &Lane| l.iter().skip(1).fold(l[0], |s, x| s + x);
        Part {
            energy: fold(&self.energy),
            h2_produced: fold(&self.h2_produced),
            running: fold(&self.running),
            charge: fold(&self.charge),
            current_squared: fold(&self.current_squared_time),
            starting: fold(&self.starting),
            starts: self.starts,
            warm_starts: self.warm_starts,
            carrying: self.carrying,
            others: fold(&self.others),
            next_event: self.next_event,
            failure: self.failure,
            reading: ReadingSums {
                power: fold(&self.power),
                h2_flow: fold(&self.h2_flow),
                current: fold(&self.current),
                current_squared: fold(&self.current_squared),
                voltage: fold(&self.voltage),
                temperature: fold(&self.temperature),
                cooling: fold(&self.cooling),
                steady: self.steady,
                counts: self.counts,
            },
        }
    }
}

/// What a chunk of groups did over a piece of a step, and what it looks like after it.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Part {
    pub energy: f64,
    pub h2_produced: f64,
    pub running: f64,
    pub charge: f64,
    pub current_squared: f64,
    pub starting: f64,
    pub starts: u64,
    pub warm_starts: u64,
    pub carrying: u32,
    pub others: f64,
    pub next_event: f64,
    pub failure: Option<ThermalError>,
    pub reading: ReadingSums,
}

/// What a survey of the groups finds: the modules carrying current (dispatched and Steady),
/// the power of the others [W], and the time until the next end of a start, a standby or a
/// stop [s].
#[derive(Clone, Copy, Debug)]
pub(super) struct Survey {
    pub carrying: u32,
    pub others: f64,
    pub next_event: Option<f64>,
    /// The first failure of the stack temperature's step (after a piece).
    pub failure: Option<ThermalError>,
}

impl Survey {
    pub fn new() -> Self {
        Survey {
            carrying: 0,
            others: 0.0,
            next_event: None,
            failure: None,
        }
    }

    /// Adds a chunk's part (chunks in order).
    pub fn add(&mut self, t: &Part) {
        self.carrying += t.carrying;
        self.others += t.others;
        self.failure = self.failure.or(t.failure);
        if t.next_event.is_finite() {
            self.next_event = Some(
                self.next_event
                    .map_or(t.next_event, |e| e.min(t.next_event)),
            );
        }
    }
}

/// Sums behind [`HubReadings`], chunks added in order.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct ReadingSums {
    power: f64,
    h2_flow: f64,
    current: f64,
    current_squared: f64,
    voltage: f64,
    /// Stack temperatures [K] and cooling powers [W] summed (0 without the thermal model).
    temperature: f64,
    cooling: f64,
    steady: u64,
    counts: [u32; 5],
}

impl ReadingSums {
    pub fn add(&mut self, part: &ReadingSums) {
        self.power += part.power;
        self.h2_flow += part.h2_flow;
        self.current += part.current;
        self.current_squared += part.current_squared;
        self.voltage += part.voltage;
        self.temperature += part.temperature;
        self.cooling += part.cooling;
        self.steady += part.steady;
        for (a, b) in self.counts.iter_mut().zip(part.counts) {
            *a += b;
        }
    }

    pub fn readings(&self) -> HubReadings {
        HubReadings {
            power: self.power,
            h2_flow: self.h2_flow,
            current: self.current,
            current_squared: self.current_squared,
            voltage: if self.steady > 0 {
                self.voltage / self.steady as f64
            } else {
                0.0
            },
            // Temperatures are summed only with the thermal model (all > 0 K then).
            temperature: if self.temperature > 0.0 {
                self.temperature / self.counts.iter().map(|&c| c as f64).sum::<f64>()
            } else {
                super::super::operation::CURVE_TEMPERATURE
            },
            cooling_power: self.cooling,
            counts: self.counts,
            voltage_drift: 0.0,
            max_voltage_drift: 0.0,
        }
    }
}
