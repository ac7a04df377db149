//! The servo built from the control core: `ArmModel` (joints <-> sensor centre),
//! `MotionPlanner` (straight-line setpoints at the contact height), `PdController` with
//! `ArmGravity` (the arm and the configured instrument). Every control-core error becomes a named fault with its numbers.

use config::Config;
use control::frames::SurfacePoint;
use control::kinematics::{ArmModel, KinematicsError, RodMechanics};
use control::motion::{Arrival, MotionPlanner};
use control::pd::gravity::{ArmGravity, PhantomGravity};
use control::pd::{GravityModel, PdController, PdFault};
use control::types::{JointState, Joints};
use nalgebra::{Point3, Vector3};

use crate::rt::fault::{Fault, FaultKind};
use crate::rt::link::Refusal;
use crate::rt::servo::{SensorPose, Servo, ServoStep};
use crate::supervisor::TrackerFactory;

#[derive(Debug, Clone)]
pub struct CoreServo {
    arm: ArmModel,
    planner: MotionPlanner,
    pd: PdController,
    gravity: ArmGravity,
    /// The config's rod, the arm's own bodies and g: what reads the sensor's place from the
    /// arm's load.
    rod: Option<(RodMechanics, PhantomGravity, f64)>,
    /// The arm's own bodies: all the joint-space mode holds up (the instrument out).
    bodies: PhantomGravity,
}

pub fn build(c: &Config) -> Result<Box<dyn Servo>, String> {
    Ok(Box::new(CoreServo::new(c)?))
}

impl CoreServo {
    /// Use `arm` (a calibration's tissue frame or pivot) from now on. Powered (`state`), the
    /// setpoint becomes the measured pose through it, so that nothing moves; the old model
    /// stays if the arm cannot hold there.
    fn replace_arm(
        &mut self,
        now_s: f64,
        arm: Result<ArmModel, KinematicsError>,
        state: Option<&JointState>,
    ) -> Result<(), Refusal> {
        let arm = arm.map_err(|e| Refusal::Unreachable(kinematic_fault(&e, now_s).kind))?;
        let before = std::mem::replace(&mut self.arm, arm);
        match state {
            Some(s) => self.hold_here(now_s, s).map_err(|f| {
                self.arm = before;
                Refusal::Unreachable(f.kind)
            }),
            None => {
                // Unpowered: the next enable holds where the arm is, in the new model.
                self.planner.clear();
                Ok(())
            }
        }
    }

    pub fn new(c: &Config) -> Result<Self, String> {
        Ok(Self {
            arm: c
                .robot
                .arm_model()
                .map_err(|e| format!("robot geometry: {e}"))?,
            planner: MotionPlanner::new(c.control.motion)
                .map_err(|e| format!("control.motion: {e}"))?,
            pd: PdController::new(c.control.pd).map_err(|e| format!("control.pd: {e}"))?,
            // The arm's bodies and the instrument's weight beyond its contact load.
            gravity: ArmGravity::new(
                &c.robot.link_masses,
                &c.robot.phantom,
                &c.robot.pivot,
                c.instrument.as_ref(),
            ),
            bodies: PhantomGravity::new(&c.robot.link_masses),
            rod: c.rod.map(|r| {
                (
                    r,
                    PhantomGravity::new(&c.robot.link_masses),
                    c.robot.link_masses.gravity_m_s2,
                )
            }),
        })
    }
}

