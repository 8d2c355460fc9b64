//! A hub of N modules, simulated as groups.
//!
//! Modules with the same parameter set, the same dispatch role (running or stopped) and the
//! same state (operating state, timer, current dynamics, and for `Rotation` the same running
//! hours and starts) behave identically, so they form ONE [`Group`] with a count. An `Equal`
//! hub of identical modules is one group; a `Sequential` hub a few (modules started at
//! different times merge again once their states are bit-identical). Per-module parameter
//! sets give groups of one: a plain `Vec` of small structs, stepped in place with no
//! allocation per step.
//!
//! Hub totals: P_hub = Σ count·P_module [W], F_hub = Σ count·c·I [Nl/h],
//! E_hub = Σ count·E_module [J], N_hub = Σ count·c·∫I dt / 3600 [Nl].

use std::cmp::Ordering;

use super::dispatch::{running_count, within_window, Demand, DispatchPolicy, Limits, PowerCurve};
use super::dynamics::{CurrentDynamics, StepFactors};
use super::grid::GridParameters;
use super::lanes::{LaneBank, Share, LANES};
use super::module::StepError;
use super::operation::{BelowMinimum, Command, OperatingState, OperationParameters, UnitState};
use super::parameters::{ParameterError, Parameters};
use super::snapshot_error::SnapshotError;
use super::thermal::{HeatBalance, ThermalParameters};
use stepper::{ChunkVisitor, Stepper};
use tally::{Part, ReadingSums, Survey, Tally};

mod stepper;
mod tally;

const SECONDS_PER_HOUR: f64 = 3600.0;
/// Hydrogen density at normal conditions (0 °C, 1 atm) [kg/Nl]: 2.01588 g/mol / 22.413969 l/mol.
pub const H2_KG_PER_NL: f64 = 2.01588e-3 / 22.413969;

/// Hub-level configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HubConfig {
    /// Number of modules N ≥ 1.
    pub n_modules: u32,
    /// Dispatch policy.
    pub policy: DispatchPolicy,
    /// `Target` dispatch: the setpoint a running module should be nearest to [%], within
    /// [minSetpoint, maxSetpoint] (in power mode: that setpoint's power).
    pub dispatch_target: f64,
    /// Hysteresis band [% of one module's nominal setpoint range]: in setpoint mode in %,
    /// in power mode as that fraction of one module's power at maxSetpoint.
    pub hysteresis: f64,
    /// Start-up, standby and shut-down.
    pub operation: OperationParameters,
    /// Reserve compensation: every module's setpoint is pre-filtered so that the slow pole
    /// is cancelled ([`CurrentDynamics::with_compensation`]).
    pub compensation: bool,
    /// The reserve control's zero τn [s]: every module's setpoint is pre-filtered so that
    /// its transfer function's zero moves there ([`CurrentDynamics::with_filter_zero`]); 0: none.
    pub filter_zero: f64,
    /// The stack temperature, if modelled: every module's thermal parameters.
    pub thermal: Option<ThermalParameters>,
    /// Modules held in warm standby at t = 0, of those the dispatch does not run (the rest
    /// are idle, cold): each draws standbyPower and starts in warmStartTime until
    /// standbyDuration has passed; at most nModules.
    pub initial_standby: u32,
}

impl Default for HubConfig {
    fn default() -> Self {
        HubConfig {
            n_modules: 1,
            policy: DispatchPolicy::Equal,
            dispatch_target: 80.0,
            hysteresis: 5.0,
            operation: OperationParameters::default(),
            compensation: false,
            filter_zero: 0.0,
            thermal: None,
            initial_standby: 0,
        }
    }
}

/// One parameter set with its derived constants and the number of modules that have it.
#[derive(Clone, Debug)]
struct ModuleType {
    params: Parameters,
    count: u32,
    dynamics: CurrentDynamics,
    factors: StepFactors,
    /// c / 3600 [Nl/(A·s)].
    h2_per_coulomb: f64,
    /// The stack's heat balance with this set's polarisation curve, if modelled.
    thermal: Option<HeatBalance>,
    /// A running module's steady power at a setpoint, as a power reference means it.
    curve: PowerCurve,
}

/// `count` modules that behave identically.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Group {
    /// Number of modules in the group (≥ 1).
    pub count: u32,
    /// Index of the parameter set.
    pub kind: u32,
    /// Dispatched to run (true) or stopped.
    pub active: bool,
    /// The modules' state.
    pub unit: UnitState,
    /// Running seconds per module (tracked for `Rotation` only) [s].
    pub running: f64,
    /// Starts per module (tracked for `Rotation` only).
    pub starts: u64,
}

/// Hub totals since the start.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HubTotals {
    /// Model time [s].
    pub time: f64,
    /// Electric energy [J].
    pub energy: f64,
    /// Hydrogen [Nl].
    pub h2_produced: f64,
    /// Running time summed over modules [s].
    pub running: f64,
    /// Starts summed over modules.
    pub starts: u64,
    /// Of them, warm starts (warmStartTime).
    pub warm_starts: u64,
    /// Charge ∫ΣI dt [A·s] and ∫ΣI² dt [A²·s] summed over modules.
    pub charge: f64,
    pub current_squared: f64,
    /// Starting (Curve) time summed over modules [s].
    pub starting: f64,
}

