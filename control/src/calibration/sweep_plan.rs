//! The order and the poses of a joint stop sweep (docs/rig-bring-up.md section 1): for each
//! stop asked for, a straight joint-space move to a pose from which that joint can sweep to
//! its software limit plus the overtravel, the sweep itself, a move back off the stop, and at
//! the end a move back to where the sweep started. The held joints are placed so that the
//! parallel drive's coupling `θ3 − θ2` (`JointLimits::coupling_min_rad..coupling_max_rad`)
//! stays inside its range, with a margin, over the whole sweep: from the reset pose θ3's
//! upper stop cannot be reached without raising θ2 first. The limits and the coupling range
//! are a convex set, so a straight joint-space line between two poses inside it stays inside
//! it. Pure, fixed size: built once when a sweep starts, read every servo cycle.

use thiserror::Error;

use super::joints::{JointSettings, Side};
use crate::kinematics::JointLimits;
use crate::types::{JOINTS, Joints};

/// Every stop of every joint: a lower and an upper per joint.
pub const MAX_STOPS: usize = 2 * JOINTS;
/// Three legs per stop (there, sweep, back off) and the way home.
pub const MAX_LEGS: usize = 3 * MAX_STOPS + 1;
/// How far inside a software limit or the coupling range a planned pose stays, rad.
pub const PLAN_MARGIN_RAD: f64 = 0.05;

/// Which stops a sweep looks for, in the order it sweeps them (joint 0 lower first).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StopTargets {
    wanted: [bool; MAX_STOPS],
}

impl StopTargets {
    /// Both stops of every joint.
    pub fn all() -> Self {
        Self {
            wanted: [true; MAX_STOPS],
        }
    }

    /// Both stops of each joint named.
    pub fn joints(joints: &[usize]) -> Result<Self, PlanError> {
        let mut t = Self::default();
        for &j in joints {
            if j >= JOINTS {
                return Err(PlanError::NoSuchJoint { joint: j });
            }
            t.wanted[2 * j] = true;
            t.wanted[2 * j + 1] = true;
        }
        Ok(t)
    }

    /// The stops asked for, in sweep order.
    pub fn iter(&self) -> impl Iterator<Item = (usize, Side)> + '_ {
        (0..MAX_STOPS).filter(|i| self.wanted[*i]).map(|i| {
            let side = if i % 2 == 0 { Side::Lower } else { Side::Upper };
            (i / 2, side)
        })
    }

    pub fn count(&self) -> usize {
        self.wanted.iter().filter(|w| **w).count()
    }
}

/// One leg of the sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Leg {
    /// Every joint along a straight joint-space line to `to` at the sweep speed. `widened`:
    /// the stop whose limit check stays widened (backing off it from beyond the limit).
    Move {
        to: Joints,
        widened: Option<(usize, Side)>,
    },
    /// `joint` swept toward its `side` stop, the others held at `hold` (where the move
    /// before it left them).
    Search {
        joint: usize,
        side: Side,
        hold: Joints,
    },
}

impl Leg {
    /// The stop whose limit check is widened during this leg.
    pub fn widened(&self) -> Option<(usize, Side)> {
        match *self {
            Leg::Move { widened, .. } => widened,
            Leg::Search { joint, side, .. } => Some((joint, side)),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Error)]
pub enum PlanError {
    #[error("there is no joint {joint} (the Phantom has joints 0, 1 and 2)")]
    NoSuchJoint { joint: usize },
    #[error("no stops asked for")]
    NoTargets,
    #[error("the sweep's start pose is not finite (joint {joint}: {value})")]
    NonFinite { joint: usize, value: f64 },
    #[error(
        "the sweep must start inside the software limits and the coupling range: {what} is \
         {value:.4} rad, allowed {min:.4}..{max:.4} rad"
    )]
    StartOutside {
        what: &'static str,
        value: f64,
        min: f64,
        max: f64,
    },
    #[error(
        "joint {joint}'s {side} stop cannot be swept inside the coupling range θ3 − θ2: \
         joint {other} would have to lie in {min:.4}..{max:.4} rad, which its own limits \
         (less {margin} rad) exclude",
        side = side.name(),
        margin = PLAN_MARGIN_RAD
    )]
    CouplingBlocks {
        joint: usize,
        side: Side,
        other: usize,
        min: f64,
        max: f64,
    },
}

