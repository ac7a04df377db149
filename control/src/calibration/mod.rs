//! Calibration math for bringing up a rig (issue 15): the pivot (incision) from rod lines, the
//! tissue frame from touched surface points, the tactile array's tare, gains and faulty
//! elements, and the joints' encoder zero and stops; each result carries its residual and [`tolerance::Check`]s against configured
//! tolerances.
//!
//! Pure functions over recorded data: the procedures that move the arm and record the data,
//! the calibration file and the daemon's verbs are not here (docs/calibration.md, "Rig
//! calibration").

pub mod joint_sweep;
pub mod joints;
pub mod level_pivot;
pub mod pivot;
pub mod stop_search;
pub mod sweep_plan;
pub mod tactile;
mod tactile_applied;
pub mod tissue_frame;
pub mod tolerance;
pub mod touch;

#[cfg(test)]
mod joint_sweep_tests;
#[cfg(test)]
mod joints_tests;
#[cfg(test)]
mod kinematics_tests;

pub use joint_sweep::{Findings, JointSweep, SweepCycle, SweepError};
pub use joints::{
    JointSettings, JointsError, Side, StopFound, through_zero, zero_checks, zero_offsets,
};
pub use level_pivot::{LevelPivotError, LevelPivotFit, check_layout, fit_pivot_level};
pub use pivot::{PivotFit, PivotFitError, RodLine, fit_pivot};
pub use stop_search::{SearchStep, StopSearch};
pub use sweep_plan::{Leg, PlanError, StopTargets, SweepPlan};
pub use tactile::{
    ElementCalibration, ElementStatus, Recording, TactileCalibration, TactileCalibrationError,
    TactileSettings, Tare, calibrate_gains,
};
pub use tissue_frame::{ArteryCourse, TissueFit, TissueFrameError, YawSource, fit_tissue_frame};
pub use tolerance::{Bound, Check, Tolerances, all_passed};
pub use touch::{SurfaceTouch, Touch, TouchError, TouchSettings};
