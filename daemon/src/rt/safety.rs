//! The safety layer run on every cycle, independent of the servo's own checks: data
//! freshness and finiteness, joint, coupling, depth and workspace limits, the distance
//! between commanded and believed sensor, contact force, and a last clamp of every torque
//! command (magnitude and rate) after a finite check.

use config::Config;
use control::kinematics::JointLimits;
use control::types::{JOINTS, JointState, JointTorques};

use crate::rt::fault::{Fault, FaultKind};
use crate::rt::servo::{SensorPose, ServoStep};

#[derive(Debug, Clone)]
pub struct SafetyLimits {
    pub joint_stale_s: f64,
    pub tactile_stale_s: f64,
    pub contact_force_max_n: f64,
    pub joint_limits: JointLimits,
    pub min_depth_m: f64,
    pub max_depth_m: f64,
    pub workspace_x_m: [f64; 2],
    pub workspace_z_m: [f64; 2],
    pub max_sensor_error_m: f64,
    pub torque_limit_nm: [f64; JOINTS],
    pub torque_rate_limit_nm_per_s: [f64; JOINTS],
}

impl SafetyLimits {
    pub fn from_config(c: &Config) -> Self {
        Self {
            joint_stale_s: c.safety.joint_stale_s,
            tactile_stale_s: c.safety.tactile_stale_s,
            contact_force_max_n: c.safety.contact_force_max_n,
            joint_limits: c.robot.joint_limits,
            min_depth_m: c.robot.pivot.min_depth_m,
            max_depth_m: c.robot.pivot.max_depth_m,
            workspace_x_m: c.safety.workspace_x_m,
            workspace_z_m: c.safety.workspace_z_m,
            max_sensor_error_m: c.safety.max_sensor_error_m,
            torque_limit_nm: c.control.pd.torque_limit_nm,
            torque_rate_limit_nm_per_s: c.control.pd.torque_rate_limit_nm_per_s,
        }
    }

    /// True if a tissue-frame point lies in the allowed region.
    pub fn in_workspace(&self, x_m: f64, z_m: f64) -> bool {
        x_m.is_finite()
            && z_m.is_finite()
            && (self.workspace_x_m[0]..=self.workspace_x_m[1]).contains(&x_m)
            && (self.workspace_z_m[0]..=self.workspace_z_m[1]).contains(&z_m)
    }
}

/// `a <= b`, false when either is NaN: a NaN never passes a check.
fn at_most(a: f64, b: f64) -> bool {
    matches!(
        a.partial_cmp(&b),
        Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
    )
}

/// Joint data: finite and fresh.
pub fn check_joint_data(l: &SafetyLimits, now_s: f64, s: &JointState) -> Result<(), Fault> {
    if !s.is_finite() {
        return Err(Fault::new(FaultKind::NonFiniteJoints, now_s));
    }
    let age = now_s - s.t_s;
    if !at_most(age, l.joint_stale_s) {
        return Err(Fault::new(FaultKind::JointStale, now_s).with_values(age, l.joint_stale_s));
    }
    Ok(())
}

/// Joint range and the θ2/θ3 coupling.
pub fn check_joint_limits(l: &SafetyLimits, now_s: f64, s: &JointState) -> Result<(), Fault> {
    check_joints_within(&l.joint_limits, now_s, s)
}

/// Joint range and the θ2/θ3 coupling against `j` (the configured limits, or the joint
/// sweep's, widened past the stop it sweeps).
pub fn check_joints_within(j: &JointLimits, now_s: f64, s: &JointState) -> Result<(), Fault> {
    for i in 0..JOINTS {
        let q = s.position_rad[i];
        if q < j.min_rad[i] {
            return Err(Fault::new(FaultKind::JointLimit, now_s)
                .on_axis(i)
                .with_values(q, j.min_rad[i]));
        }
        if q > j.max_rad[i] {
            return Err(Fault::new(FaultKind::JointLimit, now_s)
                .on_axis(i)
                .with_values(q, j.max_rad[i]));
        }
    }
    let c = s.position_rad[2] - s.position_rad[1];
    if c < j.coupling_min_rad {
        return Err(Fault::new(FaultKind::CouplingLimit, now_s).with_values(c, j.coupling_min_rad));
    }
    if c > j.coupling_max_rad {
        return Err(Fault::new(FaultKind::CouplingLimit, now_s).with_values(c, j.coupling_max_rad));
    }
    Ok(())
}

