//! The composed map: Phantom joints <-> the sensor centre in the tissue frame.
//!
//! joints --[phantom]--> gimbal G --[pivot]--> rod tip T --[placement]--> tissue frame,
//! then plus the sensor offset: the vector from T to the centre of the element line. The
//! instrument cannot roll and the sensor is pinned to lie flat, so that offset is the same
//! tissue-frame vector in every pose. Every step is guarded (reach, base-axis singularity,
//! joint and coupling limits, depth range, gimbal or tip on the pivot); every failure is a
//! [`KinematicsError`].

use nalgebra::{Matrix3, Point3, Vector3};

use super::error::KinematicsError;
use super::params::{JointLimits, PhantomGeometry, PivotGeometry};
use super::rod_load::{RodAt, RodMechanics};
use super::{phantom, pivot};
use crate::frames::{SurfacePoint, Tip, TissuePlacement};
use crate::types::{JointSetpoint, Joints};

/// Joint rates are refused where the smallest singular value of d sensor / d q falls below
/// this: at the motion layer's top speeds (a few cm/s) it caps joint rates at a few rad/s.
/// The default workspace stays above 0.1 m/rad.
pub const MIN_SENSOR_GAIN_M_PER_RAD: f64 = 0.01;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmModel {
    phantom: PhantomGeometry,
    limits: JointLimits,
    pivot: PivotGeometry,
    placement: TissuePlacement,
    sensor_offset_m: Vector3<f64>,
    base_to_tissue: Matrix3<f64>,
}

fn require(ok: bool, what: &'static str) -> Result<(), KinematicsError> {
    if ok {
        Ok(())
    } else {
        Err(KinematicsError::InvalidGeometry { what })
    }
}

fn all_finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

impl ArmModel {
    /// Check the geometry and build the model. Refuses anything a real arm cannot have.
    pub fn new(
        phantom: PhantomGeometry,
        limits: JointLimits,
        pivot: PivotGeometry,
        placement: TissuePlacement,
        sensor_offset_m: [f64; 3],
    ) -> Result<Self, KinematicsError> {
        use std::f64::consts::FRAC_PI_2;
        require(
            phantom.l1_m.is_finite() && phantom.l1_m > 0.0,
            "phantom.l1_m must be positive",
        )?;
        require(
            phantom.l2_m.is_finite() && phantom.l2_m > 0.0,
            "phantom.l2_m must be positive",
        )?;
        require(
            all_finite(&limits.min_rad) && all_finite(&limits.max_rad),
            "joint limits must be finite",
        )?;
        require(
            (0..3).all(|i| limits.min_rad[i] < limits.max_rad[i]),
            "each joint's min_rad must be below its max_rad",
        )?;
        require(
            limits.coupling_min_rad < limits.coupling_max_rad,
            "coupling_min_rad must be below coupling_max_rad",
        )?;
        require(
            limits.coupling_min_rad >= -FRAC_PI_2 && limits.coupling_max_rad <= FRAC_PI_2,
            "the coupling range must lie within the elbow-up branch, −π/2..π/2",
        )?;
        require(
            pivot.rod_length_m.is_finite() && pivot.rod_length_m > 0.0,
            "pivot.rod_length_m must be positive",
        )?;
        require(
            all_finite(&pivot.pivot_in_base_m),
            "pivot.pivot_in_base_m must be finite",
        )?;
        require(
            pivot.min_depth_m > 0.0
                && pivot.min_depth_m < pivot.max_depth_m
                && pivot.max_depth_m < pivot.rod_length_m,
            "need 0 < min_depth_m < max_depth_m < rod_length_m",
        )?;
        require(
            all_finite(&placement.origin_in_base_m) && placement.yaw_rad.is_finite(),
            "tissue placement must be finite",
        )?;
        require(
            all_finite(&sensor_offset_m),
            "sensor_offset_m must be finite",
        )?;
        let base_to_tissue = Matrix3::from_columns(&[
            placement.direction_to_tissue(&Vector3::x()),
            placement.direction_to_tissue(&Vector3::y()),
            placement.direction_to_tissue(&Vector3::z()),
        ]);
        Ok(Self {
            phantom,
            limits,
            pivot,
            placement,
            sensor_offset_m: Vector3::from(sensor_offset_m),
            base_to_tissue,
        })
    }

