//! Named fault flags of the control loop, with the numbers that tripped them. Built in the
//! cycle without allocation; described in words only outside it.

use serde::Serialize;

/// Why the loop latched a fault (libfranka-style named flags).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// A joint angle left its configured range.
    JointLimit,
    /// θ3 − θ2 left the parallel drive's coupling range.
    CouplingLimit,
    /// The setpoint left the allowed region on the tissue surface.
    Workspace,
    /// Insertion depth below the pivot left its range.
    Depth,
    /// A joint trailed its setpoint by more than allowed.
    TrackingError,
    /// The believed sensor centre trailed the commanded one by more than allowed.
    SensorError,
    /// A computed command was not a finite number.
    NonFiniteCommand,
    /// The arm reported a non-finite joint state.
    NonFiniteJoints,
    /// No fresh joint data.
    JointStale,
    /// No fresh tactile frame while the arm is powered.
    TactileStale,
    /// A tactile frame held a non-finite force.
    NonFiniteTactile,
    /// The total contact force exceeded its bound.
    ContactForce,
    /// Too many consecutive missed deadlines on real hardware.
    Deadline,
    /// The kinematic model could not place the sensor (out of reach, near the pivot).
    Kinematics,
    /// The hardware or simulator port returned an error.
    Backend,
    /// Emergency stop requested.
    Estop,
    /// The trial recording could not be written (the supervisor names the file and error).
    RecordingFailed,
}

impl FaultKind {
    pub fn as_str(&self) -> &'static str {
        match self {
            FaultKind::JointLimit => "joint_limit",
            FaultKind::CouplingLimit => "coupling_limit",
            FaultKind::Workspace => "workspace",
            FaultKind::Depth => "depth",
            FaultKind::TrackingError => "tracking_error",
            FaultKind::SensorError => "sensor_error",
            FaultKind::NonFiniteCommand => "non_finite_command",
            FaultKind::NonFiniteJoints => "non_finite_joints",
            FaultKind::JointStale => "joint_stale",
            FaultKind::TactileStale => "tactile_stale",
            FaultKind::NonFiniteTactile => "non_finite_tactile",
            FaultKind::ContactForce => "contact_force",
            FaultKind::Deadline => "deadline",
            FaultKind::Kinematics => "kinematics",
            FaultKind::Backend => "backend",
            FaultKind::Estop => "estop",
            FaultKind::RecordingFailed => "recording_failed",
        }
    }

    fn unit(&self) -> &'static str {
        match self {
            FaultKind::JointLimit | FaultKind::CouplingLimit | FaultKind::TrackingError => "rad",
            FaultKind::Workspace | FaultKind::Depth | FaultKind::SensorError => "m",
            FaultKind::JointStale | FaultKind::TactileStale => "s",
            FaultKind::ContactForce => "N",
            FaultKind::Deadline => "cycles",
            _ => "",
        }
    }
}

/// A latched fault: what, when, and the offending value against its limit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Fault {
    pub kind: FaultKind,
    /// Daemon clock, s.
    pub t_s: f64,
    /// The joint or axis concerned, when there is one.
    pub axis: Option<u8>,
    /// The offending value and the limit it broke (NaN when not applicable).
    pub value: f64,
    pub limit: f64,
    /// A static note from the code that tripped (the backend's error text is logged apart).
    pub note: &'static str,
}

impl Fault {
    pub fn new(kind: FaultKind, t_s: f64) -> Self {
        Self {
            kind,
            t_s,
            axis: None,
            value: f64::NAN,
            limit: f64::NAN,
            note: "",
        }
    }

    pub fn with_values(mut self, value: f64, limit: f64) -> Self {
        self.value = value;
        self.limit = limit;
        self
    }

    pub fn on_axis(mut self, axis: usize) -> Self {
        self.axis = u8::try_from(axis).ok();
        self
    }

    pub fn noting(mut self, note: &'static str) -> Self {
        self.note = note;
        self
    }

    /// A sentence for operators (allocates: call outside the cycle).
    pub fn describe(&self) -> String {
        let mut s = self.kind.as_str().replace('_', " ");
        if let Some(a) = self.axis {
            s.push_str(&format!(" on joint {}", a + 1));
        }
        if self.value.is_finite() || self.limit.is_finite() {
            s.push_str(&format!(
                ": {:.6} {} against a limit of {:.6} {}",
                self.value,
                self.kind.unit(),
                self.limit,
                self.kind.unit()
            ));
        }
        if !self.note.is_empty() {
            s.push_str(" (");
            s.push_str(self.note);
            s.push(')');
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn descriptions_name_the_axis_and_the_numbers() {
        let f = Fault::new(FaultKind::JointLimit, 1.0)
            .on_axis(1)
            .with_values(1.3, 1.2);
        let d = f.describe();
        assert!(d.contains("joint limit on joint 2"), "{d}");
        assert!(d.contains("1.300000 rad"), "{d}");
        assert_eq!(Fault::new(FaultKind::Estop, 0.0).describe(), "estop");
    }
}
