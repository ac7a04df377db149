//! The servo built from the control core (ArmModel, MotionPlanner, PdController) and the
//! tracker factory. Wired in when the control core lands on main.

use config::Config;

use crate::rt::servo::Servo;
use crate::supervisor::TrackerFactory;

pub fn build(_c: &Config) -> Result<Box<dyn Servo>, String> {
    Err("the control core (kinematics, motion, PD) has not landed in this build".into())
}

pub fn tracker_factory(_c: &Config) -> Result<TrackerFactory, String> {
    Err("the tracker has not landed in this build".into())
}