/// A kinematic failure as a fault kind with its value and limit.
pub fn kinematic_fault(e: &KinematicsError, t_s: f64) -> Fault {
    match *e {
        KinematicsError::JointLimit {
            joint,
            value_rad,
            min_rad,
            max_rad,
        } => Fault::new(FaultKind::JointLimit, t_s)
            .on_axis(joint)
            .with_values(
                value_rad,
                if value_rad < min_rad {
                    min_rad
                } else {
                    max_rad
                },
            ),
        KinematicsError::CouplingLimit {
            value_rad,
            min_rad,
            max_rad,
        } => Fault::new(FaultKind::CouplingLimit, t_s).with_values(
            value_rad,
            if value_rad < min_rad {
                min_rad
            } else {
                max_rad
            },
        ),
        KinematicsError::DepthOutOfRange {
            depth_m,
            min_m,
            max_m,
        } => Fault::new(FaultKind::Depth, t_s)
            .with_values(depth_m, if depth_m < min_m { min_m } else { max_m }),
        KinematicsError::OutOfReach {
            distance_m, max_m, ..
        } => Fault::new(FaultKind::Workspace, t_s)
            .with_values(distance_m, max_m)
            .noting("out of the arm's reach"),
        KinematicsError::NearSingular {
            sigma_min_m_per_rad,
            limit_m_per_rad,
        } => Fault::new(FaultKind::Kinematics, t_s)
            .with_values(sigma_min_m_per_rad, limit_m_per_rad)
            .noting("near a singular pose"),
        KinematicsError::AtPivot { what, distance_m } => Fault::new(FaultKind::Depth, t_s)
            .with_values(distance_m, 0.0)
            .noting(what),
        KinematicsError::Singular { what }
        | KinematicsError::NonFinite { what }
        | KinematicsError::InvalidGeometry { what } => {
            Fault::new(FaultKind::Kinematics, t_s).noting(what)
        }
        #[allow(unreachable_patterns)]
        _ => Fault::new(FaultKind::Kinematics, t_s),
    }
}

fn pd_fault(e: &PdFault, t_s: f64) -> Fault {
    match *e {
        PdFault::TrackingError {
            joint,
            error_rad,
            limit_rad,
        } => Fault::new(FaultKind::TrackingError, t_s)
            .on_axis(joint)
            .with_values(error_rad, limit_rad),
        PdFault::NonFinite { what } => Fault::new(FaultKind::NonFiniteCommand, t_s).noting(what),
        PdFault::InvalidTimeStep { dt_s } => Fault::new(FaultKind::NonFiniteCommand, t_s)
            .with_values(dt_s, 0.0)
            .noting("invalid time step"),
        PdFault::InvalidParams { what } => Fault::new(FaultKind::Kinematics, t_s).noting(what),
        #[allow(unreachable_patterns)]
        _ => Fault::new(FaultKind::NonFiniteCommand, t_s),
    }
}

impl CoreServo {
    fn believed_speed(&self, state: &JointState) -> Result<f64, KinematicsError> {
        let j = self.arm.sensor_jacobian(&state.position_rad)?;
        let v = j * Vector3::from(state.velocity_rad_s);
        Ok(v.x.hypot(v.z))
    }

    /// Where the setpoint is now (or, before any, where the sensor is).
    fn setpoint_point(&self, now_s: f64) -> Option<Point3<f64>> {
        self.planner.setpoint(now_s).map(|(p, _)| p)
    }
}

impl Servo for CoreServo {
    fn sensor_pose(&self, now_s: f64, q: &Joints) -> Result<SensorPose, Fault> {
        let p = self
            .arm
            .sensor_from_joints(q)
            .map_err(|e| kinematic_fault(&e, now_s))?;
        let depth_m = self
            .arm
            .depth_m(q)
            .map_err(|e| kinematic_fault(&e, now_s))?;
        Ok(SensorPose {
            centre: SurfacePoint::new(p.x, p.z),
            depth_m,
            height_m: p.y,
        })
    }

    fn sensor_felt(&self, q: &Joints, motor_torque_nm: &Joints) -> Option<SurfacePoint> {
        let (rod, bodies, g) = self.rod.as_ref()?;
        self.arm
            .sensor_felt(q, motor_torque_nm, &bodies.torque_nm(q), rod, *g)
            .ok()
    }

    fn hold_here(&mut self, now_s: f64, state: &JointState) -> Result<(), Fault> {
        let p = self
            .arm
            .sensor_from_joints(&state.position_rad)
            .map_err(|e| kinematic_fault(&e, now_s))?;
        self.planner
            .hold_point(p, now_s)
            .map_err(|_| Fault::new(FaultKind::Kinematics, now_s).noting("hold point"))?;
        self.pd.reset();
        Ok(())
    }

    fn move_to(&mut self, now_s: f64, target: SurfacePoint, speed_m_s: f64) -> Result<(), Refusal> {
        let end = self.planner.contact_point(&target);
        self.move_to_point(now_s, end, speed_m_s)
    }

