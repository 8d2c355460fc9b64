//! The hub keeps its groups in identity order and repairs that order after a step rather than
//! sorting: the repairs must give exactly what a full sort gives.

use super::tests::config;
use super::*;

/// The groups of a 2 000-module target-dispatch hub (as many running as the base allows) after
/// a minute of a power reference that swings ±35 % of rated around half of it every 15 s, as
/// FCR-N's sine test asks: modules stop to warm standby and start again at many moments, so
/// the groups are many and all distinct.
fn churned_groups() -> Vec<Group> {
    let p = Parameters::default();
    let cfg = HubConfig {
        dispatch_target: p.min_setpoint,
        ..config(2000, DispatchPolicy::Target, BelowMinimum::Standby)
    };
    let rated = 2000.0 * crate::dispatch::power_at_setpoint(&p, p.max_setpoint);
    let demand = |t: f64| {
        Demand::Power(rated * (0.5 + 0.35 * (2.0 * std::f64::consts::PI * t / 15.0).sin()))
    };
    let mut hub = Hub::new(p, cfg, demand(0.0)).unwrap();
    for k in 1..=600 {
        hub.step_with_base(demand(k as f64 * 0.1), demand(0.0), 0.1)
            .unwrap();
    }
    let groups = hub.groups().to_vec();
    assert!(
        groups.len() >= 30,
        "{} groups: too few to test",
        groups.len()
    );
    groups
}

/// A small deterministic generator (a linear congruential one): positions to disturb.
struct Draws(u64);

impl Draws {
    fn below(&mut self, n: usize) -> usize {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 33) % n as u64) as usize
    }
}

/// What merging did before: sort everything, then add up the equal neighbours.
fn sorted_and_merged(mut groups: Vec<Group>) -> Vec<Group> {
    groups.sort_unstable_by(identity_order);
    let mut out: Vec<Group> = Vec::new();
    for g in groups {
        match out.last_mut() {
            Some(last) if same(last, &g) => last.count += g.count,
            _ => out.push(g),
        }
    }
    out
}

fn merged(groups: Vec<Group>) -> (Vec<Group>, bool) {
    let p = Parameters::default();
    let mut hub = Hub::new(p, HubConfig::default(), Demand::Setpoint(80.0)).unwrap();
    hub.groups = groups;
    let changed = hub.merge();
    (hub.groups, changed)
}

#[test]
fn merging_groups_moved_out_of_place_gives_what_a_full_sort_gives() {
    let ordered = churned_groups();
    assert!(ordered
        .windows(2)
        .all(|w| identity_order(&w[0], &w[1]) == Ordering::Less));
    // In order and distinct: nothing to do, and merge says so.
    assert_eq!(merged(ordered.clone()), (ordered.clone(), false));
    let mut draws = Draws(7);
    // From one group moved to many (past FEW_OUT_OF_PLACE, where merge sorts).
    for moved in [1, 2, 5, FEW_OUT_OF_PLACE, 3 * FEW_OUT_OF_PLACE] {
        for _ in 0..20 {
            let mut groups = ordered.clone();
            for _ in 0..moved {
                let g = groups.remove(draws.below(groups.len()));
                groups.insert(draws.below(groups.len() + 1), g);
            }
            // And one group split in two, as a dispatch change splits one.
            let at = draws.below(groups.len());
            if groups[at].count > 1 {
                groups[at].count -= 1;
                let one = Group {
                    count: 1,
                    ..groups[at]
                };
                groups.insert(draws.below(groups.len() + 1), one);
            }
            let (got, changed) = merged(groups.clone());
            assert_eq!(changed, got != groups);
            assert_eq!(got, sorted_and_merged(groups), "{moved} moved");
            assert_eq!(got.iter().map(|g| g.count).sum::<u32>(), 2000);
        }
    }
}

#[test]
fn candidates_come_in_the_order_a_full_sort_gives() {
    // With modules waiting warm, stopped at ten moments, and some idle: candidates to start.
    let mut groups = churned_groups();
    let waiting = groups[0];
    for k in 0..10 {
        let unit = UnitState {
            state: OperatingState::Standby,
            timer: 60.0 * k as f64 + 0.5,
            ..UnitState::idle()
        };
        groups.push(Group {
            count: 1,
            active: false,
            unit,
            ..waiting
        });
    }
    groups.push(Group {
        count: 1,
        active: false,
        unit: UnitState::idle(),
        ..waiting
    });
    let ordered = sorted_and_merged(groups);
    let mut draws = Draws(11);
    let mut order = Vec::new();
    for shuffled in [false, true] {
        let mut groups = ordered.clone();
        if shuffled {
            for i in (1..groups.len()).rev() {
                groups.swap(i, draws.below(i + 1));
            }
        }
        for (starting, rotation) in [(true, false), (false, false), (true, true), (false, true)] {
            let sorted = in_preference(&groups, starting, rotation, &mut order);
            // Groups in identity order need no sort without rotation.
            if !rotation && !shuffled {
                assert!(!sorted, "starting {starting}");
            }
            let mut expected: Vec<u32> = (0..groups.len() as u32)
                .filter(|&i| groups[i as usize].active != starting)
                .collect();
            expected.sort_unstable_by(|&a, &b| {
                preference(&groups[a as usize], &groups[b as usize], starting, rotation)
            });
            assert!(
                expected.len() >= 3,
                "{} candidates, starting {starting}",
                expected.len()
            );
            assert_eq!(order, expected, "starting {starting}, rotation {rotation}");
        }
    }
}