    /// The same arm with its pivot elsewhere (a pivot calibration).
    pub fn with_pivot(&self, pivot: PivotGeometry) -> Result<Self, KinematicsError> {
        let offset = self.sensor_offset_m;
        Self::new(
            self.phantom,
            self.limits,
            pivot,
            self.placement,
            [offset.x, offset.y, offset.z],
        )
    }

    /// The same arm over a tissue frame placed elsewhere (a tissue-frame calibration).
    pub fn with_placement(&self, placement: TissuePlacement) -> Result<Self, KinematicsError> {
        let offset = self.sensor_offset_m;
        Self::new(
            self.phantom,
            self.limits,
            self.pivot,
            placement,
            [offset.x, offset.y, offset.z],
        )
    }

    pub fn phantom(&self) -> &PhantomGeometry {
        &self.phantom
    }

    pub fn limits(&self) -> &JointLimits {
        &self.limits
    }

    pub fn pivot(&self) -> &PivotGeometry {
        &self.pivot
    }

    pub fn placement(&self) -> &TissuePlacement {
        &self.placement
    }

    pub fn sensor_offset_m(&self) -> Vector3<f64> {
        self.sensor_offset_m
    }

    /// The sensor centre (tissue frame) for joint angles. Joint limits are not applied (a
    /// measurement is what it is); the depth range and pivot guards are.
    pub fn sensor_from_joints(&self, q: &Joints) -> Result<Point3<f64>, KinematicsError> {
        let gimbal = phantom::forward(&self.phantom, q)?;
        let tip = pivot::tip_from_gimbal(&self.pivot, &gimbal)?;
        Ok(self.placement.to_tissue(&tip.0) + self.sensor_offset_m)
    }

    /// Where the sensor centre is over the tissue surface (its `x`, `z`), for the tracker.
    pub fn surface_point(&self, q: &Joints) -> Result<SurfacePoint, KinematicsError> {
        let s = self.sensor_from_joints(q)?;
        Ok(SurfacePoint::new(s.x, s.z))
    }

    /// The rod tip (robot base frame) that puts the sensor centre at `sensor` (tissue).
    pub fn tip_for_sensor(&self, sensor: &Point3<f64>) -> Tip {
        Tip(self.placement.to_base(&(sensor - self.sensor_offset_m)))
    }

    /// Joint angles that put the sensor centre at `sensor` (tissue frame), with every guard
    /// and limit applied.
    pub fn joints_for_sensor(&self, sensor: &Point3<f64>) -> Result<Joints, KinematicsError> {
        if !sensor.iter().all(|v| v.is_finite()) {
            return Err(KinematicsError::NonFinite {
                what: "sensor position",
            });
        }
        let gimbal = pivot::gimbal_from_tip(&self.pivot, &self.tip_for_sensor(sensor))?;
        let q = phantom::inverse(&self.phantom, &gimbal)?;
        phantom::check_limits(&self.limits, &q)?;
        Ok(q)
    }

    /// d sensor / d q in the tissue frame (rows x, y, z; columns θ1, θ2, θ3), m/rad.
    pub fn sensor_jacobian(&self, q: &Joints) -> Result<Matrix3<f64>, KinematicsError> {
        let gimbal = phantom::forward(&self.phantom, q)?;
        let d_gimbal = phantom::jacobian(&self.phantom, q)?;
        let d_tip = pivot::tip_jacobian(&self.pivot, &gimbal)?;
        Ok(self.base_to_tissue * d_tip * d_gimbal)
    }

    /// Joint positions and rates that put the sensor centre at `position` moving at
    /// `velocity` (both tissue frame). Refuses near-singular poses rather than answer with
    /// huge rates.
    pub fn joint_setpoint(
        &self,
        position: &Point3<f64>,
        velocity: &Vector3<f64>,
    ) -> Result<JointSetpoint, KinematicsError> {
        if !velocity.iter().all(|v| v.is_finite()) {
            return Err(KinematicsError::NonFinite {
                what: "sensor velocity",
            });
        }
        let q = self.joints_for_sensor(position)?;
        let j = self.sensor_jacobian(&q)?;
        let sigma_min = j.singular_values().min();
        if sigma_min.is_nan() || sigma_min < MIN_SENSOR_GAIN_M_PER_RAD {
            return Err(KinematicsError::NearSingular {
                sigma_min_m_per_rad: sigma_min,
                limit_m_per_rad: MIN_SENSOR_GAIN_M_PER_RAD,
            });
        }
        let rates = j.lu().solve(velocity).ok_or(KinematicsError::Singular {
            what: "sensor Jacobian",
        })?;
        let setpoint = JointSetpoint {
            position_rad: q,
            velocity_rad_s: [rates.x, rates.y, rates.z],
        };
        if !setpoint.is_finite() {
            return Err(KinematicsError::NonFinite {
                what: "joint setpoint",
            });
        }
        Ok(setpoint)
    }