    fn move_to_point(
        &mut self,
        now_s: f64,
        target: Point3<f64>,
        speed_m_s: f64,
    ) -> Result<(), Refusal> {
        let Some(from) = self.setpoint_point(now_s) else {
            return Err(Refusal::NotEnabled);
        };
        // The end must be reachable with every guard; so must the middle of the line (the
        // workspace is convex enough that this catches a line through the pivot's cone).
        let mid = Point3::from((from.coords + target.coords) / 2.0);
        for p in [target, mid] {
            if let Err(e) = self.arm.joints_for_sensor(&p) {
                return Err(Refusal::Unreachable(kinematic_fault(&e, now_s).kind));
            }
        }
        self.planner
            .start_to_point(from, target, speed_m_s, now_s)
            .map_err(|_| Refusal::Unreachable(FaultKind::NonFiniteCommand))
    }

    fn set_placement(
        &mut self,
        now_s: f64,
        placement: control::frames::TissuePlacement,
        state: Option<&JointState>,
    ) -> Result<(), Refusal> {
        let arm = self.arm.with_placement(placement);
        self.replace_arm(now_s, arm, state)
    }

    fn set_pivot(
        &mut self,
        now_s: f64,
        pivot: control::kinematics::PivotGeometry,
        state: Option<&JointState>,
    ) -> Result<(), Refusal> {
        let arm = self.arm.with_pivot(pivot);
        self.replace_arm(now_s, arm, state)?;
        // The instrument's excess weight reaches the joints through the pivot too.
        self.gravity = self.gravity.with_pivot(&pivot);
        Ok(())
    }

    fn joint_step(
        &mut self,
        now_s: f64,
        state: &JointState,
        setpoint: &control::types::JointSetpoint,
        dt_s: f64,
    ) -> Result<control::types::JointTorques, Fault> {
        let g = self.bodies.torque_nm(&state.position_rad);
        self.pd
            .step(setpoint, state, &g, dt_s)
            .map_err(|e| pd_fault(&e, now_s))
    }

    fn joint_reset(&mut self) {
        self.planner.clear();
        self.pd.reset();
    }

    fn hold(&mut self, now_s: f64) {
        if let Some(p) = self.setpoint_point(now_s) {
            let _ = self.planner.hold_point(p, now_s);
        }
    }

    fn step(&mut self, now_s: f64, state: &JointState, dt_s: f64) -> Result<ServoStep, Fault> {
        let believed = self
            .arm
            .surface_point(&state.position_rad)
            .map_err(|e| kinematic_fault(&e, now_s))?;
        let speed = self
            .believed_speed(state)
            .map_err(|e| kinematic_fault(&e, now_s))?;
        // Judged from the encoders through the kinematics, never from the setpoint; the
        // first verdict of a move is kept. Until then the outer loop trims a stalled arm.
        let arrival = self.planner.observe(believed, speed, now_s);
        let (p, v) = self
            .planner
            .setpoint(now_s)
            .ok_or_else(|| Fault::new(FaultKind::Kinematics, now_s).noting("no motion setpoint"))?;
        let js = self
            .arm
            .joint_setpoint(&p, &v)
            .map_err(|e| kinematic_fault(&e, now_s))?;
        let g = self.gravity.torque_nm(&state.position_rad);
        let torques = self
            .pd
            .step(&js, state, &g, dt_s)
            .map_err(|e| pd_fault(&e, now_s))?;
        Ok(ServoStep {
            torques,
            setpoint: SurfacePoint::new(p.x, p.z),
            setpoint_rad: js.position_rad,
            settled: arrival == Arrival::Arrived,
            shortfall: match arrival {
                Arrival::StoppedShort(s) => Some(s),
                Arrival::Moving | Arrival::Arrived => None,
            },
        })
    }
}

/// A fresh tracker per trial, by the configured name, for the array as calibrated then. The
/// name and parameters are checked once here (with the configured array), so a bad config
/// fails at start-up rather than at the first mark.
pub fn tracker_factory(c: &Config) -> Result<TrackerFactory, String> {
    let name = c.tracker.name.clone();
    let params = c.tracker.params;
    let sensor = c.sensor;
    control::tracker::build(&name, &params, &sensor).map_err(|e| format!("tracker: {e}"))?;
    Ok(Box::new(move |sensor: &control::sensor::ArrayGeometry| {
        control::tracker::build(&name, &params, sensor).map_err(|e| e.to_string())
    }))
}
