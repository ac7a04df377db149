//! The search's map as a Foxglove scene entity on `/artery` (foxglove.SceneUpdate), so that
//! the live view's 3D panel shows it beside the artery: the region's outline, every look
//! (blue where a pulse was placed, grey where none), and a 2 mm grid of translucent tiles,
//! each as opaque as the probability that the artery crosses its column there.

use serde_json::json;

use super::*;

/// Side of a map tile, m.
const TILE_M: f64 = 0.002;
/// Tiles fainter than this are left out (a 40 mm region has 400 tiles).
const MIN_SHOWN: f64 = 0.01;
/// Height of a tile above the surface, m (under the located points' spheres).
const TILE_THICKNESS_M: f64 = 0.0002;

impl Supervisor {
    /// Publish the search's map now, live and into the search's file.
    pub(super) fn live_search_map(&self, t: f64) {
        let looks = &self.search_looks;
        let Some(searcher) = self.searcher.as_ref() else {
            return;
        };
        let region = *searcher.region();
        let nx = ((region.width_m() / TILE_M).round() as usize).max(1);
        let nz = ((region.height_m() / TILE_M).round() as usize).max(1);
        let occupancy = searcher.map().occupancy(&region, nx, nz);
        let (w, h) = (region.width_m() / nx as f64, region.height_m() / nz as f64);
        self.emit(Topic::Artery, t, |epoch| {
            let mut e = fox::SceneEntity::new(epoch.time(t), TISSUE_FRAME, "search_map");
            for (k, &p) in occupancy.iter().enumerate() {
                if p < MIN_SHOWN {
                    continue;
                }
                let (c, r) = (k / nz, k % nz);
                let pose = fox::Pose::at_surface(
                    region.x0_m + (c as f64 + 0.5) * w,
                    region.z0_m + (r as f64 + 0.5) * h,
                );
                e.cubes.push(json!({
                    "pose": pose,
                    "size": {"x": w, "y": TILE_THICKNESS_M, "z": h},
                    "color": {"r": 1.0, "g": 0.6, "b": 0.1, "a": p.clamp(0.0, 1.0) * 0.8},
                }));
            }
            let corners = [
                (region.x0_m, region.z0_m),
                (region.x1_m, region.z0_m),
                (region.x1_m, region.z1_m),
                (region.x0_m, region.z1_m),
                (region.x0_m, region.z0_m),
            ];
            e.lines.push(fox::LinePrimitive {
                kind: 0,
                pose: fox::Pose::at_surface(0.0, 0.0),
                thickness: 0.0003,
                scale_invariant: false,
                points: corners
                    .iter()
                    .map(|&(x, z)| fox::Vector3 { x, y: 0.0, z })
                    .collect(),
                color: fox::Color {
                    r: 1.0,
                    g: 0.6,
                    b: 0.1,
                    a: 1.0,
                },
                colors: Vec::new(),
                indices: Vec::new(),
            });
            for &(at, felt) in looks {
                let (r, g, b) = if felt {
                    (0.2, 0.5, 1.0)
                } else {
                    (0.6, 0.6, 0.6)
                };
                e.spheres.push(fox::SpherePrimitive {
                    pose: fox::Pose::at_surface(at.x_m, at.z_m),
                    size: fox::Vector3 {
                        x: 0.001,
                        y: 0.001,
                        z: 0.001,
                    },
                    color: fox::Color { r, g, b, a: 0.9 },
                });
            }
            fox::SceneUpdate {
                deletions: Vec::new(),
                entities: vec![e],
            }
        });
    }
}
