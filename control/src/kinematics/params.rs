//! Geometry and limits of the arm and the rod through the pivot, as configured.

use serde::{Deserialize, Serialize};

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
    /// Allowed range of θ3 − θ2 (the two links cannot fold onto each other), rad.
    pub coupling_min_rad: f64,
    pub coupling_max_rad: f64,
}

impl Default for JointLimits {
    fn default() -> Self {
        // Roughly the Phantom 1.5's mechanical stops, kept slightly inside them.
        Self {
            min_rad: [-1.0, -0.35, -0.45],
            max_rad: [1.0, 1.2, 1.3],
            coupling_min_rad: -0.9,
            coupling_max_rad: 1.4,
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
        Self {
            rod_length_m: 0.495,
            pivot_in_base_m: [0.0, -0.25, 0.0],
            min_depth_m: 0.05,
            max_depth_m: 0.30,
        }
    }
}