/// The legs of one sweep, in order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepPlan {
    legs: [Leg; MAX_LEGS],
    len: usize,
    start: Joints,
}

impl SweepPlan {
    /// Plan a sweep of `targets` from `start` (the arm's pose, which must lie inside the
    /// limits and the coupling range).
    pub fn new(
        start: &Joints,
        targets: StopTargets,
        limits: &JointLimits,
        settings: &JointSettings,
    ) -> Result<Self, PlanError> {
        check_start(start, limits)?;
        if targets.count() == 0 {
            return Err(PlanError::NoTargets);
        }
        let home = Leg::Move {
            to: *start,
            widened: None,
        };
        let mut legs = [home; MAX_LEGS];
        let mut len = 0;
        for (joint, side) in targets.iter() {
            let hold = hold_pose(start, joint, side, limits, settings)?;
            for leg in [
                Leg::Move {
                    to: hold,
                    widened: None,
                },
                Leg::Search { joint, side, hold },
                Leg::Move {
                    to: hold,
                    widened: Some((joint, side)),
                },
            ] {
                legs[len] = leg;
                len += 1;
            }
        }
        legs[len] = home;
        len += 1;
        Ok(Self {
            legs,
            len,
            start: *start,
        })
    }

    pub fn legs(&self) -> &[Leg] {
        &self.legs[..self.len]
    }

    /// Where the sweep started (and ends).
    pub fn start(&self) -> Joints {
        self.start
    }
}

fn check_start(q: &Joints, limits: &JointLimits) -> Result<(), PlanError> {
    const NAMES: [&str; JOINTS] = ["joint 0", "joint 1", "joint 2"];
    for j in 0..JOINTS {
        if !q[j].is_finite() {
            return Err(PlanError::NonFinite {
                joint: j,
                value: q[j],
            });
        }
        if !(limits.min_rad[j]..=limits.max_rad[j]).contains(&q[j]) {
            return Err(PlanError::StartOutside {
                what: NAMES[j],
                value: q[j],
                min: limits.min_rad[j],
                max: limits.max_rad[j],
            });
        }
    }
    let c = q[2] - q[1];
    if !(limits.coupling_min_rad..=limits.coupling_max_rad).contains(&c) {
        return Err(PlanError::StartOutside {
            what: "the coupling θ3 − θ2",
            value: c,
            min: limits.coupling_min_rad,
            max: limits.coupling_max_rad,
        });
    }
    Ok(())
}

/// The pose a sweep of `joint` toward `side` starts from and holds the other joints at: the
/// swept joint where it starts (inside its limits by the margin), the coupled joint moved
/// just enough that `θ3 − θ2` stays inside its range over the whole sweep.
fn hold_pose(
    start: &Joints,
    joint: usize,
    side: Side,
    limits: &JointLimits,
    settings: &JointSettings,
) -> Result<Joints, PlanError> {
    let m = PLAN_MARGIN_RAD;
    let inside = |j: usize, v: f64| v.clamp(limits.min_rad[j] + m, limits.max_rad[j] - m);
    let mut hold = *start;
    let a = inside(joint, start[joint]);
    hold[joint] = a;
    let b = side.limit(limits, joint) + side.sign() * settings.overtravel_rad;
    let (lo, hi) = (a.min(b), a.max(b));
    let (cmin, cmax) = (limits.coupling_min_rad + m, limits.coupling_max_rad - m);
    // θ3 − θ2 in [cmin, cmax] for every swept value in [lo, hi].
    let (other, range) = match joint {
        2 => (1, (hi - cmax, lo - cmin)),
        1 => (2, (hi + cmin, lo + cmax)),
        _ => return Ok(hold),
    };
    let min = range.0.max(limits.min_rad[other] + m);
    let max = range.1.min(limits.max_rad[other] - m);
    if min > max {
        return Err(PlanError::CouplingBlocks {
            joint,
            side,
            other,
            min: range.0,
            max: range.1,
        });
    }
    hold[other] = start[other].clamp(min, max);
    Ok(hold)
}