impl HubTotals {
    /// Adds the energy, hydrogen, running time and starts of a chunk's part.
    fn add(&mut self, part: &Part) {
        self.energy += part.energy;
        self.h2_produced += part.h2_produced;
        self.running += part.running;
        self.charge += part.charge;
        self.current_squared += part.current_squared;
        self.starting += part.starting;
        self.starts = self.starts.saturating_add(part.starts);
        self.warm_starts = self.warm_starts.saturating_add(part.warm_starts);
    }
}

/// The hub: parameter sets, groups, dispatch memory and totals.
#[derive(Clone, Debug)]
pub struct Hub {
    config: HubConfig,
    types: Vec<ModuleType>,
    groups: Vec<Group>,
    /// Modules dispatched to run after the last step.
    running_target: u32,
    totals: HubTotals,
    /// Upper bound of the hub's power, on the grid side [W], for the overflow check.
    max_power: f64,
    /// The window's steady power range of the whole hub [W] ([`Hub::power_range`]).
    power_range: (f64, f64),
    /// Scratch for choosing modules (reused: no allocation once warm).
    order: Vec<u32>,
    /// With many parameter sets, their tracking-step constants in lanes (built for the step
    /// length in use; see [`super::lanes`]).
    lanes: Option<LaneBank>,
    /// Whether [`Self::lanes`] may be used (tests compare against the scalar path).
    lanes_enabled: bool,
    /// Group i holds parameter set i for every i (see [`Self::is_aligned`]).
    aligned: bool,
    /// What each chunk of groups did in a piece (scratch, reused).
    partials: Vec<Part>,
    /// The survey of the groups as they are, kept from the last piece (None: survey again).
    surveyed: Option<Survey>,
    /// The outputs of the groups as they are, kept from the last piece (None: sum again).
    read: Option<HubReadings>,
}

/// From this many parameter sets on, running modules are stepped in lanes.
const LANES_FROM: usize = 8;
/// Groups per chunk (a multiple of four lanes): each chunk sums its own totals.
const CHUNK: usize = 64;
/// From this many groups (aligned, in lanes) on, chunks are stepped on every core (rayon's
/// pool; RAYON_NUM_THREADS=1 keeps to the calling thread, with no hand-off). The sums do not
/// depend on it.
const PARALLEL_FROM: usize = 4096;

impl Hub {
    /// A hub of `config.n_modules` identical modules with parameters `params`, in the state
    /// the dispatch asks for at t = 0 under `demand`: running modules Steady in steady state,
    /// `config.initial_standby` of the others in warm standby, the rest Idle.
    pub fn new(
        params: Parameters,
        config: HubConfig,
        demand: Demand,
    ) -> Result<Self, ParameterError> {
        Self::build(vec![(params, config.n_modules)], config, demand)
    }

    /// A hub whose module k has parameter set `sets[k]` (one group per module).
    pub fn with_parameter_sets(
        sets: Vec<Parameters>,
        config: HubConfig,
        demand: Demand,
    ) -> Result<Self, ParameterError> {
        if sets.len() != config.n_modules as usize {
            return Err(ParameterError {
                name: "nModules",
                value: config.n_modules as f64,
                requirement: format!("must equal the number of parameter sets, {}", sets.len()),
            });
        }
        Self::build(sets.into_iter().map(|p| (p, 1)).collect(), config, demand)
    }

    /// A hub whose modules have the parameter sets `sets`, `(set, count)` each; the counts
    /// must add up to nModules.
    pub fn with_parameter_counts(
        sets: Vec<(Parameters, u32)>,
        config: HubConfig,
        demand: Demand,
    ) -> Result<Self, ParameterError> {
        let total: u64 = sets.iter().map(|(_, c)| *c as u64).sum();
        if total != config.n_modules as u64 || sets.iter().any(|(_, c)| *c == 0) {
            return Err(ParameterError {
                name: "nModules",
                value: config.n_modules as f64,
                requirement: format!(
                    "must equal the modules of the parameter sets, {total}, none empty"
                ),
            });
        }
        Self::build(sets, config, demand)
    }

