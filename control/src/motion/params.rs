//! Tip motion settings: how the sensor is moved between tracker targets.

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MotionParams {
    /// Upper bound on any commanded sensor speed, m/s.
    pub max_speed_m_s: f64,
    /// Acceleration of the straight-line setpoint profile, m/s².
    pub accel_m_s2: f64,
    /// Commanded height of the sensor centre relative to the tissue surface, m. A few mm
    /// negative presses into the tissue: the low-gain PD and the tissue act as springs and
    /// the uncompensated weight on the shaft supplies the contact force.
    pub contact_height_m: f64,
    /// A move has arrived when the believed sensor centre is this close to the target, m.
    /// The seed's low-gain PD comes to rest 2.5-4.3 mm short of a 10 mm move against the
    /// Phantom's friction (measured in the simulator, docs/BENCHMARKS.md "Arrival"), so the
    /// default is 5 mm: a rest within it is where the arm stalls, one beyond it (a heavy
    /// instrument: 0.4 mm of a 10 mm move) is a stop short, reported, never marked.
    pub settle_tolerance_m: f64,
    /// ... and moving slower than this, m/s.
    pub settle_speed_m_s: f64,
    /// A move whose setpoint has finished and that has not arrived this long after is judged
    /// to have stopped short of its target (low-gain PD against friction may never get
    /// within the tolerance); it is never counted as arrived, s.
    pub settle_timeout_s: f64,
    /// After a move's profile has finished, the setpoint is trimmed toward where the arm has
    /// to go, at this rate times the believed error (1/s), until the believed sensor centre
    /// is within `settle_tolerance_m`: the low-gain PD's steady error against friction and
    /// load is taken out by the outer loop, not by stiffer gains. 0 turns it off.
    pub trim_rate_per_s: f64,
    /// Largest trim, m (keeps setpoint minus believed well inside the safety layer's
    /// `max_sensor_error_m`); 0 (the default) turns the trim off. On the seed's rig the
    /// trim (4/s, 6 mm) brought the arm to 1 mm of every target but moved the first seed
    /// point of two shipped arcs 2.2 mm off and tripled the beats on the 30 mm arc:
    /// `beatslide`'s compliance compensation is calibrated for an arm that stalls.
    pub trim_max_m: f64,
}

impl Default for MotionParams {
    fn default() -> Self {
        // 30 mm/s is three times the "fast" scale of DESIGN.md §7 and reached within
        // 0.3 s / 4.5 mm at 0.1 m/s²; the PD's slowest (heavy-joint) mode has a time constant
        // of ~0.2 s, so after a second at rest it has done what it can against friction.
        Self {
            max_speed_m_s: 0.03,
            accel_m_s2: 0.1,
            contact_height_m: -0.003,
            settle_tolerance_m: 0.005,
            settle_speed_m_s: 0.002,
            settle_timeout_s: 1.0,
            // A stall of 3 mm (the seed's rig on a 10 mm placement) builds the 3 mm the PD
            // needs to break away in about 0.3 s, well inside the settling time.
            trim_rate_per_s: 4.0,
            trim_max_m: 0.0,
        }
    }
}