/// Depth below the pivot, and the believed sensor against its setpoint and the workspace.
pub fn check_pose(
    l: &SafetyLimits,
    now_s: f64,
    pose: &SensorPose,
    step: &ServoStep,
) -> Result<(), Fault> {
    if !at_most(l.min_depth_m, pose.depth_m) {
        return Err(Fault::new(FaultKind::Depth, now_s).with_values(pose.depth_m, l.min_depth_m));
    }
    if !at_most(pose.depth_m, l.max_depth_m) {
        return Err(Fault::new(FaultKind::Depth, now_s).with_values(pose.depth_m, l.max_depth_m));
    }
    let sp = step.setpoint;
    if !l.in_workspace(sp.x_m, sp.z_m) {
        let (value, limit) = if !(l.workspace_x_m[0]..=l.workspace_x_m[1]).contains(&sp.x_m) {
            (sp.x_m, nearest(sp.x_m, l.workspace_x_m))
        } else {
            (sp.z_m, nearest(sp.z_m, l.workspace_z_m))
        };
        return Err(Fault::new(FaultKind::Workspace, now_s).with_values(value, limit));
    }
    let err = pose.centre.distance_to(&sp);
    if !at_most(err, l.max_sensor_error_m) {
        return Err(
            Fault::new(FaultKind::SensorError, now_s).with_values(err, l.max_sensor_error_m)
        );
    }
    Ok(())
}

fn nearest(v: f64, r: [f64; 2]) -> f64 {
    if (v - r[0]).abs() < (v - r[1]).abs() {
        r[0]
    } else {
        r[1]
    }
}

/// Tactile freshness and contact force (judged on the newest frame; NaN time = never seen).
pub fn check_tactile(
    l: &SafetyLimits,
    now_s: f64,
    newest_t_s: f64,
    contact_n: f64,
) -> Result<(), Fault> {
    let age = now_s - newest_t_s;
    if !at_most(age, l.tactile_stale_s) {
        return Err(Fault::new(FaultKind::TactileStale, now_s).with_values(age, l.tactile_stale_s));
    }
    if !at_most(contact_n, l.contact_force_max_n) {
        return Err(Fault::new(FaultKind::ContactForce, now_s)
            .with_values(contact_n, l.contact_force_max_n));
    }
    Ok(())
}

/// The last word on every torque command: finite, within magnitude, within rate of change.
#[derive(Debug, Clone)]
pub struct TorqueGuard {
    previous: JointTorques,
}

impl Default for TorqueGuard {
    fn default() -> Self {
        Self::new()
    }
}

impl TorqueGuard {
    pub fn new() -> Self {
        Self {
            previous: JointTorques::ZERO,
        }
    }

    /// Forget history: the next command ramps from zero.
    pub fn reset(&mut self) {
        self.previous = JointTorques::ZERO;
    }