    fn build(
        sets: Vec<(Parameters, u32)>,
        config: HubConfig,
        demand: Demand,
    ) -> Result<Self, ParameterError> {
        validate(&config)?;
        let mut types = Vec::with_capacity(sets.len());
        let mut max_power = 0.0;
        for (params, count) in sets {
            params.validate()?;
            let (lo, hi) = params.filter_zero_range();
            if config.filter_zero > 0.0 && !(lo..=hi).contains(&config.filter_zero) {
                return Err(ParameterError {
                    name: "reserveFilterZero",
                    value: config.filter_zero,
                    requirement: format!(
                        "must lie between the poles, within [{}, {}] s (tauPole1, tauPole2 of every module)",
                        super::shown(lo),
                        super::shown(hi)
                    ),
                });
            }
            if matches!(demand, Demand::Power(_))
                && params.voltage_intercept == 0.0
                && params.ohmic_resistance == 0.0
            {
                return Err(ParameterError {
                    name: "voltageIntercept",
                    value: 0.0,
                    requirement:
                        "and ohmicResistance = 0 draw no power: a power reference cannot be met"
                            .into(),
                });
            }
            let op = &config.operation;
            let curve = PowerCurve::new(&params, &op.grid);
            // The grid's power bounds the stack's (and the energies of both).
            let grid_side = PowerCurve::new(
                &params,
                &GridParameters {
                    grid_side_reference: true,
                    ..op.grid
                },
            );
            max_power += count as f64
                * grid_side
                    .power(params.max_setpoint)
                    .max(op.start_power + op.grid.auxiliary_power)
                    .max(op.standby_power);
            types.push(ModuleType {
                count,
                dynamics: if config.filter_zero > 0.0 {
                    CurrentDynamics::new(&params).with_filter_zero(config.filter_zero)
                } else {
                    CurrentDynamics::new(&params).with_compensation(config.compensation)
                },
                factors: StepFactors::default(),
                h2_per_coulomb: params.h2_coefficient / SECONDS_PER_HOUR,
                thermal: config.thermal.map(|thermal| HeatBalance {
                    thermal,
                    voltage_intercept: params.voltage_intercept,
                    ohmic_resistance: params.ohmic_resistance,
                    ambient: super::thermal::AMBIENT_START,
                    heater: 0.0,
                }),
                curve,
                params,
            });
        }
        let first = &types[0].params;
        if config.policy == DispatchPolicy::Target
            && !(first.min_setpoint..=first.max_setpoint).contains(&config.dispatch_target)
        {
            return Err(ParameterError {
                name: "dispatchTargetSetpoint",
                value: config.dispatch_target,
                requirement: format!(
                    "must lie within the window [{}, {}] % (minSetpoint, maxSetpoint) with dispatch = 4 (target)",
                    super::shown(first.min_setpoint),
                    super::shown(first.max_setpoint)
                ),
            });
        }
        if !demand.value().is_finite() {
            return Err(ParameterError {
                name: "setpoint",
                value: demand.value(),
                requirement: "must be a finite number".into(),
            });
        }
        let stays = config.operation.below_minimum == BelowMinimum::Minimum;
        let power_range = types.iter().fold((0.0, 0.0), |(lo, hi), ty| {
            let n = ty.count as f64;
            let min = if stays {
                n * ty.curve.power(ty.params.min_setpoint)
            } else {
                0.0
            };
            (lo + min, hi + n * ty.curve.power(ty.params.max_setpoint))
        });
        let mut hub = Hub {
            config,
            groups: Vec::with_capacity(types.len().max(4)),
            types,
            running_target: 0,
            totals: HubTotals::default(),
            max_power,
            power_range,
            order: Vec::new(),
            lanes: None,
            // The lanes step the plain dynamics only, without the stack temperature or a drift,
            // and share a power reference by the stack's curve.
            lanes_enabled: !config.compensation
                && config.filter_zero == 0.0
                && config.thermal.is_none()
                && !config.operation.grid.grid_side_reference
                && !config.operation.ageing.is_on(),
            aligned: false,
            partials: Vec::new(),
            surveyed: None,
            read: None,
        };
        let n = hub.target_count(demand, demand);
        hub.running_target = n;
        let start_temperature = config
            .thermal
            .map_or(super::operation::CURVE_TEMPERATURE, |t| {
                t.initial_temperature
            });
        let drift = config.operation.ageing.initial();
        let mut active_left = n;
        let mut standby_left = config.initial_standby;
        for kind in 0..hub.types.len() {
            let per_type_count = hub.types[kind].count;
            let on = active_left.min(per_type_count);
            active_left -= on;
            let u = hub.module_setpoint(kind, demand, n.max(1));
            let ty = &hub.types[kind];
            if on > 0 {
                let unit = UnitState::steady(&ty.params, &ty.dynamics, u)
                    .at_temperature(start_temperature)
                    .with_drift(drift);
                hub.groups.push(Group {
                    count: on,
                    kind: kind as u32,
                    active: true,
                    unit,
                    running: 0.0,
                    starts: 0,
                });
            }
            let warm = standby_left.min(per_type_count - on);
            standby_left -= warm;
            let off = per_type_count - on - warm;
            let standby = UnitState::standby(config.operation.standby_duration);
            for (count, unit) in [(warm, standby), (off, UnitState::idle())] {
                if count > 0 {
                    hub.groups.push(Group {
                        count,
                        kind: kind as u32,
                        active: false,
                        unit: unit.at_temperature(start_temperature).with_drift(drift),
                        running: 0.0,
                        starts: 0,
                    });
                }
            }
        }
        if let (Demand::Power(p), true) = (demand, config.initial_standby > 0) {
            // A power reference is what the running modules share after the warm modules'
            // standby power ([`Self::advance_groups`]): their steady state is at that share.
            let others = hub.survey().others;
            let carried = Demand::Power((p - others).max(0.0));
            for g in 0..hub.groups.len() {
                if hub.groups[g].active {
                    let kind = hub.groups[g].kind as usize;
                    let u = hub.module_setpoint(kind, carried, n.max(1));
                    let ty = &hub.types[kind];
                    hub.groups[g].unit = UnitState::steady(&ty.params, &ty.dynamics, u)
                        .at_temperature(start_temperature)
                        .with_drift(drift);
                }
            }
        }
        hub.aligned = hub.is_aligned();
        Ok(hub)
    }

