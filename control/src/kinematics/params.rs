//! Geometry and limits of the arm and the rod through the pivot, as configured.

use serde::{Deserialize, Serialize};

use crate::frames::TissuePlacement;
use crate::types::Joints;

/// Phantom Premium 1.5 link lengths (Cavusoglu et al. form).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PhantomGeometry {
    /// Upper arm, m.
    pub l1_m: f64,
    /// Forearm, m.
    pub l2_m: f64,
}

impl Default for PhantomGeometry {
    fn default() -> Self {
        Self {
            l1_m: 0.215,
            l2_m: 0.170,
        }
    }
}

/// Joint range and the parallel-drive coupling between θ2 and θ3.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct JointLimits {
    pub min_rad: Joints,
    pub max_rad: Joints,
    /// Allowed range of θ3 − θ2, rad: the links can neither fold onto each other nor
    /// stretch out straight (π/2 is full stretch on the elbow-up branch, −π/2 folded flat).
    pub coupling_min_rad: f64,
    pub coupling_max_rad: f64,
}

impl Default for JointLimits {
    fn default() -> Self {
        // Software limits a few degrees inside the stops. The coupling range (−65°..+55°
        // mechanically) and θ3's lower stop (−29°) follow an open model of a Premium of
        // that era; θ1 and θ2 enclose the quoted workspace box. Sources and reasoning are in
        // docs/kinematics.md; measure the stops of a real rig and write them in its file.
        Self {
            min_rad: [-1.0, -0.35, -0.45],
            max_rad: [1.0, 1.2, 1.5],
            coupling_min_rad: -1.08,
            coupling_max_rad: 0.91,
        }
    }
}

/// The rod through the fixed pivot (remote centre of motion).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PivotGeometry {
    /// Gimbal point to rod tip, m (the seed's rod: 0.495 m).
    pub rod_length_m: f64,
    /// The pivot (incision) in the robot base frame, m.
    pub pivot_in_base_m: [f64; 3],
    /// Smallest allowed insertion depth |T − P|: near the pivot the lever (L − d)/d blows up.
    pub min_depth_m: f64,
    /// Largest allowed insertion depth; keeps the gimbal clear of the pivot.
    pub max_depth_m: f64,
}

impl Default for PivotGeometry {
    fn default() -> Self {
        // The pivot 0.215 m straight below the gimbal point of the pose θ = (0, 0.5, 0.5)
        // rad, so that with the tip 0.28 m below the pivot the arm sits mid-range; see
        // docs/kinematics.md for the sweep that checks the whole tissue patch.
        Self {
            rod_length_m: 0.495,
            pivot_in_base_m: [0.0, -0.09, 0.055],
            min_depth_m: 0.15,
            max_depth_m: 0.36,
        }
    }
}

/// From the rod tip to the centre of the element line, tissue frame, m: the rod ends on the
/// axis of the 9 mm sensor cylinder, whose bottom edge carries the elements.
pub const DEFAULT_SENSOR_OFFSET_M: [f64; 3] = [0.0, -0.0045, 0.0];

/// Depth of the rod tip below the pivot, m, at which the default placement puts the sensor
/// centre on the tissue surface straight under the pivot.
pub const DEFAULT_SURFACE_DEPTH_M: f64 = 0.28;

/// A tissue frame whose origin lies on the surface straight below the pivot, where the
/// sensor centre touches it with the tip `surface_depth_m` deep (the rod vertical when the
/// offset points straight down, as the default does).
pub fn tissue_under_pivot(
    pivot: &PivotGeometry,
    sensor_offset_m: [f64; 3],
    surface_depth_m: f64,
    yaw_rad: f64,
) -> TissuePlacement {
    let [px, py, pz] = pivot.pivot_in_base_m;
    TissuePlacement {
        origin_in_base_m: [px, py - surface_depth_m + sensor_offset_m[1], pz],
        yaw_rad,
    }
}
