//! A search trial in lockstep: the searcher (control's `search`) explores a region of the
//! scene's tissue from where the sensor rests, driven by the same arm, planner and
//! controller as a tracking trial. The trial is scored against the scene's truth: whether
//! the region's artery was found, the seeds' lateral errors, and the heartbeats spent.

use control::frames::SurfacePoint;
use control::motion::Arrival;
use control::search::{
    LookReport, Region, SearchEvent, SearchMethod, SearchOutcome, SearchParams, Searcher,
};
use control::tracker::{MotionCommand, TrackerInput};
use serde::Serialize;

use super::{Lockstep, Stop};
use crate::error::SimError;
use crate::scene::Scene;

/// One search trial's result.
#[derive(Debug, Clone, Serialize)]
pub struct SearchTrial {
    pub seed: u64,
    pub method: SearchMethod,
    /// `found`, `not_found`, `stopped`, or how the trial itself stopped (`timeout`,
    /// `fault: ...`).
    pub end: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outcome: Option<SearchOutcome>,
    /// Heartbeats from the search's start to its end.
    pub beats: u64,
    pub duration_s: f64,
    pub looks: usize,
    /// Each seed's lateral distance from the true artery (where the sensor truly was), m.
    pub seed_errors_m: Vec<f64>,
    /// Every place the sensor centre was asked to look (tissue frame, m).
    pub asked: Vec<[f64; 2]>,
    /// The farthest the sensor truly went outside the region, m (0 inside).
    pub outside_m: f64,
    /// Every look, in order, with where the sensor truly was.
    pub looks_made: Vec<(LookReport, SurfacePoint)>,
}

/// Run a search of `region` on `scene` from where the scene rests the sensor.
pub fn run_search(
    scene: &Scene,
    config: &config::Config,
    region: Region,
    method: SearchMethod,
    params: SearchParams,
    seed: u64,
) -> Result<SearchTrial, SimError> {
    let mut l = Lockstep::new(
        scene,
        config,
        "beatslide",
        seed,
        &super::Calibrated::default(),
    )?;
    let mut searcher = Searcher::new(params, config.sensor, region, method)
        .map_err(|e| SimError::Config(format!("search: {e}")))?;
    l.bench.set_enabled(true);
    l.pd.reset();
    l.hold_here()?;
    let t0 = l.now();
    let beats0 = l.bench.beats_started_by(t0);
    let mut asked: Vec<[f64; 2]> = Vec::new();
    let mut outside_m: f64 = 0.0;
    let mut looks_made = Vec::new();
    let end = loop {
        let frame = match l.next_frame() {
            Ok(f) => f,
            Err(stop) => break stop_name(stop),
        };
        let truth = l.bench.truth().sensor;
        outside_m = outside_m.max(region.clamp(truth).distance_to(&truth));
        if l.last_move_target.is_some()
            && let Arrival::StoppedShort(_) = l.arrival()
        {
            // The arm cannot get there: the searcher looks elsewhere.
            searcher.target_unreachable();
            if let Err(e) = l.hold_at_believed() {
                break format!("fault: {e}");
            }
        }
        let input = TrackerInput {
            frame: &frame,
            sensor: l.believed_surface(),
            settled: l.settled(),
            loaded_sensor: l.felt_surface(),
        };
        let out = searcher.step(&input);
        if let MotionCommand::MoveTo { target, .. } = out.motion
            && asked.last() != Some(&[target.x_m, target.z_m])
        {
            asked.push([target.x_m, target.z_m]);
        }
        if let Err(e) = l.apply(out.motion) {
            match e {
                SimError::Kinematics(_) => searcher.target_unreachable(),
                other => break format!("fault: {other}"),
            }
        }
        if let Some(SearchEvent::Look(r)) = out.event {
            looks_made.push((r, l.bench.truth().sensor));
        }
        if let Some(SearchEvent::Finished(o)) = out.event {
            break match o {
                SearchOutcome::Found { .. } => "found".into(),
                SearchOutcome::NotFound { .. } => "not_found".into(),
                SearchOutcome::Stopped { .. } => "stopped".into(),
            };
        }
    };
    let t_end = l.now();
    let outcome = searcher.outcome().copied();
    let mut seed_errors_m = Vec::new();
    if let Some(SearchOutcome::Found { seeds, .. }) = &outcome {
        for p in seeds {
            // Where the sensor truly was at the seed's look (the look's event carries the
            // same time), not at the search's end.
            let look = looks_made.iter().find(|(r, _)| r.t_s == p.t_s);
            let truly = look.map_or_else(|| l.true_sensor_at(p.t_s), |(_, s)| *s);
            let point = SurfacePoint::new(
                truly.x_m + (p.point.x_m - p.sensor.x_m),
                truly.z_m + (p.point.z_m - p.sensor.z_m),
            );
            // Tissue moving with breathing carries the artery: scored where it lay at the
            // look's middle, as tracking trials score their points.
            let mid_s = look.map_or(p.t_s, |(r, _)| r.t_s - r.duration_s / 2.0);
            let point = scene
                .tissue
                .breathing
                .as_ref()
                .map_or(point, |b| b.to_rest(point, mid_s));
            seed_errors_m.push(l.bench.path().nearest(point).offset_m.abs());
        }
    }
    let looks = match outcome {
        Some(
            SearchOutcome::Found { looks, .. }
            | SearchOutcome::NotFound { looks, .. }
            | SearchOutcome::Stopped { looks, .. },
        ) => looks,
        None => 0,
    };
    Ok(SearchTrial {
        seed,
        method,
        end,
        outcome,
        beats: l.bench.beats_started_by(t_end).saturating_sub(beats0),
        duration_s: t_end - t0,
        looks,
        seed_errors_m,
        asked,
        outside_m,
        looks_made,
    })
}

fn stop_name(stop: Stop) -> String {
    match stop {
        Stop::Timeout => "timeout".into(),
        Stop::Fault(m) => format!("fault: {m}"),
        Stop::ShortOfTarget { what, .. } => format!("short_of_target: {what}"),
    }
}