    /// Module limits and band in module units for this demand, from parameter set 0.
    fn limits(&self, demand: Demand) -> Limits {
        let p = &self.types[0].params;
        match demand {
            Demand::Setpoint(_) => Limits {
                min: p.min_setpoint,
                max: p.max_setpoint,
                band: self.config.hysteresis,
                target: self.config.dispatch_target,
            },
            Demand::Power(_) => {
                let curve = &self.types[0].curve;
                let max = curve.power(p.max_setpoint);
                Limits {
                    min: curve.power(p.min_setpoint),
                    max,
                    band: self.config.hysteresis / 100.0 * max,
                    target: curve.power(self.config.dispatch_target),
                }
            }
        }
    }

    /// The running count for `demand`; `Target` dispatch counts for `base` (the demand
    /// without the reserves' request) and brings that count into the window of `demand`.
    fn target_count(&self, demand: Demand, base: Demand) -> u32 {
        let n = self.config.n_modules;
        let total = |d: Demand| match d {
            Demand::Setpoint(u) => u * n as f64,
            Demand::Power(p) => p,
        };
        let always_on = self.config.operation.below_minimum == BelowMinimum::Minimum;
        let limits = self.limits(demand);
        if self.config.policy == DispatchPolicy::Target {
            let counted = running_count(
                DispatchPolicy::Target,
                n,
                total(base),
                limits,
                self.running_target,
                always_on,
            );
            return within_window(n, total(demand), limits, counted);
        }
        running_count(
            self.config.policy,
            n,
            total(demand),
            limits,
            self.running_target,
            always_on,
        )
    }

    /// Setpoint [%] of a running module of parameter set `kind` when `running` modules share
    /// the demand equally (setpoint: u·N/n; power: the inverse polarisation curve at P/n).
    #[inline]
    fn module_setpoint(&self, kind: usize, demand: Demand, running: u32) -> f64 {
        match demand {
            Demand::Setpoint(u) if running == self.config.n_modules => u,
            Demand::Setpoint(u) => u * self.config.n_modules as f64 / running as f64,
            Demand::Power(p) => self.types[kind].curve.setpoint(p / running as f64),
        }
    }

    /// Advances the hub by `h` seconds with `demand` held over the step. Refused requests
    /// leave the hub unchanged.
    pub fn step(&mut self, demand: Demand, h: f64) -> Result<(), StepError> {
        self.step_with_base(demand, demand, h)
    }

    /// [`Hub::step`] where `demand` holds a reserve request on top of `base` (of the same
    /// kind): `Target` dispatch counts its running modules for the base.
    pub fn step_with_base(
        &mut self,
        demand: Demand,
        base: Demand,
        h: f64,
    ) -> Result<(), StepError> {
        let value = demand.value();
        if !value.is_finite() {
            return Err(StepError::NonFiniteSetpoint(value));
        }
        if !(h.is_finite() && h > 0.0) {
            return Err(StepError::InvalidStepSize(h));
        }
        let bound = self.totals.energy + h * self.max_power;
        if !(bound.is_finite()
            && (self.totals.time + h).is_finite()
            && (self.totals.running + h * self.config.n_modules as f64).is_finite())
        {
            return Err(StepError::Overflow(h));
        }
        let n = self.target_count(demand, base);
        // The stack temperature's integrator may refuse a step (in theory: its tolerances are
        // met at any step size the time allows); the hub is then put back as it was.
        let before = self
            .config
            .thermal
            .is_some()
            .then(|| (self.groups.clone(), self.running_target));
        let mut totals = self.totals;
        if self.rebalance(n) {
            self.settle(&mut totals);
            self.aligned = self.is_aligned();
            self.surveyed = None;
            self.read = None;
        }
        self.running_target = n;
        // The demand is shared by the dispatched modules that carry current, and a power
        // reference is what is left after the start-up and standby power of the others: the
        // hub draws the reference. Both change when a start completes or a standby or stop
        // ends; those instants are known in advance, so the step is cut there and the shares
        // recomputed: still exact, still independent of the communication step size.
        let mut left = h;
        while left > 0.0 {
            let survey = self.surveyed.take().unwrap_or_else(|| self.survey());
            let piece = survey.next_event.filter(|t| *t < left).unwrap_or(left);
            let after = self.advance_groups(demand, n, &survey, piece, piece == h, &mut totals);
            if let Some(failure) = after.failure {
                if let Some((groups, running_target)) = before {
                    self.groups = groups;
                    self.running_target = running_target;
                    self.aligned = self.is_aligned();
                    self.surveyed = None;
                    self.read = None;
                }
                return Err(StepError::Thermal(failure));
            }
            self.surveyed = Some(after);
            left -= piece;
        }
        totals.time += h;
        self.totals = totals;
        if self.groups.len() > self.types.len() && self.merge() {
            self.aligned = self.is_aligned();
            self.surveyed = None;
            self.read = None;
        }
        Ok(())
    }

    /// One pass over the groups: the modules carrying current (dispatched and Steady), the
    /// power of the others [W], and the time until the next end of a start, a standby or a
    /// stop [s] (the next instant at which either changes).
    fn survey(&self) -> Survey {
        self.summed().0
    }

    /// The survey and the outputs' sums of the groups as they are, summed by chunks as
    /// [`Self::advance_groups`] sums them after a piece, so that either gives the same bits.
    fn summed(&self) -> (Survey, ReadingSums) {
        let op = &self.config.operation;
        let (mut survey, mut reading) = (Survey::new(), ReadingSums::default());
        for gs in self.groups.chunks(CHUNK) {
            let mut t = Tally::default();
            for (j, g) in gs.iter().enumerate() {
                let ty = &self.types[g.kind as usize];
                t.observe(j % LANES, g, &ty.params, ty.thermal.as_ref(), op);
            }
            let part = t.fold();
            survey.add(&part);
            reading.add(&part.reading);
        }
        (survey, reading)
    }

