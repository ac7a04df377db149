//! The artery as a Foxglove scene (`/artery`, foxglove.SceneUpdate): the simulated true
//! course, the points the trial's tracker located with their uncertainty, and the course it
//! expects ahead. One builder for the recording and the live view.

use control::tracker::PredictedPoint;

use super::*;

/// Diameter of a located point's sphere, m.
const POINT_SIZE_M: f64 = 0.0015;

/// Thickness of the flat discs that show a point's uncertainty, m.
const DISC_THICKNESS_M: f64 = 0.0002;

impl Supervisor {
    /// The simulated artery's true course, once per trial, as a line in `/artery`.
    pub(super) fn record_true_path(&self, t: f64) {
        if self.true_path.is_empty() {
            return;
        }
        self.emit(Topic::Artery, t, |epoch| fox::SceneUpdate {
            deletions: Vec::new(),
            entities: self.true_path_entity(epoch, t).into_iter().collect(),
        });
    }

    /// The located points so far, as spheres in `/artery` (the entity is replaced each time),
    /// and the course the tracker now expects ahead of them.
    pub(super) fn record_located_scene(&self, t: f64) {
        if self.trial.is_none() {
            return;
        }
        self.emit(Topic::Artery, t, |epoch| fox::SceneUpdate {
            deletions: Vec::new(),
            entities: self
                .located_entity(epoch, t)
                .into_iter()
                .chain([self.ahead_entity(epoch, t)])
                .collect(),
        });
    }

    /// The simulator's true path (`None` off the sim).
    pub(super) fn true_path_entity(&self, epoch: Epoch, t: f64) -> Option<fox::SceneEntity> {
        if self.true_path.is_empty() {
            return None;
        }
        let mut e = fox::SceneEntity::new(epoch.time(t), TISSUE_FRAME, "true_path");
        e.lines.push(line(
            self.true_path
                .iter()
                .map(|p| fox::Vector3 {
                    x: p.x_m,
                    y: 0.0,
                    z: p.z_m,
                })
                .collect(),
            0.0005,
            fox::Color {
                r: 0.9,
                g: 0.2,
                b: 0.2,
                a: 0.8,
            },
        ));
        Some(e)
    }

    /// The open trial's located points: seeds blue, tracked points green, each on a
    /// translucent disc of radius two SDs of its uncertainty (when the tracker gives one).
    pub(super) fn located_entity(&self, epoch: Epoch, t: f64) -> Option<fox::SceneEntity> {
        let trial = self.trial.as_ref()?;
        let mut e = fox::SceneEntity::new(epoch.time(t), TISSUE_FRAME, "located");
        for p in trial.located.iter().map(|r| &r.point) {
            let (r, g, b) = if p.seed {
                (0.2, 0.5, 1.0)
            } else {
                (0.1, 0.9, 0.3)
            };
            e.spheres.push(sphere(
                p.x_m,
                p.z_m,
                [POINT_SIZE_M; 3],
                fox::Color { r, g, b, a: 1.0 },
            ));
            if let Some(sd) = p.sd_m.filter(|sd| sd.is_finite() && *sd > 0.0) {
                let d = 4.0 * sd;
                e.spheres.push(sphere(
                    p.x_m,
                    p.z_m,
                    [d, DISC_THICKNESS_M, d],
                    fox::Color { r, g, b, a: 0.2 },
                ));
            }
        }
        Some(e)
    }

    /// The course the trial's tracker expects ahead (`Tracker::path_ahead`): its centre line
    /// and, where it gives an SD, the band of two SDs either side. A tracker with no model
    /// of it shows a line from the last located point to the target it is moving the sensor
    /// to. Empty when there is neither, which clears it.
    pub(super) fn ahead_entity(&self, epoch: Epoch, t: f64) -> fox::SceneEntity {
        let mut e = fox::SceneEntity::new(epoch.time(t), TISSUE_FRAME, "ahead");
        let mut ahead = Vec::new();
        if let Some(tracker) = self.tracker.as_ref() {
            tracker.path_ahead(&mut ahead);
        }
        let from = self
            .trial
            .as_ref()
            .and_then(|tr| tr.located.last())
            .map(|r| SurfacePoint::new(r.point.x_m, r.point.z_m));
        if ahead.len() < 2
            && let (Some(from), Some(target)) = (from, self.tracker_target)
        {
            ahead = [from, target]
                .map(|point| PredictedPoint { point, sd_m: None })
                .to_vec();
        }
        if ahead.len() < 2 {
            return e;
        }
        let yellow = |a| fox::Color {
            r: 1.0,
            g: 0.8,
            b: 0.1,
            a,
        };
        let centre: Vec<fox::Vector3> = ahead.iter().map(|p| surface(p.point)).collect();
        e.lines.push(line(centre, 0.0004, yellow(0.9)));
        if ahead.iter().all(|p| p.sd_m.is_some_and(f64::is_finite)) {
            for side in [-2.0, 2.0] {
                let edge = (0..ahead.len())
                    .map(|i| {
                        // Across the course: the left normal of its local direction.
                        let a = ahead[i.saturating_sub(1)].point;
                        let b = ahead[(i + 1).min(ahead.len() - 1)].point;
                        let (dx, dz) = (b.x_m - a.x_m, b.z_m - a.z_m);
                        let n = dx.hypot(dz).max(1e-12);
                        let off = side * ahead[i].sd_m.unwrap_or(0.0);
                        let p = ahead[i].point;
                        surface(SurfacePoint::new(
                            p.x_m - off * dz / n,
                            p.z_m + off * dx / n,
                        ))
                    })
                    .collect();
                e.lines.push(line(edge, 0.0002, yellow(0.4)));
            }
        }
        e
    }
}

/// A point on the tissue surface in the scene.
fn surface(p: SurfacePoint) -> fox::Vector3 {
    fox::Vector3 {
        x: p.x_m,
        y: 0.0,
        z: p.z_m,
    }
}

/// An ellipsoid of diameters `size` (x, y, z) centred on the surface at (`x_m`, `z_m`).
fn sphere(x_m: f64, z_m: f64, size: [f64; 3], color: fox::Color) -> fox::SpherePrimitive {
    fox::SpherePrimitive {
        pose: fox::Pose::at_surface(x_m, z_m),
        size: fox::Vector3 {
            x: size[0],
            y: size[1],
            z: size[2],
        },
        color,
    }
}

fn line(points: Vec<fox::Vector3>, thickness_m: f64, color: fox::Color) -> fox::LinePrimitive {
    fox::LinePrimitive {
        kind: 0,
        pose: fox::Pose::at_surface(0.0, 0.0),
        thickness: thickness_m,
        scale_invariant: false,
        points,
        color,
        colors: Vec::new(),
        indices: Vec::new(),
    }
}
