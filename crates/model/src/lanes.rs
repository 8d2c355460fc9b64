//! Modules with parameter sets of their own, stepped four at a time.
//!
//! A hub whose modules each have their own parameters (nModules groups of one) spends its time
//! in one place: every running module takes a [`TrackingStep`] every communication step, then
//! its energy V0·∫I + R·∫I² [J] and hydrogen c/3600·∫I [Nl]. [`LaneBank`] keeps those constants
//! for four parameter sets side by side (field-major blocks of four lanes, read as one stream),
//! and the setpoint of a power share P [W] from the inverse polarisation curve,
//! u = 2P / (K·(V0 + √(V0² + 4RP))) [%], clamped to [minSetpoint, maxSetpoint].
//!
//! The compiler turns the four lanes into vector instructions; on x86-64 the loop is compiled a
//! second time for AVX2 and that copy is chosen at run time when the CPU has it. Each lane runs
//! exactly the scalar arithmetic of [`TrackingStep::step`] and
//! [`super::dispatch::setpoint_for_power`] (Rust never fuses a·b + c into one rounding), so
//! results are bit-identical to the scalar path on every CPU.

use super::dispatch::setpoint_at_power;
use super::dynamics::{CurrentDynamics, CurrentState, TrackedStep, TrackingStep};
use super::parameters::Parameters;
use super::select::clamped;

/// Modules per block.
pub const LANES: usize = 4;
/// One value per module of a block.
pub type Lane = [f64; LANES];
/// Blocks whose setpoints are computed together (64 modules).
const BATCH: usize = 16;

/// What each running module is asked for this step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Share {
    /// The same setpoint [%] for every module.
    Setpoint(f64),
    /// The same electric power [W] for every module, turned into each module's setpoint.
    Power(f64),
}

/// The results for the modules of one block, lane k for module k (field-major, as computed).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Outcomes {
    /// The state at the end of the step: z1, z2 [A] and I [A].
    pub z1: Lane,
    pub z2: Lane,
    pub current: Lane,
    /// ∫I dt [A·s], ∫I² dt [A²·s].
    pub charge: Lane,
    pub current_squared: Lane,
    /// The step was in the common case (use the other fields only where it holds).
    pub tracks: [bool; LANES],
    /// V0·∫I dt + R·∫I² dt [J].
    pub energy: Lane,
    /// c/3600·∫I dt [Nl].
    pub hydrogen: Lane,
    /// At the end: power (V0 + R·I)·I [W], hydrogen flow c·I [Nl/h], voltage V0 + R·I [V].
    pub power: Lane,
    pub h2_flow: Lane,
    pub voltage: Lane,
}

impl Outcomes {
    /// The tracking step of lane k.
    pub fn step(&self, k: usize) -> TrackedStep {
        TrackedStep {
            state: CurrentState {
                z1: self.z1[k],
                z2: self.z2[k],
                current: self.current[k],
            },
            charge: self.charge[k],
            current_squared: self.current_squared[k],
            tracks: self.tracks[k],
        }
    }
}

/// What the caller does with the modules: where their state is, and what to do with the
/// outcomes of each block. Implementations should mark both `#[inline(always)]`: they run
/// inside the vector loop.
pub trait Visit<T> {
    /// The module's current state.
    fn state(item: &T) -> CurrentState;
    /// Takes the outcomes of one block, lane k for `items[k]` (one to four items; blocks in
    /// order).
    fn visit(&mut self, items: &mut [T], outcomes: &Outcomes);
}

/// Constants of four parameter sets at one step length, lane k of block j being set 4j + k.
#[derive(Clone, Copy, Debug, Default)]
struct LaneBlock {
    gain: Lane,
    a: Lane,
    b: Lane,
    e1: Lane,
    e2: Lane,
    w1: Lane,
    w2: Lane,
    q11: Lane,
    q22: Lane,
    q12: Lane,
    rise1: Lane,
    rise2: Lane,
    ramp: Lane,
    /// V0 [V], R [Ω].
    v0: Lane,
    r: Lane,
    /// minSetpoint, maxSetpoint [%].
    min: Lane,
    max: Lane,
    /// c/3600 [Nl/(A·s)], c [Nl/(h·A)].
    h2_per_coulomb: Lane,
    h2_coefficient: Lane,
}