    /// Group i holds the modules of parameter set i, for every i (always so with a parameter
    /// set per module): groups and sets can then be split alike.
    fn is_aligned(&self) -> bool {
        self.groups.len() == self.types.len()
            && self
                .groups
                .iter()
                .enumerate()
                .all(|(i, g)| g.kind as usize == i)
    }

    /// Applies the transitions a new dispatch causes at once (a start from Idle or Standby, a
    /// stop to Standby or Blowdown, an abandoned start), counting the starts.
    fn settle(&mut self, totals: &mut HubTotals) {
        let op = self.config.operation;
        for g in self.groups.iter_mut() {
            let ty = &mut self.types[g.kind as usize];
            let command = if g.active {
                Command::Run(ty.params.min_setpoint)
            } else {
                Command::Stop
            };
            let t = g.unit.advance(
                &ty.params,
                &ty.dynamics,
                &mut ty.factors,
                &op,
                ty.thermal.as_ref(),
                command,
                0.0,
            );
            // Counters saturate: a restored state may carry any count (found by fuzzing).
            totals.starts = totals
                .starts
                .saturating_add(g.count as u64 * t.starts as u64);
            totals.warm_starts = totals
                .warm_starts
                .saturating_add(g.count as u64 * t.warm_starts as u64);
            if self.config.policy == DispatchPolicy::Rotation {
                g.starts = g.starts.saturating_add(t.starts as u64);
            }
        }
    }

    /// Advances every group by `piece` seconds, the demand shared by the dispatched modules
    /// that carry current now (by all `n` dispatched while none does); a power reference less
    /// the power of the modules that carry none. `whole`: the piece is the whole step.
    ///
    /// Groups go in chunks of [`CHUNK`], each summing its own totals ([`tally`]), added in
    /// order: the same sums whichever path steps a group. Returns the survey of the groups after it.
    fn advance_groups(
        &mut self,
        demand: Demand,
        n: u32,
        survey: &Survey,
        piece: f64,
        whole: bool,
        totals: &mut HubTotals,
    ) -> Survey {
        let sharing = if survey.carrying > 0 {
            survey.carrying
        } else {
            n.max(1)
        };
        let demand = match demand {
            Demand::Power(p) => Demand::Power((p - survey.others).max(0.0)),
            setpoint => setpoint,
        };
        let share = match demand {
            Demand::Setpoint(_) => Share::Setpoint(self.module_setpoint(0, demand, sharing)),
            Demand::Power(p) => Share::Power(p / sharing as f64),
        };
        let common = match share {
            Share::Setpoint(u) => Some(u),
            Share::Power(_) if self.types.len() == 1 => {
                Some(self.module_setpoint(0, demand, sharing))
            }
            Share::Power(_) => None,
        };
        let rotation = self.config.policy == DispatchPolicy::Rotation;
        let step = Stepper {
            share,
            common,
            piece,
            rotation,
            op: self.config.operation,
        };
        let use_lanes =
            self.lanes_enabled && whole && self.aligned && self.types.len() >= LANES_FROM;
        if use_lanes && self.lanes.as_ref().is_none_or(|bank| bank.h() != piece) {
            self.lanes = Some(LaneBank::new(
                self.types.iter().map(|t| (&t.params, &t.dynamics)),
                piece,
            ));
        }
        let Hub {
            groups,
            types,
            lanes,
            partials,
            ..
        } = self;
        if let Some(bank) = lanes.as_ref().filter(|_| use_lanes) {
            // Aligned: chunk c of the groups is stepped with chunk c of the parameter sets.
            let chunk_step =
                |c: usize, gs: &mut [Group], ts: &mut [ModuleType], part: &mut Part| {
                    let mut tally = Tally::default();
                    bank.step(
                        c * CHUNK,
                        gs,
                        share,
                        &mut ChunkVisitor {
                            step: &step,
                            types: ts,
                            next: 0,
                            tally: &mut tally,
                        },
                    );
                    *part = tally.fold();
                };
            partials.resize(groups.len().div_ceil(CHUNK), Part::default());
            if groups.len() >= PARALLEL_FROM && rayon::current_num_threads() > 1 {
                use rayon::prelude::*;
                groups
                    .par_chunks_mut(CHUNK)
                    .zip(types.par_chunks_mut(CHUNK))
                    .zip(partials.par_iter_mut())
                    .with_min_len(16)
                    .enumerate()
                    .for_each(|(c, ((gs, ts), part))| chunk_step(c, gs, ts, part));
            } else {
                let chunks = groups
                    .chunks_mut(CHUNK)
                    .zip(types.chunks_mut(CHUNK))
                    .zip(partials.iter_mut());
                for (c, ((gs, ts), part)) in chunks.enumerate() {
                    chunk_step(c, gs, ts, part);
                }
            }
        } else {
            partials.clear();
            for gs in groups.chunks_mut(CHUNK) {
                let mut tally = Tally::default();
                for (j, g) in gs.iter_mut().enumerate() {
                    step.advance(&mut types[g.kind as usize], g, &mut tally, j % LANES);
                }
                partials.push(tally.fold());
            }
        }
        let (mut survey, mut reading) = (Survey::new(), ReadingSums::default());
        for part in partials.iter() {
            totals.add(part);
            survey.add(part);
            reading.add(&part.reading);
        }
        self.read = Some(reading.readings());
        survey
    }

