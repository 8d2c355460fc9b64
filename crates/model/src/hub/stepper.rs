//! One piece of a hub's step, group by group (the scalar path) or four groups at a time
//! from the lanes' outcomes; both add to a chunk's [`Tally`] with the same arithmetic.

use super::super::dynamics::CurrentState;
use super::super::lanes::{Outcomes, Share, Visit, LANES};
use super::super::operation::{Command, OperatingState, OperationParameters, UnitTotals};
use super::tally::Tally;
use super::{Group, ModuleType};

/// One piece of a step, as every group sees it.
pub(super) struct Stepper {
    /// Per module: a setpoint [%] or a power [W].
    pub share: Share,
    /// The setpoint [%] every running module gets, where it is the same for all.
    pub common: Option<f64>,
    /// Length of the piece [s].
    pub piece: f64,
    /// Running hours and starts are kept per group (`Rotation`).
    pub rotation: bool,
    pub op: OperationParameters,
}

impl Stepper {
    /// The scalar path: group `g` (lane k of the chunk's tally) through its operating states.
    #[inline]
    pub fn advance(&self, ty: &mut ModuleType, g: &mut Group, tally: &mut Tally, k: usize) {
        let command = match (g.active, self.share, self.common) {
            (false, ..) => Command::Stop,
            (true, _, Some(u)) => Command::Run(u),
            (true, Share::Setpoint(u), None) => Command::Run(u),
            (true, Share::Power(p), None) => Command::Run(ty.curve.setpoint(p)),
        };
        let t = g.unit.advance(
            &ty.params,
            &ty.dynamics,
            &mut ty.factors,
            &self.op,
            ty.thermal.as_ref(),
            command,
            self.piece,
        );
        self.add(ty, g, &t, tally, k);
    }

    /// Adds group `g`'s step `t` (lane k) and the group as it is after it.
    #[inline(always)]
    fn add(&self, ty: &ModuleType, g: &mut Group, t: &UnitTotals, tally: &mut Tally, k: usize) {
        let c = g.count as f64;
        tally.energy[k] += c * t.energy;
        tally.h2_produced[k] += c * (ty.h2_per_coulomb * t.charge);
        tally.running[k] += c * t.running;
        tally.charge[k] += c * t.charge;
        tally.current_squared_time[k] += c * t.current_squared;
        tally.starting[k] += c * t.starting;
        tally.starts += g.count as u64 * t.starts as u64;
        tally.warm_starts += g.count as u64 * t.warm_starts as u64;
        if self.rotation {
            g.running += t.running;
            g.starts = g.starts.saturating_add(t.starts as u64);
        }
        if t.failure.is_some() {
            tally.failure = tally.failure.or(t.failure);
        }
        tally.observe(k, g, &ty.params, ty.thermal.as_ref(), &self.op);
    }

    /// [`Self::advance`] for a stopped group that stays as it is (Idle, or Standby or Blowdown
    /// with time left), with the same arithmetic, in a few instructions that stay in the lanes'
    /// loop. False, changing nothing, for any other group.
    #[inline(always)]
    fn waited(&self, ty: &ModuleType, g: &mut Group, tally: &mut Tally, k: usize) -> bool {
        if g.active {
            return false;
        }
        let Some(t) = g
            .unit
            .wait_stopped(&self.op, ty.thermal.as_ref(), self.piece)
        else {
            return false;
        };
        self.add(ty, g, &t, tally, k);
        true
    }

    /// [`Self::advance`] kept out of the lanes' vector loop.
    #[inline(never)]
    fn advance_aside(&self, ty: &mut ModuleType, g: &mut Group, tally: &mut Tally, k: usize) {
        self.advance(ty, g, tally, k);
    }

    /// Group `g`, dispatched and Steady, whose step the lanes computed in lane k (the same
    /// arithmetic as the scalar path).
    #[inline(always)]
    fn tracked(&self, g: &mut Group, o: &Outcomes, k: usize, tally: &mut Tally) {
        g.unit.current = CurrentState {
            z1: o.z1[k],
            z2: o.z2[k],
            current: o.current[k],
        };
        if self.rotation {
            g.running += self.piece;
        }
        tally.tracked(k, g.count, o, self.piece);
    }

    /// [`Self::tracked`] for a whole block, group k in lane k (the sums as vector instructions).
    #[inline(always)]
    fn tracked_block(&self, block: &mut [Group; LANES], o: &Outcomes, tally: &mut Tally) {
        for (k, g) in block.iter_mut().enumerate() {
            g.unit.current = CurrentState {
                z1: o.z1[k],
                z2: o.z2[k],
                current: o.current[k],
            };
            if self.rotation {
                g.running += self.piece;
            }
        }
        tally.tracked_block(block.each_ref().map(|g| g.count), o, self.piece);
    }
}

/// Steps a chunk of aligned groups (group i has parameter set i of the chunk) with the lanes'
/// outcomes, and the scalar path where a group is not a dispatched Steady one whose current
/// tracks; sums into the chunk's tally.
pub(super) struct ChunkVisitor<'a> {
    pub step: &'a Stepper,
    /// The chunk's parameter sets.
    pub types: &'a mut [ModuleType],
    /// Index in the chunk of the next block's first group.
    pub next: usize,
    pub tally: &'a mut Tally,
}

impl Visit<Group> for ChunkVisitor<'_> {
    #[inline(always)]
    fn state(g: &Group) -> CurrentState {
        g.unit.current
    }

    #[inline(always)]
    fn visit(&mut self, gs: &mut [Group], o: &Outcomes) {
        let first = self.next;
        self.next += gs.len();
        let mut tracks = [false; LANES];
        for (k, g) in gs.iter().enumerate() {
            tracks[k] = g.active & (g.unit.state == OperatingState::Steady) & o.tracks[k];
        }
        if let (Ok(block), true) = (
            <&mut [Group; LANES]>::try_from(&mut *gs),
            tracks == [true; LANES],
        ) {
            self.step.tracked_block(block, o, self.tally);
            return;
        }
        for (k, g) in gs.iter_mut().enumerate() {
            if tracks[k] {
                self.step.tracked(g, o, k, self.tally);
                continue;
            }
            let ty = &mut self.types[first + k];
            if !self.step.waited(ty, g, self.tally, k) {
                self.step.advance_aside(ty, g, self.tally, k);
            }
        }
    }
}
