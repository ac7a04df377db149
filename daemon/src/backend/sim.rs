//! The simulator behind the daemon's ports (`backend: Sim(...)`): `sim::rig::SimRig` split
//! into its arm and tactile array, the simulated clock as the daemon's clock, the true sensor
//! pose recorded beside the believed one, and the scene's path and pulse to score trials.

use std::path::Path;

use control::frames::SurfacePoint;
use control::ports::{Manipulator, TactileArray};
use control::types::{JointState, JointTorques, TactileFrame};
use sim::bench::ArrayPlace;
use sim::rig::{ArrayHand, SimArm, SimRig, SimTactile};
use sim::scene::{ArteryPath, PulseSource, PulseSpec};

use crate::backend::{
    ArmPort, ArrayBench, Backend, BackendInfo, OpenError, PathJudge, PortError, SceneInfo,
    TactilePort, Truth,
};

struct SimArmPort(SimArm);

fn port_err(e: sim::SimError) -> PortError {
    PortError(e.to_string())
}

impl ArmPort for SimArmPort {
    fn enable(&mut self) -> Result<(), PortError> {
        self.0.enable().map_err(port_err)
    }
    fn disable(&mut self) -> Result<(), PortError> {
        self.0.disable().map_err(port_err)
    }
    fn read_joints(&mut self) -> Result<JointState, PortError> {
        self.0.read_joints().map_err(port_err)
    }
    fn write_torques(&mut self, torques: &JointTorques) -> Result<(), PortError> {
        self.0.write_torques(torques).map_err(port_err)
    }
    fn recover(&mut self) -> Result<(), PortError> {
        self.0.recover().map_err(port_err)
    }
    fn now_s(&self) -> f64 {
        self.0.now_s()
    }
    fn truth(&mut self) -> Option<Truth> {
        let t = self.0.truth();
        Some(Truth {
            t_s: t.t_s,
            sensor_x_m: t.sensor.x_m,
            sensor_z_m: t.sensor.z_m,
        })
    }
}

struct SimTactilePort(SimTactile);

impl TactilePort for SimTactilePort {
    fn poll_frame(&mut self) -> Result<Option<TactileFrame>, PortError> {
        self.0.poll_frame().map_err(port_err)
    }
}

struct SimArrayBench(ArrayHand);

impl ArrayBench for SimArrayBench {
    fn place(&self, load_per_element_n: Option<f64>) -> bool {
        self.0.place(match load_per_element_n {
            Some(l) => ArrayPlace::OnBench {
                load_per_element_n: l,
            },
            None => ArrayPlace::OnTissue,
        })
    }
}

/// Scores against the scene's true path; counts the scene's heartbeats.
struct SceneJudge {
    path: ArteryPath,
    pulse: PulseSpec,
    pulse_seed: u64,
}

impl PathJudge for SceneJudge {
    fn lateral_offset_m(&self, x_m: f64, z_m: f64) -> f64 {
        self.path.nearest(SurfacePoint::new(x_m, z_m)).offset_m
    }
    fn beats_between(&self, t0_s: f64, t1_s: f64) -> f64 {
        // The pulse source only runs forward: replay it from the start for each query.
        let mut src = PulseSource::new(&self.pulse, self.pulse_seed);
        let b0 = src.beats_started_by(t0_s);
        let b1 = src.beats_started_by(t1_s.max(t0_s));
        (b1 - b0) as f64
    }
    fn path_points(&self) -> Vec<SurfacePoint> {
        self.path.sample(0.001)
    }
}

pub fn open(
    config: &config::Config,
    s: &config::schema::SimBackend,
    base_dir: Option<&Path>,
) -> Result<Backend, OpenError> {
    let scene = sim::scene::load(&s.scene, base_dir)?;
    let rig = SimRig::new(&scene, config, s.seed).map_err(|e| OpenError::Backend(e.to_string()))?;
    let (mut arm, tactile) = rig.split();
    let hand = arm.array_hand();
    let judge = SceneJudge {
        path: arm.path().clone(),
        pulse: scene.pulse.clone(),
        pulse_seed: sim::random::stream_seed(s.seed, sim::random::Stream::Pulse),
    };
    Ok(Backend {
        arm: Box::new(SimArmPort(arm)),
        tactile: Box::new(SimTactilePort(tactile)),
        info: BackendInfo {
            kind: "sim",
            time_scale: s.time_scale,
            wall_clock_bound: false,
            scene: Some(SceneInfo {
                name: scene.name.clone(),
                placements: [
                    [scene.placements[0].x_m, scene.placements[0].z_m],
                    [scene.placements[1].x_m, scene.placements[1].z_m],
                ],
                tracked_length_m: Some(scene.track.length_m),
                seed: s.seed,
            }),
        },
        judge: Some(Box::new(judge)),
        array_bench: Some(Box::new(SimArrayBench(hand))),
    })
}
