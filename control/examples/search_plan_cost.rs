//! What choosing a search's next look costs: the map's update with one look and the choice
//! over the candidate grid, on the default 40 mm region (19 481 lines, 18 x 18 candidates).
//! Medians of repeated runs: `cargo run --release -p pulsetrack-control --example
//! search_plan_cost`. The choice runs once per look (every 2-4 s), on the supervisor's
//! thread, never on the 1 kHz loop.

use std::time::Instant;

use pulsetrack_control::frames::SurfacePoint;
use pulsetrack_control::search::line_map::{LineMap, LookReading, MapSettings};
use pulsetrack_control::search::plan::{PlanScratch, best_look, candidate_looks};
use pulsetrack_control::search::{Region, SearchParams};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), String> {
    let p = SearchParams::default();
    let region = Region::square(SurfacePoint::new(0.0, 0.0), 0.04).map_err(|e| e.to_string())?;
    let settings = MapSettings {
        max_heading_rad: p.max_heading_rad,
        heading_centre_rad: 0.0,
        offset_step_m: p.offset_step_m,
        heading_step_rad: p.heading_step_rad,
        reach_m: 0.01,
        p_detect: p.p_detect,
        p_false: p.p_false,
        place_floor_m: p.place_floor_m,
        prior_absent: p.prior_absent,
    };
    let candidates = candidate_looks(&region.inset(p.edge_margin_m), p.candidate_step_m);
    let mut scratch = PlanScratch::default();
    let (mut update, mut choose) = (Vec::new(), Vec::new());
    for k in 0..50 {
        let mut map = LineMap::new(&region, settings);
        let t0 = Instant::now();
        map.observe(
            SurfacePoint::new(0.0, 0.0),
            LookReading::Felt {
                offset_z_m: 1e-3 * (k % 5) as f64,
                se_m: 1e-4,
            },
        );
        update.push(t0.elapsed().as_secs_f64());
        let t0 = Instant::now();
        let c = best_look(
            &map,
            &candidates,
            &[],
            &[SurfacePoint::new(0.0, 0.0)],
            SurfacePoint::new(0.0, 0.0),
            2.3,
            p.speed_m_s,
            2e-4,
            &mut scratch,
        );
        choose.push(t0.elapsed().as_secs_f64());
        if c.is_none() {
            return Err("no look chosen".into());
        }
    }
    println!(
        "lines {}, candidates {}: map update median {:.2} ms, choice median {:.2} ms",
        LineMap::new(&region, settings).cells(),
        candidates.len(),
        median(update) * 1e3,
        median(choose) * 1e3
    );
    Ok(())
}