    /// Switches modules on or off until `target` modules are dispatched to run, preferring
    /// (to start) warm Standby over Idle over Blowdown, (to stop) Steady over Curve (a running
    /// module stops to warm standby and the others take its share, while an abandoned start
    /// would be lost: a demand that dips faster than a cold start would otherwise never let
    /// a start complete); under
    /// `Rotation`, fewest running hours then starts first (to stop: most). Ties are broken by
    /// state contents, never by position, so the choice does not depend on grouping.
    fn rebalance(&mut self, target: u32) -> bool {
        // Every step leaves exactly `running_target` modules dispatched (restore checks it too).
        let active = self.running_target;
        if active == target {
            return false;
        }
        let starting = target > active;
        let mut need = if starting {
            target - active
        } else {
            active - target
        };
        let rotation = self.config.policy == DispatchPolicy::Rotation;
        let _ = in_preference(&self.groups, starting, rotation, &mut self.order);
        for k in 0..self.order.len() {
            if need == 0 {
                break;
            }
            let gi = self.order[k] as usize;
            let g = self.groups[gi];
            if g.count <= need {
                self.groups[gi].active = starting;
                need -= g.count;
            } else {
                self.groups[gi].count = g.count - need;
                self.groups.push(Group {
                    count: need,
                    active: starting,
                    ..g
                });
                need = 0;
            }
        }
        true
    }

    /// Merges groups of the same parameter set whose modules are in bit-identical states.
    /// The groups stay in identity order from step to step but for the few a step moved (a
    /// dispatch change, crossing currents): those are moved into place one by one, in about
    /// one pass; a sort only where many are out of place. Returns whether the groups changed
    /// (false: already in order and all distinct, the common case, found in one pass).
    fn merge(&mut self) -> bool {
        let (mut descents, mut equal) = (0, false);
        for w in self.groups.windows(2) {
            match identity_order(&w[0], &w[1]) {
                Ordering::Less => {}
                Ordering::Equal => equal = true,
                Ordering::Greater => descents += 1,
            }
        }
        if descents > FEW_OUT_OF_PLACE {
            self.groups.sort_unstable_by(identity_order);
        } else if descents > 0 {
            insert_out_of_place(&mut self.groups);
        } else if !equal {
            return false;
        }
        let mut w = 0;
        for r in 1..self.groups.len() {
            let g = self.groups[r];
            if same(&self.groups[w], &g) {
                self.groups[w].count += g.count;
            } else {
                w += 1;
                self.groups[w] = g;
            }
        }
        self.groups.truncate(w + 1);
        true
    }

    /// Parameter set `kind` (0: the first, which also sets the dispatch's limits).
    pub fn parameter_set(&self, kind: usize) -> &Parameters {
        &self.types[kind].params
    }

    /// The steady power of a running module of parameter set `kind` as a power reference
    /// means it (stack or grid side).
    pub fn power_curve(&self, kind: usize) -> &PowerCurve {
        &self.types[kind].curve
    }

    /// The steady power the operating window allows the whole hub [W] (stack or grid side, as
    /// a power reference means it): every module at maxSetpoint at most; at least every module
    /// at minSetpoint where modules never stop (belowMinimum = stay at minimum), else 0
    /// (start-up and standby power aside).
    pub fn power_range(&self) -> (f64, f64) {
        self.power_range
    }

    /// The configuration.
    pub fn config(&self) -> &HubConfig {
        &self.config
    }

    /// The groups (for inspection and saving).
    pub fn groups(&self) -> &[Group] {
        &self.groups
    }

    /// Totals since the start.
    pub fn totals(&self) -> &HubTotals {
        &self.totals
    }

    /// Model time [s].
    pub fn time(&self) -> f64 {
        self.totals.time
    }

    /// Electric power of the hub [W]: stack power of Steady modules plus start and standby power.
    pub fn power(&self) -> f64 {
        let op = &self.config.operation;
        self.groups
            .iter()
            .map(|g| {
                let ty = &self.types[g.kind as usize];
                g.count as f64 * g.unit.power(&ty.params, op, ty.thermal.as_ref())
            })
            .sum()
    }

    /// Sets the ambient temperature [K] of every module's heat balance (none without the
    /// thermal model); the caller checks it.
    pub fn set_ambient_temperature(&mut self, ambient: f64) {
        for ty in &mut self.types {
            if let Some(balance) = &mut ty.thermal {
                balance.ambient = ambient;
            }
        }
        // The standby heater's power (in the survey's `others`) depends on the ambient.
        self.surveyed = None;
        self.read = None;
    }

    /// Hydrogen flow of the hub, c·ΣI [Nl/h].
    pub fn h2_flow(&self) -> f64 {
        self.groups
            .iter()
            .map(|g| {
                g.count as f64
                    * self.types[g.kind as usize].params.h2_coefficient
                    * g.unit.stack_current()
            })
            .sum()
    }

    /// Hydrogen flow of the hub [kg/h] (normal density 0.0899 kg/Nm³).
    pub fn h2_mass_flow(&self) -> f64 {
        self.h2_flow() * H2_KG_PER_NL
    }

