//! Where to look next. `search` picks, among looks on a grid over the region, the one with
//! the most expected information per second (the look's time plus the travel to it);
//! `raster`, the named baseline, visits a fixed boustrophedon grid that covers the region,
//! column by column. Both share the map, the looks and the stopping rule, so that the two
//! differ only in the choice.

use serde::{Deserialize, Serialize};

use crate::frames::SurfacePoint;

use super::line_map::LineMap;
use super::region::Region;

/// How the next look is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SearchMethod {
    /// The most information per second.
    #[default]
    Search,
    /// A fixed raster of the region.
    Raster,
}

impl SearchMethod {
    pub fn as_str(&self) -> &'static str {
        match self {
            SearchMethod::Search => "search",
            SearchMethod::Raster => "raster",
        }
    }

    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "search" => Some(Self::Search),
            "raster" => Some(Self::Raster),
            _ => None,
        }
    }
}

/// Looks closer than this to a place found unreachable are not chosen, m.
const UNREACHABLE_RADIUS_M: f64 = 1e-3;
/// Looks closer than this to an earlier look are not chosen, m: a look repeated in place
/// repeats the error of where the sensor is believed to be, which the map (taking looks as
/// independent) would count as new evidence; the search would then stay put and beat that
/// error down on paper.
const REPEAT_RADIUS_M: f64 = 2e-3;
/// Bins of the crossing's spread within a look's reach.
const PLACE_BINS: usize = 40;
/// A look worth less than this (nats) is not worth making.
pub const MIN_INFORMATION: f64 = 1e-3;
/// Time each move costs beyond its distance over the speed (accelerating and settling), s.
const MOVE_OVERHEAD_S: f64 = 0.5;

/// The raster's looks: columns `seed_separation_m` apart along `x` (so that two felt
/// columns seed), rows along `z` overlapping by a fifth of the reach, in boustrophedon
/// order from the region's `−x` side.
pub fn raster_looks(region: &Region, reach_m: f64, column_spacing_m: f64) -> Vec<SurfacePoint> {
    let cols = ((region.width_m() / column_spacing_m).floor() as usize + 1).max(1);
    let row_span = 2.0 * reach_m * 0.8;
    let rows = ((region.height_m() / row_span).ceil() as usize).max(1);
    let mut out = Vec::with_capacity(cols * rows);
    for c in 0..cols {
        let x = if cols == 1 {
            region.centre().x_m
        } else {
            region.x0_m + region.width_m() * c as f64 / (cols - 1) as f64
        };
        for r in 0..rows {
            let r = if c % 2 == 0 { r } else { rows - 1 - r };
            let z = region.z0_m + region.height_m() * (r as f64 + 0.5) / rows as f64;
            out.push(region.clamp(SurfacePoint::new(x, z)));
        }
    }
    out
}

/// The candidate looks of `search`: a grid over the region.
pub fn candidate_looks(region: &Region, step_m: f64) -> Vec<SurfacePoint> {
    let n = |side: f64| (side / step_m).round().max(1.0) as usize + 1;
    let (nx, nz) = (n(region.width_m()), n(region.height_m()));
    let mut out = Vec::with_capacity(nx * nz);
    for i in 0..nx {
        for k in 0..nz {
            // Clamped: rounding must not put a corner a hair outside.
            out.push(region.clamp(SurfacePoint::new(
                region.x0_m + region.width_m() * i as f64 / (nx - 1) as f64,
                region.z0_m + region.height_m() * k as f64 / (nz - 1) as f64,
            )));
        }
    }
    out
}

/// Scratch for [`best_look`], allocated once.
#[derive(Debug, Clone, Default)]
pub struct PlanScratch {
    p: Vec<f64>,
    bins: Vec<f64>,
}

/// A chosen look and what it is expected to give.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Choice {
    pub at: SurfacePoint,
    pub information: f64,
    pub seconds: f64,
}

/// The candidate with the most expected information per second from `from`, skipping
/// places found unreachable and places already looked at; `None` when no look is worth
/// making.
#[allow(clippy::too_many_arguments)]
pub fn best_look(
    map: &LineMap,
    candidates: &[SurfacePoint],
    unreachable: &[SurfacePoint],
    looked: &[SurfacePoint],
    from: SurfacePoint,
    look_s: f64,
    speed_m_s: f64,
    se_m: f64,
    scratch: &mut PlanScratch,
) -> Option<Choice> {
    map.probabilities(&mut scratch.p);
    scratch.bins.resize(PLACE_BINS, 0.0);
    let mut best: Option<(f64, Choice)> = None;
    for &c in candidates {
        if unreachable
            .iter()
            .any(|u| u.distance_to(&c) < UNREACHABLE_RADIUS_M)
            || looked.iter().any(|u| u.distance_to(&c) < REPEAT_RADIUS_M)
        {
            continue;
        }
        let information = map.look_information(&scratch.p, c, se_m, &mut scratch.bins);
        if information < MIN_INFORMATION {
            continue;
        }
        let travel = from.distance_to(&c);
        let seconds = look_s
            + if travel > UNREACHABLE_RADIUS_M {
                travel / speed_m_s + MOVE_OVERHEAD_S
            } else {
                0.0
            };
        let rate = information / seconds;
        if best.as_ref().is_none_or(|(r, _)| rate > *r) {
            best = Some((
                rate,
                Choice {
                    at: c,
                    information,
                    seconds,
                },
            ));
        }
    }
    best.map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_raster_covers_the_region_in_boustrophedon_order() {
        let r = Region::square(SurfacePoint::new(0.0, 0.0), 0.04).expect("region");
        let looks = raster_looks(&r, 0.01, 0.01);
        // 5 columns 10 mm apart, 3 rows (16 mm each) across 40 mm.
        assert_eq!(looks.len(), 15);
        assert!(looks.iter().all(|p| r.contains(*p)));
        assert_eq!(looks[0].x_m, -0.02);
        assert!(looks[0].z_m < looks[1].z_m && looks[3].z_m > looks[4].z_m);
        // Every z of the region lies within a row's 80 % reach.
        for k in 0..=40 {
            let z = -0.02 + k as f64 * 1e-3;
            assert!(
                looks[..3]
                    .iter()
                    .any(|p| (p.z_m - z).abs() <= 0.008 + 1e-12),
                "{z}"
            );
        }
        let c = candidate_looks(&r, 0.002);
        assert_eq!(c.len(), 21 * 21);
        assert!(c.iter().all(|p| r.contains(*p)));
    }
}
