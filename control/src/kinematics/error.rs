//! Why a kinematic map refused: every failure of the arm, pivot and composed maps is one of
//! these, carrying the numbers that made it fail. No map ever answers with a NaN.

use thiserror::Error;

#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum KinematicsError {
    /// An input (or, defensively, a result) was NaN or infinite.
    #[error("{what} is not finite")]
    NonFinite { what: &'static str },

    /// The configured geometry cannot describe a real arm.
    #[error("invalid geometry: {what}")]
    InvalidGeometry { what: &'static str },

    /// The gimbal point is farther from the shoulder axis than the stretched arm, or nearer
    /// than the folded arm.
    #[error(
        "gimbal point out of the arm's reach: {distance_m:.6} m from the shoulder axis, \
         reachable {min_m:.6}..{max_m:.6} m"
    )]
    OutOfReach {
        distance_m: f64,
        min_m: f64,
        max_m: f64,
    },

    /// A configuration where the map has no unique answer (an axis singularity).
    #[error("singular configuration: {what}")]
    Singular { what: &'static str },

    /// The map's Jacobian is too close to singular to turn a velocity into joint rates.
    #[error(
        "near-singular Jacobian: smallest singular value {sigma_min_m_per_rad:.3e} m/rad \
         below {limit_m_per_rad:.3e} m/rad"
    )]
    NearSingular {
        sigma_min_m_per_rad: f64,
        limit_m_per_rad: f64,
    },

    /// A joint angle outside its configured range (joint index from 0).
    #[error("joint {joint} at {value_rad:.4} rad is outside {min_rad:.4}..{max_rad:.4} rad")]
    JointLimit {
        joint: usize,
        value_rad: f64,
        min_rad: f64,
        max_rad: f64,
    },

    /// θ3 − θ2 outside the parallel drive's coupling range.
    #[error(
        "joint coupling θ3 − θ2 = {value_rad:.4} rad is outside {min_rad:.4}..{max_rad:.4} rad"
    )]
    CouplingLimit {
        value_rad: f64,
        min_rad: f64,
        max_rad: f64,
    },

    /// The rod tip is too close to the pivot (the lever blows up) or too deep (the gimbal
    /// would come down onto the pivot).
    #[error("insertion depth {depth_m:.4} m is outside {min_m:.4}..{max_m:.4} m")]
    DepthOutOfRange {
        depth_m: f64,
        min_m: f64,
        max_m: f64,
    },

    /// The gimbal point or the tip sits on the pivot: the rod's direction is undefined.
    #[error("{what} is {distance_m:.3e} m from the pivot: the rod direction is undefined")]
    AtPivot { what: &'static str, distance_m: f64 },
}