    /// Number of modules in `state`.
    pub fn count_in(&self, state: OperatingState) -> u32 {
        self.groups
            .iter()
            .filter(|g| g.unit.state == state)
            .map(|g| g.count)
            .sum()
    }

    /// The hub's dominant state: Steady if any module is Steady, else Curve, Standby,
    /// Blowdown, Idle in that order (for one module: its state).
    pub fn state(&self) -> OperatingState {
        use OperatingState::*;
        [Steady, Curve, Standby, Blowdown]
            .into_iter()
            .find(|&s| self.count_in(s) > 0)
            .unwrap_or(Idle)
    }

    /// Modules dispatched to run.
    pub fn running_target(&self) -> u32 {
        self.running_target
    }
}

/// The time-varying part of a hub: with its configuration and parameter sets it determines
/// the hub completely (for saving and restoring).
#[derive(Clone, Debug, PartialEq)]
pub struct HubSnapshot {
    /// The groups.
    pub groups: Vec<Group>,
    /// Modules dispatched to run after the last step.
    pub running_target: u32,
    /// Totals since the start.
    pub totals: HubTotals,
}

/// Every hub output at one instant, from one pass over the groups.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HubReadings {
    /// Electric power [W].
    pub power: f64,
    /// Hydrogen flow c·ΣI [Nl/h].
    pub h2_flow: f64,
    /// Sum of stack currents [A].
    pub current: f64,
    /// Sum of squared stack currents ΣI² [A²].
    pub current_squared: f64,
    /// Mean stack voltage V0 + R·I (+ drift) over Steady modules [V]; 0 when none is Steady.
    pub voltage: f64,
    /// Mean stack temperature over the modules [K] (the thermal model's; Tn without it).
    pub temperature: f64,
    /// Heat the modules' cooling removes, summed [W].
    pub cooling_power: f64,
    /// Modules in each operating state, indexed by [`OperatingState::code`].
    pub counts: [u32; 5],
    /// The voltage's drift, mean over the modules and the largest [V] (0 without ageing).
    pub voltage_drift: f64,
    pub max_voltage_drift: f64,
}

impl Hub {
    /// The time-varying state.
    pub fn snapshot(&self) -> HubSnapshot {
        HubSnapshot {
            groups: self.groups.clone(),
            running_target: self.running_target,
            totals: self.totals,
        }
    }

    /// Restores a snapshot taken from a hub of the same configuration and parameter sets.
    /// Refuses (changing nothing) a snapshot that cannot belong to this hub.
    pub fn restore(&mut self, snapshot: HubSnapshot) -> Result<(), SnapshotError> {
        let kinds = self.types.len();
        let mut per_kind = vec![0u64; kinds];
        for g in &snapshot.groups {
            let u = &g.unit;
            let c = &u.current;
            if g.count == 0 || g.kind as usize >= kinds {
                return Err(SnapshotError::BadGroup {
                    count: g.count,
                    kind: g.kind,
                    kinds,
                });
            }
            let d = &u.drift;
            if ![
                u.timer,
                c.current,
                c.z1,
                c.z2,
                g.running,
                u.temperature,
                d.irreversible,
                d.reversible,
            ]
            .iter()
            .all(|x| x.is_finite())
                || u.timer < 0.0
                || g.running < 0.0
                || u.temperature <= 0.0
                || d.irreversible < 0.0
                || d.reversible < 0.0
            {
                return Err(SnapshotError::NonFiniteGroup);
            }
            per_kind[g.kind as usize] += g.count as u64;
        }
        if per_kind
            .iter()
            .zip(&self.types)
            .any(|(&n, ty)| n != ty.count as u64)
        {
            return Err(SnapshotError::ModuleCount {
                n_modules: self.config.n_modules,
            });
        }
        let t = &snapshot.totals;
        if ![t.time, t.energy, t.h2_produced, t.running]
            .iter()
            .all(|x| x.is_finite())
            || snapshot.running_target > self.config.n_modules
        {
            return Err(SnapshotError::TotalsOutOfRange);
        }
        let active: u64 = snapshot
            .groups
            .iter()
            .filter(|g| g.active)
            .map(|g| g.count as u64)
            .sum();
        if active != snapshot.running_target as u64 {
            return Err(SnapshotError::DispatchMismatch {
                active,
                target: snapshot.running_target,
            });
        }
        self.groups = snapshot.groups;
        self.running_target = snapshot.running_target;
        self.totals = snapshot.totals;
        self.aligned = self.is_aligned();
        self.surveyed = None;
        self.read = None;
        Ok(())
    }

    /// All outputs in one pass over the groups.
    pub fn readings(&self) -> HubReadings {
        let mut readings = self.read.unwrap_or_else(|| self.summed().1.readings());
        if self.config.operation.ageing.is_on() {
            let (sum, max) = self
                .groups
                .iter()
                .fold((0.0, 0.0), |(sum, max): (f64, f64), g| {
                    let d = g.unit.drift.total();
                    (sum + g.count as f64 * d, max.max(d))
                });
            readings.voltage_drift = sum / self.config.n_modules as f64;
            readings.max_voltage_drift = max;
        }
        readings
    }
}

