//! The artery as a Foxglove scene (`/artery`, foxglove.SceneUpdate): the simulated true
//! course, the points the trial's tracker located, and (live only) where it is heading next.
//! One builder for the recording and the live view.

use super::*;

/// Diameter of a located point's sphere, m. The tracker reports no uncertainty with a
/// point, so every sphere is the same size.
const POINT_SIZE_M: f64 = 0.0015;

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

    /// The located points so far, as spheres in `/artery` (the entity is replaced each time).
    pub(super) fn record_located_scene(&self, t: f64) {
        if self.trial.is_none() {
            return;
        }
        self.emit(Topic::Artery, t, |epoch| fox::SceneUpdate {
            deletions: Vec::new(),
            entities: self.located_entity(epoch, t).into_iter().collect(),
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

    /// The open trial's located points: seeds blue, tracked points green.
    pub(super) fn located_entity(&self, epoch: Epoch, t: f64) -> Option<fox::SceneEntity> {
        let trial = self.trial.as_ref()?;
        let mut e = fox::SceneEntity::new(epoch.time(t), TISSUE_FRAME, "located");
        for p in trial.located.iter().map(|r| &r.point) {
            let (r, g, b) = if p.seed {
                (0.2, 0.5, 1.0)
            } else {
                (0.1, 0.9, 0.3)
            };
            e.spheres.push(fox::SpherePrimitive {
                pose: fox::Pose::at_surface(p.x_m, p.z_m),
                size: fox::Vector3 {
                    x: POINT_SIZE_M,
                    y: POINT_SIZE_M,
                    z: POINT_SIZE_M,
                },
                color: fox::Color { r, g, b, a: 1.0 },
            });
        }
        Some(e)
    }

    /// The path ahead as far as the tracker has said: a line from the last located point to
    /// the target it is moving the sensor to (empty when it has none, which clears it).
    pub(super) fn ahead_entity(&self, epoch: Epoch, t: f64) -> fox::SceneEntity {
        let mut e = fox::SceneEntity::new(epoch.time(t), TISSUE_FRAME, "ahead");
        let from = self
            .trial
            .as_ref()
            .and_then(|tr| tr.located.last())
            .map(|r| (r.point.x_m, r.point.z_m));
        if let (Some((x, z)), Some(target)) = (from, self.tracker_target) {
            e.lines.push(line(
                vec![
                    fox::Vector3 { x, y: 0.0, z },
                    fox::Vector3 {
                        x: target.x_m,
                        y: 0.0,
                        z: target.z_m,
                    },
                ],
                0.0004,
                fox::Color {
                    r: 1.0,
                    g: 0.8,
                    b: 0.1,
                    a: 0.9,
                },
            ));
        }
        e
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