/// The tracking-step constants of many parameter sets at one step length h, in lanes.
#[derive(Clone, Debug)]
pub struct LaneBank {
    h: f64,
    sets: usize,
    blocks: Vec<LaneBlock>,
}

impl LaneBank {
    /// The constants of `sets` (parameters with their dynamics) for steps of `h` seconds.
    pub fn new<'a>(
        sets: impl ExactSizeIterator<Item = (&'a Parameters, &'a CurrentDynamics)>,
        h: f64,
    ) -> Self {
        let n = sets.len();
        let mut blocks = vec![LaneBlock::default(); n.div_ceil(LANES)];
        for (i, (p, d)) in sets.enumerate() {
            let (blk, k) = (&mut blocks[i / LANES], i % LANES);
            let t = d.tracking_step(h);
            for (lane, value) in [
                (&mut blk.gain, t.gain),
                (&mut blk.a, t.a),
                (&mut blk.b, t.b),
                (&mut blk.e1, t.e1),
                (&mut blk.e2, t.e2),
                (&mut blk.w1, t.w1),
                (&mut blk.w2, t.w2),
                (&mut blk.q11, t.q11),
                (&mut blk.q22, t.q22),
                (&mut blk.q12, t.q12),
                (&mut blk.rise1, t.rise1),
                (&mut blk.rise2, t.rise2),
                (&mut blk.ramp, t.ramp),
                (&mut blk.v0, p.voltage_intercept),
                (&mut blk.r, p.ohmic_resistance),
                (&mut blk.min, p.min_setpoint),
                (&mut blk.max, p.max_setpoint),
                (&mut blk.h2_per_coulomb, p.h2_coefficient / 3600.0),
                (&mut blk.h2_coefficient, p.h2_coefficient),
            ] {
                lane[k] = value;
            }
        }
        LaneBank { h, sets: n, blocks }
    }

    /// The step length the constants are for [s].
    pub fn h(&self) -> f64 {
        self.h
    }

    /// Number of parameter sets.
    pub fn sets(&self) -> usize {
        self.sets
    }

    /// The tracking steps of `items`, item k being a module of parameter set `first + k`
    /// (`first` a multiple of four, `first + items.len()` at most [`Self::sets`]) at the state
    /// `V::state(item)`, under `share`, handed to `visitor.visit` four at a time, in order.
    pub fn step<T, V: Visit<T>>(
        &self,
        first: usize,
        items: &mut [T],
        share: Share,
        visitor: &mut V,
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (checked just above), the only requirement of `step_avx2`.
            unsafe { self.step_avx2(first, items, share, visitor) };
            return;
        }
        self.step_portable(first, items, share, visitor);
    }

    /// [`Self::step`] compiled for AVX2 (the visitor inlined into it).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn step_avx2<T, V: Visit<T>>(
        &self,
        first: usize,
        items: &mut [T],
        share: Share,
        visitor: &mut V,
    ) {
        self.step_lanes(first, items, share, visitor);
    }

    /// [`Self::step`] for any CPU of the target.
    pub fn step_portable<T, V: Visit<T>>(
        &self,
        first: usize,
        items: &mut [T],
        share: Share,
        visitor: &mut V,
    ) {
        self.step_lanes(first, items, share, visitor);
    }

    #[inline(always)]
    fn step_lanes<T, V: Visit<T>>(
        &self,
        first: usize,
        items: &mut [T],
        share: Share,
        visitor: &mut V,
    ) {
        assert!(
            first.is_multiple_of(LANES) && first + items.len() <= self.sets,
            "lanes out of range"
        );
        let blocks = &self.blocks[first / LANES..];
        // Setpoints first, a batch of blocks at a time: the square roots and divisions of
        // neighbouring blocks then overlap instead of each waiting for the last.
        for (batch, items) in blocks.chunks(BATCH).zip(items.chunks_mut(BATCH * LANES)) {
            let mut setpoints = [[0.0; LANES]; BATCH];
            for (blk, u) in batch.iter().zip(setpoints.iter_mut()) {
                *u = Self::setpoints(blk, share);
            }
            for ((blk, u), items) in batch.iter().zip(&setpoints).zip(items.chunks_mut(LANES)) {
                let (mut z1, mut z2, mut current) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
                for (k, item) in items.iter().enumerate() {
                    let s = V::state(item);
                    (z1[k], z2[k], current[k]) = (s.z1, s.z2, s.current);
                }
                visitor.visit(items, &self.block(blk, u, [z1, z2, current]));
            }
        }
    }

    /// The four modules' setpoints [%] under `share`, clamped to [minSetpoint, maxSetpoint].
    #[inline(always)]
    fn setpoints(blk: &LaneBlock, share: Share) -> Lane {
        match share {
            Share::Setpoint(fixed) => {
                std::array::from_fn(|k| clamped(fixed, blk.min[k], blk.max[k]))
            }
            Share::Power(p) => std::array::from_fn(|k| {
                clamped(
                    setpoint_at_power(blk.v0[k], blk.r[k], blk.gain[k], p),
                    blk.min[k],
                    blk.max[k],
                )
            }),
        }
    }

    /// Four modules' steps from their states [z1, z2, I], field-major in and out, so that the
    /// four lanes become vector instructions.
    #[inline(always)]
    fn block(&self, blk: &LaneBlock, setpoints: &Lane, [z1, z2, current]: [Lane; 3]) -> Outcomes {
        let mut next = [[0.0; LANES]; 3];
        let (mut charge, mut squared, mut energy, mut hydrogen) =
            ([0.0; LANES], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
        let mut tracks = [false; LANES];
        let (mut power_end, mut flow_end, mut voltage_end) =
            ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        for k in 0..LANES {
            let t = TrackingStep {
                gain: blk.gain[k],
                a: blk.a[k],
                b: blk.b[k],
                e1: blk.e1[k],
                e2: blk.e2[k],
                w1: blk.w1[k],
                w2: blk.w2[k],
                q11: blk.q11[k],
                q22: blk.q22[k],
                q12: blk.q12[k],
                rise1: blk.rise1[k],
                rise2: blk.rise2[k],
                ramp: blk.ramp[k],
                h: self.h,
            };
            let state = CurrentState {
                z1: z1[k],
                z2: z2[k],
                current: current[k],
            };
            let step = t.step(&state, setpoints[k]);
            next[0][k] = step.state.z1;
            next[1][k] = step.state.z2;
            next[2][k] = step.state.current;
            charge[k] = step.charge;
            squared[k] = step.current_squared;
            tracks[k] = step.tracks;
            energy[k] = blk.v0[k] * step.charge + blk.r[k] * step.current_squared;
            hydrogen[k] = blk.h2_per_coulomb[k] * step.charge;
            let i = step.state.current;
            voltage_end[k] = blk.v0[k] + blk.r[k] * i;
            power_end[k] = voltage_end[k] * i;
            flow_end[k] = blk.h2_coefficient[k] * i;
        }
        Outcomes {
            z1: next[0],
            z2: next[1],
            current: next[2],
            charge,
            current_squared: squared,
            tracks,
            energy,
            hydrogen,
            power: power_end,
            h2_flow: flow_end,
            voltage: voltage_end,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dispatch::setpoint_for_power;
    use crate::spread::spread_parameters;

    /// 71 parameter sets (more than a batch, not a multiple of four) at states that track,
    /// ramp and fall.
    fn rig() -> (Vec<Parameters>, Vec<CurrentDynamics>, Vec<CurrentState>) {
        let sets = spread_parameters(&Parameters::default(), 71, 0.05, 3);
        let dynamics: Vec<_> = sets.iter().map(CurrentDynamics::new).collect();
        let states = dynamics
            .iter()
            .enumerate()
            .map(|(i, d)| {
                let s = d.steady_state(60.0 + 4.0 * (i % 11) as f64);
                CurrentState {
                    z1: s.z1 * (1.0 + 0.01 * (i % 11) as f64),
                    ..s
                }
            })
            .collect();
        (sets, dynamics, states)
    }

    /// One module's outcome.
    #[derive(Clone, Copy, Debug, PartialEq)]
    struct One {
        step: TrackedStep,
        energy: f64,
        hydrogen: f64,
        power: f64,
        h2_flow: f64,
        voltage: f64,
    }

    /// Collects the outcomes, checking that blocks come whole but for the last.
    struct Collect(Vec<One>);

    impl Visit<CurrentState> for Collect {
        fn state(item: &CurrentState) -> CurrentState {
            *item
        }
        fn visit(&mut self, items: &mut [CurrentState], o: &Outcomes) {
            assert!(self.0.len().is_multiple_of(LANES) && (1..=LANES).contains(&items.len()));
            for k in 0..items.len() {
                let (energy, hydrogen, power, h2_flow, voltage) = (
                    o.energy[k],
                    o.hydrogen[k],
                    o.power[k],
                    o.h2_flow[k],
                    o.voltage[k],
                );
                self.0.push(One {
                    step: o.step(k),
                    energy,
                    hydrogen,
                    power,
                    h2_flow,
                    voltage,
                });
            }
        }
    }

    fn outcomes(
        bank: &LaneBank,
        first: usize,
        states: &[CurrentState],
        share: Share,
        portable: bool,
    ) -> Vec<One> {
        let mut out = Collect(Vec::new());
        let mut items = states.to_vec();
        if portable {
            bank.step_portable(first, &mut items, share, &mut out);
        } else {
            bank.step(first, &mut items, share, &mut out);
        }
        assert_eq!(
            items, states,
            "a visitor that changes nothing changed the items"
        );
        out.0
    }

    #[test]
    fn lanes_equal_the_scalar_path_bit_for_bit() {
        let (sets, dynamics, states) = rig();
        let bank = LaneBank::new(sets.iter().zip(&dynamics), 0.7);
        for share in [
            Share::Setpoint(83.3),
            Share::Power(1900.0),
            Share::Power(0.0),
            Share::Power(1e9),
        ] {
            let got = outcomes(&bank, 0, &states, share, false);
            assert_eq!(got.len(), states.len());
            for (i, o) in got.iter().enumerate() {
                let (p, d) = (&sets[i], &dynamics[i]);
                let u = match share {
                    Share::Setpoint(u) => u,
                    Share::Power(w) => setpoint_for_power(p, w),
                };
                let want = d.tracking_step(0.7).step(&states[i], p.clamp_setpoint(u));
                assert_eq!(o.step, want, "set {i} under {share:?}");
                assert_eq!(
                    o.energy.to_bits(),
                    (p.voltage_intercept * want.charge + p.ohmic_resistance * want.current_squared)
                        .to_bits()
                );
                assert_eq!(
                    o.hydrogen.to_bits(),
                    (p.h2_coefficient / 3600.0 * want.charge).to_bits()
                );
                let i = want.state.current;
                assert_eq!(
                    o.voltage.to_bits(),
                    (p.voltage_intercept + p.ohmic_resistance * i).to_bits()
                );
                assert_eq!(
                    o.power.to_bits(),
                    ((p.voltage_intercept + p.ohmic_resistance * i) * i).to_bits()
                );
                assert_eq!(o.h2_flow.to_bits(), (p.h2_coefficient * i).to_bits());
            }
            assert_eq!(
                outcomes(&bank, 0, &states, share, true),
                got,
                "the CPU-specific copy differs under {share:?}"
            );
            // A later chunk of the sets gives the same outcomes for them.
            assert_eq!(outcomes(&bank, 4, &states[4..], share, false), got[4..]);
        }
    }

    #[test]
    fn a_tracking_step_is_the_closed_form_solution() {
        // From steady state at 90 % to 70 %: I(h) = K·70 + K·20·(a e^(−h/τp1) + b e^(−h/τp2)).
        let p = Parameters::default();
        let d = CurrentDynamics::new(&p);
        let bank = LaneBank::new(std::iter::once((&p, &d)), 2.0);
        let o = outcomes(
            &bank,
            0,
            &[d.steady_state(90.0)],
            Share::Setpoint(70.0),
            false,
        );
        assert!(o[0].step.tracks);
        let (a, b) = p.modal_weights();
        let want = p.gain * 70.0
            + p.gain * 20.0 * (a * (-2.0 / p.tau_pole1).exp() + b * (-2.0 / p.tau_pole2).exp());
        assert!(
            (o[0].step.state.current - want).abs() < 1e-12,
            "{} vs {want}",
            o[0].step.state.current
        );
    }

    #[test]
    fn a_rising_step_beyond_the_ramp_limit_is_not_tracking() {
        // 60 → 100 % from steady state: I_tf starts rising at K·40·(a/τp1 − b/τp2)·… > r.
        let p = Parameters::default();
        let d = CurrentDynamics::new(&p);
        let bank = LaneBank::new(std::iter::once((&p, &d)), 1.0);
        let o = outcomes(
            &bank,
            0,
            &[d.steady_state(60.0)],
            Share::Setpoint(100.0),
            false,
        );
        assert!(!o[0].step.tracks);
    }
}