/// Refuses configurations that cannot work; the message names the value.
pub fn validate(config: &HubConfig) -> Result<(), ParameterError> {
    config.operation.validate()?;
    if config.n_modules == 0 {
        return Err(ParameterError {
            name: "nModules",
            value: 0.0,
            requirement: "must be >= 1".into(),
        });
    }
    if !(config.hysteresis.is_finite() && config.hysteresis >= 0.0) {
        return Err(ParameterError {
            name: "hysteresis",
            value: config.hysteresis,
            requirement: "must be a finite number >= 0".into(),
        });
    }
    if config.initial_standby > config.n_modules {
        return Err(ParameterError {
            name: "initialStandby",
            value: config.initial_standby as f64,
            requirement: format!("must not exceed nModules = {}", config.n_modules),
        });
    }
    if config.policy != DispatchPolicy::Equal
        && config.operation.below_minimum == BelowMinimum::Minimum
    {
        return Err(ParameterError {
            name: "belowMinimum",
            value: 0.0,
            requirement: format!(
                "must be 1 (standby) or 2 (off) with dispatch = {} ({:?}): that policy switches modules off",
                config.policy as i32, config.policy
            ),
        });
    }
    Ok(())
}

fn state_rank(s: OperatingState, starting: bool) -> u8 {
    use OperatingState::*;
    match (starting, s) {
        (true, Standby) => 0,
        (true, Idle) => 1,
        (true, _) => 2,
        (false, Steady) => 0,
        (false, _) => 1,
    }
}

/// Fills `order` with the indices of the groups that can switch (on if `starting`, else off),
/// in the order of [`preference`]. The groups are kept in identity order ([`Hub::merge`]):
/// without `rotation` the candidates of each state rank in turn, each rank in the groups'
/// order, are then in that order already, found in three passes; checked, and sorted if not
/// (returns whether it sorted).
fn in_preference(groups: &[Group], starting: bool, rotation: bool, order: &mut Vec<u32>) -> bool {
    let candidates = (0..groups.len() as u32).filter(|&i| groups[i as usize].active != starting);
    order.clear();
    if rotation {
        order.extend(candidates.clone());
    } else {
        for rank in 0..=2 {
            order.extend(
                candidates
                    .clone()
                    .filter(|&i| state_rank(groups[i as usize].unit.state, starting) == rank),
            );
        }
    }
    let prefer = |&a: &u32, &b: &u32| {
        preference(&groups[a as usize], &groups[b as usize], starting, rotation)
    };
    let in_order = order
        .windows(2)
        .all(|w| prefer(&w[0], &w[1]) == Ordering::Less);
    if !in_order {
        // From the groups' own order, as always before: with groups of equal contents (a
        // restored state may hold some) the sort then splits the same one.
        order.clear();
        order.extend(candidates);
        order.sort_unstable_by(prefer);
    }
    !in_order
}

/// Order of preference when switching modules on (`starting`) or off.
fn preference(a: &Group, b: &Group, starting: bool, rotation: bool) -> Ordering {
    let mut o = Ordering::Equal;
    if rotation {
        o = a
            .running
            .total_cmp(&b.running)
            .then(a.starts.cmp(&b.starts));
        if !starting {
            o = o.reverse();
        }
    }
    o.then(state_rank(a.unit.state, starting).cmp(&state_rank(b.unit.state, starting)))
        .then_with(|| identity_order(a, b))
}

/// A total order on group contents (not counts), used for ties and merging.
fn identity_order(a: &Group, b: &Group) -> Ordering {
    a.kind
        .cmp(&b.kind)
        .then(a.active.cmp(&b.active))
        .then(a.unit.state.cmp(&b.unit.state))
        .then(a.unit.timer.total_cmp(&b.unit.timer))
        .then(a.unit.current.current.total_cmp(&b.unit.current.current))
        .then(a.unit.current.z1.total_cmp(&b.unit.current.z1))
        .then(a.unit.current.z2.total_cmp(&b.unit.current.z2))
        .then(a.unit.temperature.total_cmp(&b.unit.temperature))
        .then(
            a.unit
                .drift
                .irreversible
                .total_cmp(&b.unit.drift.irreversible),
        )
        .then(a.unit.drift.reversible.total_cmp(&b.unit.drift.reversible))
        .then(a.running.total_cmp(&b.running))
        .then(a.starts.cmp(&b.starts))
}

/// Groups out of identity order after a step, up to which [`Hub::merge`] moves each into
/// place rather than sorting them all.
const FEW_OUT_OF_PLACE: usize = 16;

/// Sorts groups that are in identity order but for a few: each one out of place moves into
/// the ordered part before it (a binary search, one rotation). No allocation; about one pass
/// when few are out of place. Where the groups moved add up to more than a few passes (long
/// runs interleaved), the rest is sorted instead: the same order either way.
fn insert_out_of_place(groups: &mut [Group]) {
    let mut budget = 4 * groups.len();
    for i in 1..groups.len() {
        if identity_order(&groups[i - 1], &groups[i]) == Ordering::Greater {
            let at =
                groups[..i].partition_point(|g| identity_order(g, &groups[i]) != Ordering::Greater);
            if i - at > budget {
                groups.sort_unstable_by(identity_order);
                return;
            }
            budget -= i - at;
            groups[at..=i].rotate_right(1);
        }
    }
}

fn same(a: &Group, b: &Group) -> bool {
    identity_order(a, b) == Ordering::Equal
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod order_tests;

#[cfg(test)]
mod thermal_tests;