    /// The rod's pose for joint angles, for [`RodMechanics`] (robot base frame).
    pub fn rod_at(&self, q: &Joints) -> Result<RodAt, KinematicsError> {
        let pose = pivot::rod_pose(&self.pivot, &phantom::forward(&self.phantom, q)?)?;
        Ok(RodAt {
            axis: pose.axis.into_inner(),
            gimbal_to_pivot_m: self.pivot.rod_length_m - pose.depth_m,
            length_m: self.pivot.rod_length_m,
        })
    }

    /// Where the sensor centre truly is (tissue frame) when the rod pushes on the arm with
    /// joint torques `rod_torque_nm` (the motors' torque less the arm's own gravity, negated,
    /// at rest), for a rod of `mechanics`: the rigid map plus the rod's deflection
    /// ([`super::rod_load`]). Also returns the tip load it read, tissue frame, N.
    pub fn sensor_under_load(
        &self,
        q: &Joints,
        rod_torque_nm: &Joints,
        mechanics: &RodMechanics,
        gravity_m_s2: f64,
    ) -> Result<(Point3<f64>, Vector3<f64>), KinematicsError> {
        let rigid = self.sensor_from_joints(q)?;
        let rod = self.rod_at(q)?;
        let j = phantom::jacobian(&self.phantom, q)?;
        let tau = Vector3::new(rod_torque_nm[0], rod_torque_nm[1], rod_torque_nm[2]);
        let f_gimbal = j
            .transpose()
            .lu()
            .solve(&tau)
            .ok_or(KinematicsError::Singular {
                what: "gimbal Jacobian",
            })?;
        let load = mechanics
            .tip_load_n(&rod, &f_gimbal, gravity_m_s2)
            .map_err(|_| KinematicsError::NonFinite { what: "tip load" })?;
        let deflection = mechanics.tip_deflection_m(&rod, &load, gravity_m_s2);
        Ok((
            rigid + self.base_to_tissue * deflection,
            self.base_to_tissue * load,
        ))
    }

    /// Where the sensor centre is by what the arm feels, on the tissue surface: the motors'
    /// torque `motor_torque_nm` less what holds the arm's own bodies up
    /// (`body_gravity_nm`) balances the rod's push on the gimbal
    /// ([`Self::sensor_under_load`]). The lockstep runner and the daemon both read it here.
    pub fn sensor_felt(
        &self,
        q: &Joints,
        motor_torque_nm: &Joints,
        body_gravity_nm: &Joints,
        mechanics: &RodMechanics,
        gravity_m_s2: f64,
    ) -> Result<SurfacePoint, KinematicsError> {
        let rod_torque = [0, 1, 2].map(|j| body_gravity_nm[j] - motor_torque_nm[j]);
        let (p, _) = self.sensor_under_load(q, &rod_torque, mechanics, gravity_m_s2)?;
        let felt = SurfacePoint::new(p.x, p.z);
        if felt.is_finite() {
            Ok(felt)
        } else {
            Err(KinematicsError::NonFinite {
                what: "sensor under load",
            })
        }
    }

    /// Insertion depth of the rod tip below the pivot for joint angles (no range guard).
    pub fn depth_m(&self, q: &Joints) -> Result<f64, KinematicsError> {
        pivot::depth_m(&self.pivot, &phantom::forward(&self.phantom, q)?)
    }

    /// Diagnostics: gimbal motion per unit lateral tip motion, (L − d)/d, at joint angles `q`.
    pub fn lever_ratio(&self, q: &Joints) -> Result<f64, KinematicsError> {
        pivot::lever_ratio(&self.pivot, self.depth_m(q)?)
    }
}

#[cfg(test)]
#[path = "arm_tests.rs"]
pub(crate) mod tests;
