//! The daemon's view of a backend: the two ports, object-safe, plus the clock the loop runs
//! on. Config alone chooses the backend ([`open`]); the rest of the daemon cannot tell the
//! simulator from the rig except through [`BackendInfo`].

pub mod clock;
mod hardware;
mod sim;

use control::types::{JointState, JointTorques, TactileFrame};
use serde::Serialize;

/// An error from a port, with the backend's own words.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct PortError(pub String);

/// The arm: `control::ports::Manipulator` plus the clock it is stamped with.
pub trait ArmPort: Send {
    fn enable(&mut self) -> Result<(), PortError>;
    fn disable(&mut self) -> Result<(), PortError>;
    fn read_joints(&mut self) -> Result<JointState, PortError>;
    fn write_torques(&mut self, torques: &JointTorques) -> Result<(), PortError>;
    /// `Manipulator::recover`: clear the arm's own latched fault once its cause is gone,
    /// leaving it unpowered; the error names the cause while it persists.
    fn recover(&mut self) -> Result<(), PortError> {
        Ok(())
    }
    /// The daemon's clock, s: the simulated clock on the sim backend, CLOCK_MONOTONIC since
    /// start on the rig. Every timestamp in the daemon is on this clock.
    fn now_s(&self) -> f64;
    /// What the simulator knows and the robot does not (None on the rig).
    fn truth(&mut self) -> Option<Truth> {
        None
    }
}

/// The tactile array: `control::ports::TactileArray`.
pub trait TactilePort: Send {
    fn poll_frame(&mut self) -> Result<Option<TactileFrame>, PortError>;
}

/// Ground truth from the simulator, recorded beside what the robot believed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Truth {
    pub t_s: f64,
    /// Where the centre of the element line truly is, tissue frame, m.
    pub sensor_x_m: f64,
    pub sensor_z_m: f64,
}

impl Truth {
    /// As recorded on `/truth`.
    pub fn sample(&self) -> crate::recording::messages::TruthSample {
        crate::recording::messages::TruthSample {
            t_s: self.t_s,
            sensor_x_m: self.sensor_x_m,
            sensor_z_m: self.sensor_z_m,
        }
    }
}

/// What kind of backend runs, for status replies and recordings.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BackendInfo {
    /// `sim` or `hardware`.
    pub kind: &'static str,
    /// Simulated seconds per wall second (1 on the rig).
    pub time_scale: f64,
    /// Missed deadlines matter (a real rig); the simulator's clock cannot fall behind.
    pub wall_clock_bound: bool,
    /// The scene, on the simulator.
    pub scene: Option<SceneInfo>,
}

/// What a console client needs to know of a simulated scene to run a trial on it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneInfo {
    pub name: String,
    /// The two manual starting placements, tissue frame `[x_m, z_m]`.
    pub placements: [[f64; 2]; 2],
    /// The length of artery the scene says to track, m.
    pub tracked_length_m: Option<f64>,
    pub seed: u64,
}

/// An opened backend.
pub struct Backend {
    pub arm: Box<dyn ArmPort>,
    pub tactile: Box<dyn TactilePort>,
    pub info: BackendInfo,
    /// Lateral error of located points against the true path (sim only).
    pub judge: Option<Box<dyn PathJudge>>,
    /// Takes the array to the calibration bench and back (sim only).
    pub array_bench: Option<Box<dyn ArrayBench>>,
}

/// Moves the simulated array between the tissue and the calibration bench: the simulator's
/// stand-in for the person who takes the array off and puts a known load on it. On a rig
/// that person does it by hand.
pub trait ArrayBench: Send {
    /// On the bench under a uniform load per element, N (`Some(0.0)`: nothing on it), or
    /// back on the tissue (`None`). False if the simulator is gone.
    fn place(&self, load_per_element_n: Option<f64>) -> bool;
}

impl std::fmt::Debug for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Backend").field("info", &self.info).finish()
    }
}

/// Scores located points against the true artery path (only the simulator knows it).
pub trait PathJudge: Send {
    /// Signed lateral offset of a tissue-frame point from the true path, m.
    fn lateral_offset_m(&self, x_m: f64, z_m: f64) -> f64;
    /// Heartbeats between two instants of the simulated clock.
    fn beats_between(&self, t0_s: f64, t1_s: f64) -> f64;
    /// The true path, sampled along its length (for the recording's scene).
    fn path_points(&self) -> Vec<control::frames::SurfacePoint> {
        Vec::new()
    }
}

/// Why a backend could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    #[error("{0}")]
    Config(#[from] config::ConfigError),
    #[error("backend: {0}")]
    Backend(String),
}

/// Open the backend the config names. `base_dir` resolves relative scene paths; the
/// hardware drivers run their serial task on `runtime`.
pub fn open(
    config: &config::Config,
    base_dir: Option<&std::path::Path>,
    runtime: &tokio::runtime::Handle,
) -> Result<Backend, OpenError> {
    match &config.backend {
        config::schema::Backend::Sim(s) => sim::open(config, s, base_dir),
        config::schema::Backend::Hardware(hw) => hardware::open(config, hw, runtime),
    }
}
