//! Scenes for the search benchmark (issue 17): a square region on a rig, with the artery
//! drawn straight through it at a random offset and heading, or, in a share of trials, a
//! region that holds only lumps with the artery well outside it. Each draw is reproducible
//! from its seed and is an ordinary scene (the `sim` and `bench` commands run it).

use control::frames::SurfacePoint;
use control::search::Region;
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

use crate::random::uniform_open;

use crate::scene::path::PathSpec;
use crate::scene::{LumpSpec, Scene};

/// Largest heading of a drawn artery from `+x`, rad: within the search's prior cone and
/// the families' followable range.
pub const MAX_HEADING_RAD: f64 = 45.0 * std::f64::consts::PI / 180.0;
/// Share of regions that hold no artery.
pub const EMPTY_SHARE: f64 = 0.2;
/// An artery-free region's artery lies this far beyond the region's edge, m: past the
/// array's reach (10 mm) and its kernel's tail from the region's edge.
const EMPTY_CLEARANCE_M: f64 = 0.03;
/// Length of the drawn straight artery, m (long enough to track from the region).
const ARTERY_LENGTH_M: f64 = 0.3;

/// One drawn search scene.
#[derive(Debug, Clone)]
pub struct SearchDraw {
    pub scene: Scene,
    pub region: Region,
    /// The artery crosses the region.
    pub artery_in_region: bool,
}

/// Draw trial `seed`'s scene on `base`'s rig: a `side_m` square region centred on
/// `centre`, the sensor resting at its centre.
pub fn draw(
    base: &Scene,
    centre: SurfacePoint,
    side_m: f64,
    seed: u64,
) -> Result<SearchDraw, String> {
    let region = Region::square(centre, side_m).map_err(|e| e.to_string())?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(0x5ea4c4);
    let mut u = |lo: f64, hi: f64| lo + (hi - lo) * uniform_open(&mut rng);
    let empty = u(0.0, 1.0) < EMPTY_SHARE;
    let (through, heading) = if empty {
        // Along x, beside the region on a random side.
        let side = if u(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
        let z = centre.z_m + side * (side_m / 2.0 + EMPTY_CLEARANCE_M);
        (SurfacePoint::new(centre.x_m, z), 0.0)
    } else {
        let z = centre.z_m + u(-0.5, 0.5) * side_m;
        (
            SurfacePoint::new(centre.x_m, z),
            u(-MAX_HEADING_RAD, MAX_HEADING_RAD),
        )
    };
    let lumps = if empty || u(0.0, 1.0) < 0.3 {
        let n = if empty { 1 + (u(0.0, 2.0) as usize) } else { 1 };
        (0..n)
            .map(|_| LumpSpec {
                centre: SurfacePoint::new(
                    centre.x_m + u(-0.4, 0.4) * side_m,
                    centre.z_m + u(-0.4, 0.4) * side_m,
                ),
                depth_m: u(0.004, 0.008),
                pressure_gain: u(0.3, 0.8),
            })
            .collect()
    } else {
        Vec::new()
    };
    let mut s = base.clone();
    s.name = format!("search-{seed}");
    s.description = format!(
        "Drawn for the search benchmark with seed {seed} on the rig of `{}`: a {:.0} mm square region centred at ({:.1}, {:.1}) mm, {}.",
        base.name,
        side_m * 1e3,
        centre.x_m * 1e3,
        centre.z_m * 1e3,
        if empty {
            "no artery in it (lumps only)"
        } else {
            "a straight artery through it"
        }
    );
    let half = ARTERY_LENGTH_M / 2.0;
    s.artery.path = PathSpec::Straight {
        start: SurfacePoint::new(
            through.x_m - half * heading.cos(),
            through.z_m - half * heading.sin(),
        ),
        heading_rad: heading,
        length_m: ARTERY_LENGTH_M,
    };
    s.lumps = lumps;
    s.start = Some(centre);
    // The placements a surgeon would use if shown: two points on the artery, 10 mm apart.
    s.placements = [
        through,
        SurfacePoint::new(
            through.x_m + 0.01 * heading.cos(),
            through.z_m + 0.01 * heading.sin(),
        ),
    ];
    Ok(SearchDraw {
        scene: s,
        region,
        artery_in_region: !empty,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_are_reproducible_and_empty_regions_hold_no_artery() {
        let base = crate::scene::load("seed-arc-145", None).expect("base");
        let c = SurfacePoint::new(0.0, 0.0);
        let a = draw(&base, c, 0.04, 5).expect("draw");
        let b = draw(&base, c, 0.04, 5).expect("draw");
        assert_eq!(a.scene, b.scene);
        let mut empty = 0;
        for seed in 0..200 {
            let d = draw(&base, c, 0.04, seed).expect("draw");
            let path = crate::scene::ArteryPath::from_spec(&d.scene.artery.path).expect("path");
            let nearest = path.nearest(c).offset_m.abs();
            if d.artery_in_region {
                assert!(nearest <= 0.02 + 1e-9, "{seed}: {nearest}");
            } else {
                empty += 1;
                assert!(
                    nearest >= 0.02 + EMPTY_CLEARANCE_M - 1e-9,
                    "{seed}: {nearest}"
                );
                assert!(!d.scene.lumps.is_empty());
            }
        }
        assert!((25..=55).contains(&empty), "{empty} of 200 empty");
    }
}
