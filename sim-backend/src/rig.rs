//! The simulated bench behind control's ports, for the daemon.
//!
//! [`SimRig::split`] gives a [`SimArm`] (a `Manipulator`: each `write_torques` advances
//! simulated time by one control period and integrates the plant) and a [`SimTactile`] (a
//! `TactileArray`: frames sampled by the plant every 1 / sensor rate of simulated time from
//! the sensor's *true* pose, handed over a channel). The simulated clock is the daemon's
//! clock on this backend: [`SimArm::now_s`].

use control::ports::{Manipulator, TactileArray};
use control::types::{JointState, JointTorques, TactileFrame};
use crossbeam_channel::{Receiver, Sender, TryRecvError, TrySendError};

use crate::bench::{ArrayPlace, Bench, SimTruth};
use crate::error::SimError;
use crate::scene::{ArteryPath, Scene};

/// Frames buffered between the arm's physics and the tactile port (40 s at 100 Hz); beyond
/// that new frames are dropped and the `seq` gap shows it.
const FRAME_BUFFER: usize = 4096;

/// The simulated bench before it is split into its two ports.
#[derive(Debug)]
pub struct SimRig {
    bench: Bench,
}

impl SimRig {
    /// The simulated bench for `scene`, using the robot / control / sensor sections of the
    /// daemon's `config` (geometry, limits, rates), seeded for determinism. The arm starts
    /// disabled, resting on the tissue at the scene's start point.
    pub fn new(scene: &Scene, config: &config::Config, seed: u64) -> Result<SimRig, SimError> {
        Ok(Self {
            bench: Bench::new(scene, config, seed, false)?,
        })
    }

    /// Split into the two ports the daemon drives from different tasks.
    pub fn split(self) -> (SimArm, SimTactile) {
        let (tx, rx) = crossbeam_channel::bounded(FRAME_BUFFER);
        (
            SimArm {
                bench: self.bench,
                frames: tx,
                dropped: 0,
                places: None,
            },
            SimTactile { frames: rx },
        )
    }
}

/// The simulated Phantom (control::ports::Manipulator).
#[derive(Debug)]
pub struct SimArm {
    bench: Bench,
    frames: Sender<TactileFrame>,
    dropped: u64,
    /// Where the array is to go, from whoever holds the [`ArrayHand`].
    places: Option<Receiver<ArrayPlace>>,
}

/// Moves the simulated array between the tissue and the calibration bench from another
/// thread (the daemon's debug hook); the arm applies it at its next step.
#[derive(Debug, Clone)]
pub struct ArrayHand(Sender<ArrayPlace>);

impl ArrayHand {
    /// False once the simulated arm is gone.
    pub fn place(&self, place: ArrayPlace) -> bool {
        self.0.send(place).is_ok()
    }
}

impl SimArm {
    /// Simulated time, s.
    pub fn now_s(&self) -> f64 {
        self.bench.now_s()
    }

    /// Where the sensor truly is (tissue frame), the contact force, friction, the pulse.
    pub fn truth(&mut self) -> SimTruth {
        self.bench.truth()
    }

    /// The scene's true artery path (for displays and trial scoring).
    pub fn path(&self) -> &ArteryPath {
        self.bench.path()
    }

    /// Frames lost because nobody read the tactile port for a long time.
    pub fn dropped_frames(&self) -> u64 {
        self.dropped
    }

    /// The control period, s.
    pub fn dt_s(&self) -> f64 {
        self.bench.dt_s()
    }

    /// A hand that moves the array (replaces any earlier one).
    pub fn array_hand(&mut self) -> ArrayHand {
        let (tx, rx) = crossbeam_channel::unbounded();
        self.places = Some(rx);
        ArrayHand(tx)
    }
}

impl Manipulator for SimArm {
    type Error = SimError;

    fn enable(&mut self) -> Result<(), SimError> {
        self.bench.set_enabled(true);
        Ok(())
    }