    pub fn apply(
        &mut self,
        l: &SafetyLimits,
        now_s: f64,
        dt_s: f64,
        command: &JointTorques,
    ) -> Result<JointTorques, Fault> {
        if !command.is_finite() {
            return Err(Fault::new(FaultKind::NonFiniteCommand, now_s));
        }
        let mut out = JointTorques::ZERO;
        for i in 0..JOINTS {
            let lim = l.torque_limit_nm[i];
            let step = l.torque_rate_limit_nm_per_s[i] * dt_s.max(0.0);
            let prev = self.previous.torque_nm[i];
            let t = command.torque_nm[i].clamp(-lim, lim);
            out.torque_nm[i] = t.clamp(prev - step, prev + step);
        }
        if !out.is_finite() {
            return Err(Fault::new(FaultKind::NonFiniteCommand, now_s));
        }
        self.previous = out;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use control::frames::SurfacePoint;

    fn limits() -> SafetyLimits {
        let c: Config = config::load_str::<Config>(
            config::shipped::SIM_CONFIG.0,
            config::shipped::SIM_CONFIG.1,
        )
        .expect("shipped config");
        SafetyLimits::from_config(&c)
    }

    fn state(q: [f64; 3], t_s: f64) -> JointState {
        JointState {
            t_s,
            position_rad: q,
            velocity_rad_s: [0.0; 3],
        }
    }

    #[test]
    fn stale_and_non_finite_joint_data_fault() {
        let l = limits();
        assert!(check_joint_data(&l, 1.0, &state([0.0; 3], 1.0)).is_ok());
        let f = check_joint_data(&l, 1.0, &state([0.0; 3], 0.5)).expect_err("stale");
        assert_eq!(f.kind, FaultKind::JointStale);
        assert!((f.value - 0.5).abs() < 1e-12);
        let f = check_joint_data(&l, 1.0, &state([f64::NAN, 0.0, 0.0], 1.0)).expect_err("nan");
        assert_eq!(f.kind, FaultKind::NonFiniteJoints);
    }

    #[test]
    fn joint_and_coupling_limits_name_the_axis() {
        let l = limits();
        let mut q = [0.0, 0.2, 0.3];
        assert!(check_joint_limits(&l, 0.0, &state(q, 0.0)).is_ok());
        q[1] = l.joint_limits.max_rad[1] + 0.01;
        let f = check_joint_limits(&l, 0.0, &state(q, 0.0)).expect_err("limit");
        assert_eq!((f.kind, f.axis), (FaultKind::JointLimit, Some(1)));
        let q = [0.0, 1.0, 1.0 + l.joint_limits.coupling_max_rad + 0.1];
        let q = [q[0], q[1].min(l.joint_limits.max_rad[1]), q[2]];
        let f = check_joint_limits(&l, 0.0, &state(q, 0.0)).expect_err("coupling or limit");
        assert!(matches!(
            f.kind,
            FaultKind::CouplingLimit | FaultKind::JointLimit
        ));
    }

    #[test]
    fn tactile_never_seen_is_stale_and_force_is_bounded() {
        let l = limits();
        let f = check_tactile(&l, 1.0, f64::NAN, 0.0).expect_err("never seen");
        assert_eq!(f.kind, FaultKind::TactileStale);
        assert!(check_tactile(&l, 1.0, 0.95, 1.0).is_ok());
        let f = check_tactile(&l, 1.0, 0.95, l.contact_force_max_n + 1.0).expect_err("force");
        assert_eq!(f.kind, FaultKind::ContactForce);
        let f = check_tactile(&l, 1.0, 0.95, f64::NAN).expect_err("nan force");
        assert_eq!(f.kind, FaultKind::ContactForce);
    }

    #[test]
    fn pose_checks_depth_workspace_and_sensor_error() {
        let l = limits();
        let pose = SensorPose {
            centre: SurfacePoint::new(0.0, 0.0),
            depth_m: (l.min_depth_m + l.max_depth_m) / 2.0,
            height_m: -0.003,
        };
        let mut step = ServoStep {
            torques: JointTorques::ZERO,
            setpoint: SurfacePoint::new(0.001, 0.0),
            setpoint_rad: [0.0; 3],
            settled: true,
            shortfall: None,
        };
        assert!(check_pose(&l, 0.0, &pose, &step).is_ok());
        step.setpoint = SurfacePoint::new(l.max_sensor_error_m * 2.0, 0.0);
        assert_eq!(
            check_pose(&l, 0.0, &pose, &step).expect_err("error").kind,
            FaultKind::SensorError
        );
        step.setpoint = SurfacePoint::new(l.workspace_x_m[1] + 0.01, 0.0);
        assert_eq!(
            check_pose(&l, 0.0, &pose, &step).expect_err("ws").kind,
            FaultKind::Workspace
        );
        let deep = SensorPose {
            depth_m: l.max_depth_m + 0.01,
            ..pose
        };
        assert_eq!(
            check_pose(&l, 0.0, &deep, &step).expect_err("depth").kind,
            FaultKind::Depth
        );
    }

    #[test]
    fn torque_guard_clamps_magnitude_and_rate_and_refuses_nan() {
        let l = limits();
        let mut g = TorqueGuard::new();
        let dt = 0.001;
        let big = JointTorques {
            torque_nm: [10.0, -10.0, 0.0],
        };
        let out = g.apply(&l, 0.0, dt, &big).expect("finite");
        // First step from zero: limited by the rate, not the magnitude.
        let step = l.torque_rate_limit_nm_per_s[0] * dt;
        assert!((out.torque_nm[0] - step).abs() < 1e-12);
        assert!((out.torque_nm[1] + l.torque_rate_limit_nm_per_s[1] * dt).abs() < 1e-12);
        for _ in 0..10_000 {
            g.apply(&l, 0.0, dt, &big).expect("finite");
        }
        let out = g.apply(&l, 0.0, dt, &big).expect("finite");
        assert!((out.torque_nm[0] - l.torque_limit_nm[0]).abs() < 1e-12);
        let nan = JointTorques {
            torque_nm: [f64::NAN, 0.0, 0.0],
        };
        assert_eq!(
            g.apply(&l, 0.0, dt, &nan).expect_err("nan").kind,
            FaultKind::NonFiniteCommand
        );
    }
}
