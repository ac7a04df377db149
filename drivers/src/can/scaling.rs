//! Encoder counts to joint angles and joint torques to motor torque commands.
//!
//! Joint angle `θ = direction · 2π · counts / (counts_per_rev · capstan_ratio) + zero`;
//! motor torque `τm = direction · τj / capstan_ratio`, clamped to the motor's limit, sent in
//! counts of 10 µN·m.

use config::schema::CanJoints;
use control::types::JOINTS;

use super::protocol::NM_PER_TORQUE_COUNT;

/// One joint's conversion constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointScaling {
    pub rad_per_count: f64,
    pub capstan_ratio: f64,
    pub direction: f64,
    pub zero_offset_rad: f64,
    pub max_motor_torque_nm: f64,
}

/// A torque command ready for the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MotorCommand {
    pub counts: i16,
    /// The request exceeded the motor limit and was clamped.
    pub clamped: bool,
}

impl JointScaling {
    pub fn for_joints(settings: &CanJoints) -> [JointScaling; JOINTS] {
        std::array::from_fn(|j| JointScaling {
            rad_per_count: std::f64::consts::TAU
                / (f64::from(settings.counts_per_rev[j]) * settings.capstan_ratio[j]),
            capstan_ratio: settings.capstan_ratio[j],
            direction: settings.direction[j],
            zero_offset_rad: settings.zero_offset_rad[j],
            max_motor_torque_nm: settings.max_motor_torque_nm[j],
        })
    }

    pub fn angle_rad(&self, counts: i32) -> f64 {
        self.direction * f64::from(counts) * self.rad_per_count + self.zero_offset_rad
    }

    /// The counts that read as `angle_rad` (rounded; for emulators and tests).
    pub fn counts_for(&self, angle_rad: f64) -> i32 {
        let c =
            ((angle_rad - self.zero_offset_rad) / (self.direction * self.rad_per_count)).round();
        c.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
    }

    /// The motor command for a joint torque. `None` if the torque is not finite.
    pub fn motor_command(&self, joint_torque_nm: f64) -> Option<MotorCommand> {
        if !joint_torque_nm.is_finite() {
            return None;
        }
        let motor_nm = self.direction * joint_torque_nm / self.capstan_ratio;
        let limit = self.max_motor_torque_nm;
        let clamped = motor_nm.abs() > limit;
        let motor_nm = motor_nm.clamp(-limit, limit);
        let counts = (motor_nm / NM_PER_TORQUE_COUNT)
            .round()
            .clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16;
        Some(MotorCommand { counts, clamped })
    }

    /// The joint torque a motor command applies, N·m.
    pub fn joint_torque_nm(&self, counts: i16) -> f64 {
        self.direction * f64::from(counts) * NM_PER_TORQUE_COUNT * self.capstan_ratio
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn phantom() -> [JointScaling; JOINTS] {
        JointScaling::for_joints(&CanJoints::default())
    }

    #[test]
    fn phantom_numbers() {
        let s = phantom();
        // One motor turn is 1024 counts; 13.3 motor turns (13619.2 counts) are one joint turn.
        let per_count = s[0].rad_per_count;
        assert!((s[0].angle_rad(13619) - (std::f64::consts::TAU - 0.2 * per_count)).abs() < 1e-12);
        assert!((s[0].rad_per_count - 4.6136e-4).abs() < 1e-7);
        assert!((s[1].rad_per_count - 5.4785e-4).abs() < 1e-7);
        // The continuous motor torque, 28.6 mN·m, is 0.380 N·m at joint 1 and 0.320 at 2, 3.
        let c = s[0].motor_command(0.38038).expect("finite");
        assert_eq!(
            c,
            MotorCommand {
                counts: 2860,
                clamped: false
            }
        );
        let c = s[1].motor_command(-1.0).expect("finite");
        assert_eq!(
            c,
            MotorCommand {
                counts: -2860,
                clamped: true
            }
        );
        assert!(s[2].motor_command(f64::NAN).is_none());
        assert!(s[2].motor_command(f64::INFINITY).is_none());
    }

    #[test]
    fn reversed_joint_flips_both_ways() {
        let settings = CanJoints {
            direction: [-1.0, 1.0, 1.0],
            zero_offset_rad: [0.5, 0.0, 0.0],
            ..CanJoints::default()
        };
        let s = JointScaling::for_joints(&settings)[0];
        assert!((s.angle_rad(100) - (0.5 - 100.0 * s.rad_per_count)).abs() < 1e-15);
        let c = s.motor_command(0.1).expect("finite");
        assert!(c.counts < 0);
        assert!((s.joint_torque_nm(c.counts) - 0.1).abs() < 1e-4);
    }

    proptest! {
        #[test]
        fn counts_round_trip(counts in -200_000i32..200_000, j in 0usize..3) {
            let s = phantom()[j];
            prop_assert_eq!(s.counts_for(s.angle_rad(counts)), counts);
        }

        #[test]
        fn commands_never_exceed_the_limit(t in -1e6f64..1e6, j in 0usize..3) {
            let s = phantom()[j];
            let c = s.motor_command(t).expect("finite");
            let motor = f64::from(c.counts) * NM_PER_TORQUE_COUNT;
            prop_assert!(motor.abs() <= s.max_motor_torque_nm + 0.5 * NM_PER_TORQUE_COUNT);
            if !c.clamped {
                prop_assert!((s.joint_torque_nm(c.counts) - t).abs() <= 0.5 * NM_PER_TORQUE_COUNT * s.capstan_ratio + 1e-12);
            }
        }
    }
}