    fn disable(&mut self) -> Result<(), SimError> {
        self.bench.set_enabled(false);
        Ok(())
    }

    fn read_joints(&mut self) -> Result<JointState, SimError> {
        Ok(self.bench.read_joints())
    }

    fn write_torques(&mut self, torques: &JointTorques) -> Result<(), SimError> {
        self.bench.write_torques(torques)?;
        if let Some(places) = &self.places {
            while let Ok(p) = places.try_recv() {
                self.bench.place_array(p);
            }
        }
        if let Some(frame) = self.bench.step() {
            match self.frames.try_send(frame) {
                Ok(()) => {}
                Err(TrySendError::Full(_)) => self.dropped += 1,
                // Nobody listens any more: the physics still runs.
                Err(TrySendError::Disconnected(_)) => {}
            }
        }
        Ok(())
    }
}

/// The simulated tactile array (control::ports::TactileArray).
#[derive(Debug)]
pub struct SimTactile {
    frames: Receiver<TactileFrame>,
}

impl TactileArray for SimTactile {
    type Error = SimError;

    fn poll_frame(&mut self) -> Result<Option<TactileFrame>, SimError> {
        match self.frames.try_recv() {
            Ok(f) => Ok(Some(f)),
            Err(TryRecvError::Empty) => Ok(None),
            Err(TryRecvError::Disconnected) => Err(SimError::Disconnected("arm")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rig() -> SimRig {
        let (name, text) = config::shipped::SIM_CONFIG;
        let config: config::Config = config::load_str(name, text).expect("shipped config");
        let scene = crate::scene::load("seed-arc-145.ron", None).expect("shipped scene");
        SimRig::new(&scene, &config, 1).expect("rig")
    }

    #[test]
    fn ports_advance_simulated_time_and_deliver_frames() {
        let (mut arm, mut tactile) = rig().split();
        assert_eq!(arm.now_s(), 0.0);
        assert!(
            tactile.poll_frame().unwrap().is_none(),
            "no frame before time moves"
        );
        arm.enable().unwrap();
        let hold = arm.read_joints().unwrap();
        for _ in 0..100 {
            arm.write_torques(&JointTorques::ZERO).unwrap();
        }
        assert!((arm.now_s() - 0.1).abs() < 1e-12);
        let mut frames = Vec::new();
        while let Some(f) = tactile.poll_frame().unwrap() {
            frames.push(f);
        }
        assert_eq!(frames.len(), 10);
        assert!((frames[9].t_s - 0.1).abs() < 1e-9);
        let state = arm.read_joints().unwrap();
        assert!((state.t_s - 0.1).abs() < 1e-12);
        assert!(state.is_finite() && hold.is_finite());
        // The truth is on the tissue and near the start point.
        let t = arm.truth();
        assert!(t.normal_n > 0.0 && t.sensor.is_finite());
        assert!(arm.path().length_m() > 0.25);
    }

    #[test]
    fn a_dropped_arm_disconnects_the_tactile_port_after_its_frames() {
        let (mut arm, mut tactile) = rig().split();
        for _ in 0..20 {
            arm.write_torques(&JointTorques::ZERO).unwrap();
        }
        drop(arm);
        assert!(tactile.poll_frame().unwrap().is_some());
        assert!(tactile.poll_frame().unwrap().is_some());
        assert!(matches!(
            tactile.poll_frame(),
            Err(SimError::Disconnected(_))
        ));
    }

    #[test]
    fn both_ports_can_move_to_other_threads() {
        fn send<T: Send>() {}
        send::<SimArm>();
        send::<SimTactile>();
    }

    #[test]
    fn non_finite_torques_are_refused() {
        let (mut arm, _tactile) = rig().split();
        arm.enable().unwrap();
        let mut bad = JointTorques::ZERO;
        bad.torque_nm[2] = f64::INFINITY;
        assert!(arm.write_torques(&bad).is_err());
        assert_eq!(arm.now_s(), 0.0, "a refused command does not advance time");
    }
}
