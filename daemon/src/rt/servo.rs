//! The servo seam: what the loop asks of the control core each cycle (kinematics, motion
//! setpoints, the PD law). [`crate::rt::core_servo`] implements it with the control crate's
//! `ArmModel`, `MotionPlanner` and `PdController`; tests may substitute their own.

use control::frames::SurfacePoint;
use control::types::{JointState, JointTorques, Joints};

use crate::rt::fault::Fault;
use crate::rt::link::Refusal;

/// Where the robot believes the sensor is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorPose {
    /// Centre of the element line, tissue frame.
    pub centre: SurfacePoint,
    /// Insertion depth below the pivot, m.
    pub depth_m: f64,
    /// Height of the sensor centre, tissue frame (0 on the configured surface), m.
    pub height_m: f64,
}

/// One cycle's output of the servo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoStep {
    pub torques: JointTorques,
    /// The motion setpoint of the sensor centre this cycle, tissue frame.
    pub setpoint: SurfacePoint,
    /// The joint angles the PD law is steering to.
    pub setpoint_rad: Joints,
    /// The current motion has arrived and come to rest (judged from the encoders).
    pub settled: bool,
    /// The current motion's settling time ran out short of its target.
    pub shortfall: Option<control::motion::Shortfall>,
}

pub trait Servo: Send {
    /// The believed sensor pose for joint angles (encoders + fixed-pivot model).
    fn sensor_pose(&self, now_s: f64, position_rad: &Joints) -> Result<SensorPose, Fault>;

    /// Where the arm's load says the sensor centre is, with the motors applying
    /// `motor_torque_nm` at `position_rad`: `None` without a described rod, or where the
    /// reading fails (a singular gimbal).
    fn sensor_felt(&self, position_rad: &Joints, motor_torque_nm: &Joints) -> Option<SurfacePoint>;

    /// Hold exactly at the measured state: the setpoint becomes the measured pose and the
    /// controller forgets its history, so powering up never jumps.
    fn hold_here(&mut self, now_s: f64, state: &JointState) -> Result<(), Fault>;

    /// Start a straight move of the sensor centre. Refused, with nothing changed, when the
    /// target is out of reach or outside a limit.
    fn move_to(&mut self, now_s: f64, target: SurfacePoint, speed_m_s: f64) -> Result<(), Refusal>;

    /// Start a straight move of the sensor centre to a point at any height (tissue frame):
    /// the tissue-frame calibration's lifts and descents. Refused as [`Self::move_to`]; a
    /// servo without heights refuses it.
    fn move_to_point(
        &mut self,
        _now_s: f64,
        _target: nalgebra::Point3<f64>,
        _speed_m_s: f64,
    ) -> Result<(), Refusal> {
        Err(Refusal::Backend)
    }

    /// Put the tissue frame where a calibration found it. The setpoint becomes the
    /// measured pose in the new frame (`state`, while powered), so that nothing moves.
    fn set_placement(
        &mut self,
        _now_s: f64,
        _placement: control::frames::TissuePlacement,
        _state: Option<&JointState>,
    ) -> Result<(), Refusal> {
        Err(Refusal::Backend)
    }

    /// Put the pivot (incision) where a calibration found it; as [`Self::set_placement`],
    /// the setpoint becomes the measured pose through the new pivot, so that nothing moves.
    fn set_pivot(
        &mut self,
        _now_s: f64,
        _pivot: control::kinematics::PivotGeometry,
        _state: Option<&JointState>,
    ) -> Result<(), Refusal> {
        Err(Refusal::Backend)
    }

    /// Torques that steer the joints to `setpoint` in joint space, holding up the arm's own
    /// bodies only: the instrument is out of the incision, so neither the rod through the
    /// pivot nor the sensor's pose takes part (the joint stop sweep). A servo without a
    /// joint-space mode refuses.
    fn joint_step(
        &mut self,
        now_s: f64,
        _state: &JointState,
        _setpoint: &control::types::JointSetpoint,
        _dt_s: f64,
    ) -> Result<JointTorques, Fault> {
        Err(Fault::new(crate::rt::fault::FaultKind::Kinematics, now_s)
            .noting("this servo has no joint-space mode"))
    }

    /// Forget the PD law's history before powering up in joint space.
    fn joint_reset(&mut self) {}

    /// Come to rest as soon as the motion limits allow.
    fn hold(&mut self, now_s: f64);

    /// Torques for this cycle. Called only while the arm is powered.
    fn step(&mut self, now_s: f64, state: &JointState, dt_s: f64) -> Result<ServoStep, Fault>;
}
