//! The lockstep runner: a whole trial as fast as the CPU allows, with no threads and no
//! clock but the simulated one.
//!
//! It drives the same control code the daemon does against the same plant: control's
//! `ArmModel` (encoders through the fixed-pivot model: what the robot believes),
//! `MotionPlanner`, `PdController` at the servo rate, and a `Tracker` by name at the frame
//! rate. The trial is the surgeon's: move to the first placement, mark, move to the second,
//! mark, then track on its own until the tracker ends (or a simulated time limit). The same
//! seed gives bit-identical results; only `wall_s` depends on the machine.

use std::time::Instant;

use control::calibration::TactileCalibration;
use control::frames::SurfacePoint;
use control::kinematics::ArmModel;
use control::kinematics::RodMechanics;
use control::motion::{Arrival, MotionPlanner, Shortfall};
use control::pd::PdController;
use control::pd::gravity::{ArmGravity, GravityModel, PhantomGravity};
use control::tracker::approach::ApproachTrail;
use control::tracker::{
    EndReason, MotionCommand, TrackLimit, Tracker, TrackerEvent, TrackerInput, TrackerPhase,
};
use control::types::{JointSetpoint, JointTorques, TactileFrame};
use nalgebra::{Point3, Vector3};

use crate::bench::Bench;
use crate::error::SimError;
use crate::scene::{Placing, Scene};
use crate::trial::{LocatedSample, TrialResult};
use crate::trial_event::{EventKind, TrialEvent};

pub mod search;

/// Simulated time allowed for the whole trial before it is stopped as `timeout`, s. The seed
/// took about two minutes per 26 cm track; `beatslide` on a weak artery listens a minute or
/// more at each 5 mm stop (docs/tracker-beatslide.md), about an hour per 24 cm.
pub const TRIAL_TIME_LIMIT_S: f64 = 3.0 * 3600.0;

/// Manual marks tried at one placement before giving up (a surgeon would try again).
const MARK_ATTEMPTS: usize = 3;

/// Speed at which the "surgeon" moves the sensor to a placement, m/s.
const PLACEMENT_SPEED_M_S: f64 = 0.01;

/// Placing by eye: a sensor this close to the mark is left where it is, m; the arm is sent
/// this far past the mark while the surgeon watches the sensor slide onto it (more than the
/// rod's compliance lag of a few mm), m.
const PLACEMENT_TOLERANCE_M: f64 = 0.001;
const PLACEMENT_OVERRUN_M: f64 = 0.015;

/// How often the sensor's believed and true positions are kept for plots, s.
const TRACK_SAMPLE_S: f64 = 0.1;

/// Run one whole trial of `scene` on the rig `config` describes, with the tracker `tracker`.
pub fn run_trial(
    scene: &Scene,
    config: &config::Config,
    tracker: &str,
    seed: u64,
) -> Result<TrialResult, SimError> {
    run_trial_calibrated(scene, config, tracker, seed, &Calibrated::default())
}

/// What a calibration file gives a trial, applied as the daemon applies it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Calibrated {
    /// Every frame corrected before the tracker sees it, the tracker built with the
    /// calibration's unusable elements skipped and its measured noise.
    pub tactile: Option<TactileCalibration>,
    /// The tissue frame the kinematics use in place of `robot.tissue` (the scene's truth
    /// stays where the config and the scene put it).
    pub tissue: Option<control::frames::TissuePlacement>,
    /// The pivot (base frame, m) the kinematics use in place of `robot.pivot`'s (the
    /// scene's true incision stays where the config and the scene put it).
    pub pivot_in_base_m: Option<[f64; 3]>,
    /// The homing's encoder zero offsets, rad, added to every angle read (as the daemon's
    /// loop does; the scene's encoder error stays).
    pub joint_zero_rad: Option<[f64; 3]>,
}

/// [`run_trial`] with a calibration applied.
pub fn run_trial_calibrated(
    scene: &Scene,
    config: &config::Config,
    tracker: &str,
    seed: u64,
    calibration: &Calibrated,
) -> Result<TrialResult, SimError> {
    let wall = Instant::now();
    let mut trial = Lockstep::new(scene, config, tracker, seed, calibration)?;
    let mut result = trial.run(scene)?;
    result.seed = seed;
    result.wall_s = wall.elapsed().as_secs_f64();
    Ok(result)
}

/// Why a phase of the trial stopped early.
enum Stop {
    /// The simulated time limit.
    Timeout,
    /// The controller or the kinematics refused.
    Fault(String),
    /// The arm stopped short of a placement or a tracking target (judged from the
    /// encoders): nothing is marked or fixed there.
    ShortOfTarget {
        what: String,
        target: SurfacePoint,
        shortfall: Shortfall,
    },
}

/// Everything one trial drives.
struct Lockstep {
    bench: Bench,
    model: ArmModel,
    pd: PdController,
    planner: MotionPlanner,
    gravity: ArmGravity,
    tracker: Box<dyn Tracker>,
    /// The joint setpoint of a planner at rest, reused until the planner moves.
    rest_setpoint: Option<(Point3<f64>, JointSetpoint)>,
    /// Where the robot believes the sensor is (tissue frame) and how fast it moves.
    believed: Point3<f64>,
    believed_speed_m_s: f64,
    last_move_target: Option<SurfacePoint>,
    located: Vec<LocatedSample>,
    backtracks: u32,
    misses: u32,
    first_acquisition: Vec<TactileFrame>,
    recording_first: bool,
    /// Until the first mark, the robot's believed positions (the approach), handed to the
    /// tracker at that mark as the daemon hands it those from before its trial began.
    approach: Option<ApproachTrail>,
    sensor_track: Vec<(f64, SurfacePoint, SurfacePoint)>,
    next_track_sample_s: f64,
    log: Vec<TrialEvent>,
    /// The true sensor at each recent frame, to score a localization at the time it was
    /// made (its event may come out a few frames later, once the next move has begun).
    recent_truth: std::collections::VecDeque<(f64, SurfacePoint)>,
    /// What reads the sensor's place from the arm's load, where the config describes the rod.
    load_reading: Option<LoadReading>,
    /// The array's calibration, applied to every frame before the tracker sees it.
    calibration: Option<TactileCalibration>,
    /// The homing's encoder zero offsets, added to every angle read, rad.
    joint_zero_rad: [f64; 3],
}

/// The rod and the arm's own bodies, to read where the sensor is from the motors' torque
/// (`ArmModel::sensor_felt`), as the daemon does.
struct LoadReading {
    rod: RodMechanics,
    bodies: PhantomGravity,
    gravity_m_s2: f64,
}

/// The rod the load is read with: none without a `rod` section in the config; with one, the
/// scene's compliant rod (what a lab would measure and type in, as with the instrument's
/// mass), else the config's.
fn described_rod(config: &config::Config, bench: &Bench) -> Option<RodMechanics> {
    config
        .rod
        .map(|configured| bench.rod_mechanics().unwrap_or(configured))
}

/// The instrument the controller compensates: the config's, with its mass filled from the
/// scene's mass section (what a user would weigh and type in; no mass section: none added).
/// No `instrument` section in the config: none, as on a rig configured without one.
fn instrument(config: &config::Config, scene: &Scene) -> Option<control::pd::gravity::Instrument> {
    config.instrument.map(|i| control::pd::gravity::Instrument {
        mass_kg: scene.mass.map_or(0.0, |m| m.mass_kg),
        ..i
    })
}

/// Frames of true positions kept for scoring late events (a second at 100 Hz).
const RECENT_FRAMES: usize = 100;

impl Lockstep {
    fn new(
        scene: &Scene,
        config: &config::Config,
        tracker: &str,
        seed: u64,
        calibrated: &Calibrated,
    ) -> Result<Self, SimError> {
        let robot = &config.robot;
        let calibration = calibrated.tactile.as_ref();
        let sensor = match calibration {
            Some(c) => c
                .geometry(&config.sensor)
                .map_err(|e| SimError::Config(format!("tactile calibration: {e}")))?,
            None => config.sensor,
        };
        let pivot = control::kinematics::PivotGeometry {
            pivot_in_base_m: calibrated
                .pivot_in_base_m
                .unwrap_or(robot.pivot.pivot_in_base_m),
            ..robot.pivot
        };
        let model = ArmModel::new(
            robot.phantom,
            robot.joint_limits,
            pivot,
            calibrated.tissue.unwrap_or(robot.tissue),
            robot.sensor_offset_m,
        )?;
        let tracker = control::tracker::build(tracker, &config.tracker.params, &sensor).map_err(
            |e| match e {
                control::tracker::BuildError::Unknown(u) => SimError::UnknownTracker {
                    name: u.name,
                    known: control::tracker::TRACKER_NAMES.join(", "),
                },
                other => SimError::Control(other.to_string()),
            },
        )?;
        let bench = Bench::new(scene, config, seed, scene.robot.is_none())?;
        let pd =
            PdController::new(config.control.pd).map_err(|e| SimError::Control(e.to_string()))?;
        let planner = MotionPlanner::new(config.control.motion)
            .map_err(|e| SimError::Control(e.to_string()))?;
        let mut lockstep = Self {
            bench,
            model,
            pd,
            planner,
            gravity: ArmGravity::new(
                &config.robot.link_masses,
                &config.robot.phantom,
                &pivot,
                instrument(config, scene).as_ref(),
            ),
            tracker,
            rest_setpoint: None,
            believed: Point3::origin(),
            believed_speed_m_s: 0.0,
            last_move_target: None,
            located: Vec::new(),
            backtracks: 0,
            misses: 0,
            first_acquisition: Vec::new(),
            recording_first: false,
            approach: Some(ApproachTrail::default()),
            sensor_track: Vec::new(),
            next_track_sample_s: 0.0,
            log: Vec::new(),
            recent_truth: std::collections::VecDeque::with_capacity(RECENT_FRAMES + 1),
            load_reading: None,
            calibration: calibrated.tactile,
            joint_zero_rad: calibrated.joint_zero_rad.unwrap_or([0.0; 3]),
        };
        lockstep.load_reading = described_rod(config, &lockstep.bench).map(|rod| LoadReading {
            rod,
            bodies: PhantomGravity::new(&config.robot.link_masses),
            gravity_m_s2: config.robot.link_masses.gravity_m_s2,
        });
        lockstep.update_belief()?;
        Ok(lockstep)
    }

    fn now(&self) -> f64 {
        self.bench.now_s()
    }

    /// The joints as the robot reads them: the encoders through the homing's zero offsets.
    fn read_joints(&self) -> control::types::JointState {
        let mut state = self.bench.read_joints();
        control::calibration::through_zero(&mut state.position_rad, &self.joint_zero_rad);
        state
    }

    /// Read the encoders and work out where the robot believes the sensor is.
    fn update_belief(&mut self) -> Result<(), SimError> {
        if self.bench.is_ideal() {
            let t = self.now();
            match self.planner.setpoint(t) {
                Some((p, v)) => {
                    self.believed = p;
                    self.believed_speed_m_s = v.x.hypot(v.z);
                }
                None => {
                    let s = self.bench.truth().sensor;
                    self.believed = Point3::new(s.x_m, 0.0, s.z_m);
                    self.believed_speed_m_s = 0.0;
                }
            }
            return Ok(());
        }
        let state = self.read_joints();
        self.believed = self.model.sensor_from_joints(&state.position_rad)?;
        Ok(())
    }

    /// The believed sensor speed over the surface (for settling), from the filtered joint
    /// rates through the model's Jacobian.
    fn update_believed_speed(&mut self) -> Result<(), SimError> {
        if self.bench.is_ideal() {
            return Ok(());
        }
        let state = self.read_joints();
        let j = self.model.sensor_jacobian(&state.position_rad)?;
        let v = j * Vector3::from(state.velocity_rad_s);
        self.believed_speed_m_s = v.x.hypot(v.z);
        Ok(())
    }

    fn believed_surface(&self) -> SurfacePoint {
        SurfacePoint::new(self.believed.x, self.believed.z)
    }

    /// Where the arm's load says the sensor is now (encoders and commanded torques), where
    /// the rod is described and the arm is driven.
    fn felt_surface(&self) -> Option<SurfacePoint> {
        let r = self.load_reading.as_ref()?;
        if self.bench.is_ideal() {
            return None;
        }
        let q = self.read_joints().position_rad;
        let body = r.bodies.torque_nm(&q);
        self.model
            .sensor_felt(
                &q,
                &self.bench.commanded_torque_nm(),
                &body,
                &r.rod,
                r.gravity_m_s2,
            )
            .ok()
    }

    /// The joint setpoint for the planner's setpoint now. At rest it is control's
    /// `ArmModel::joint_setpoint`, cached while the planner holds still. During a move it is
    /// the same map computed from `ArmModel`'s inverse kinematics and Jacobian directly: the
    /// 3x3 SVD conditioning guard inside `joint_setpoint` costs about 2 µs, more than the
    /// whole plant step, so the runner applies it once per move, at the move's target
    /// ([`Self::apply`]), instead of every millisecond.
    fn joint_setpoint(&mut self) -> Result<Option<JointSetpoint>, SimError> {
        let t = self.now();
        let Some((p, v)) = self.planner.setpoint(t) else {
            return Ok(None);
        };
        if v.norm() == 0.0 {
            if let Some((cached_p, sp)) = self.rest_setpoint
                && cached_p == p
            {
                return Ok(Some(sp));
            }
            let trim = self.planner.trim();
            if trim.x_m != 0.0 || trim.z_m != 0.0 {
                // Being trimmed onto the target: millimetres from a point the guard passed
                // (the move's target), so the inverse kinematics alone, as during moves.
                let q = self.model.joints_for_sensor(&p)?;
                let sp = JointSetpoint {
                    position_rad: q,
                    velocity_rad_s: [0.0; 3],
                };
                self.rest_setpoint = Some((p, sp));
                return Ok(Some(sp));
            }
            let sp = self.model.joint_setpoint(&p, &v)?;
            self.rest_setpoint = Some((p, sp));
            return Ok(Some(sp));
        }
        let q = self.model.joints_for_sensor(&p)?;
        let j = self.model.sensor_jacobian(&q)?;
        let rates = j.lu().solve(&v).ok_or(SimError::Kinematics(
            control::kinematics::KinematicsError::Singular {
                what: "sensor Jacobian",
            },
        ))?;
        let sp = JointSetpoint {
            position_rad: q,
            velocity_rad_s: [rates.x, rates.y, rates.z],
        };
        if !sp.is_finite() {
            return Err(SimError::NonFinite("joint setpoint"));
        }
        Ok(Some(sp))
    }

    /// One servo period; returns the tactile frame sampled in it, if any.
    fn servo(&mut self) -> Result<Option<TactileFrame>, Stop> {
        if self.bench.is_ideal() {
            // The ideal robot is where the setpoint is at the end of this period.
            if let Some((p, _)) = self.planner.setpoint(self.now() + self.bench.dt_s()) {
                self.bench.place_ideal(SurfacePoint::new(p.x, p.z));
            }
        } else {
            let state = self.read_joints();
            let setpoint = self
                .joint_setpoint()
                .map_err(|e| Stop::Fault(e.to_string()))?;
            let torques = match setpoint {
                Some(sp) => {
                    let g = self.gravity.torque_nm(&state.position_rad);
                    self.pd
                        .step(&sp, &state, &g, self.bench.dt_s())
                        .map_err(|e| Stop::Fault(format!("PD: {e}")))?
                }
                None => JointTorques::ZERO,
            };
            self.bench
                .write_torques(&torques)
                .map_err(|e| Stop::Fault(e.to_string()))?;
        }
        let frame = self.bench.step();
        if self.now() > TRIAL_TIME_LIMIT_S {
            return Err(Stop::Timeout);
        }
        if self.now() >= self.next_track_sample_s {
            self.next_track_sample_s += TRACK_SAMPLE_S;
            let _ = self.update_belief();
            let truth = self.bench.truth();
            self.sensor_track
                .push((self.now(), self.believed_surface(), truth.sensor));
        }
        Ok(frame)
    }

    /// Run servo periods until the next tactile frame; refresh the belief then.
    fn next_frame(&mut self) -> Result<TactileFrame, Stop> {
        loop {
            if let Some(f) = self.servo()? {
                self.update_belief()
                    .and_then(|()| self.update_believed_speed())
                    .map_err(|e| Stop::Fault(e.to_string()))?;
                // Judge the move (and trim a stalled arm) once per frame: the verdict the
                // frame is fed with.
                let (b, t) = (self.believed_surface(), self.now());
                let v = self.believed_speed_m_s;
                self.planner.observe(b, v, t);
                if let Some(trail) = self.approach.as_mut() {
                    trail.push(b);
                }
                if self.recording_first {
                    self.first_acquisition.push(f);
                }
                let truth = self.bench.truth();
                if self.recent_truth.len() == RECENT_FRAMES {
                    self.recent_truth.pop_front();
                }
                self.recent_truth.push_back((f.t_s, truth.sensor));
                return Ok(f);
            }
        }
    }

    /// Start a straight move of the sensor to `target` from where the setpoint is now.
    fn move_to(&mut self, target: SurfacePoint, speed_m_s: f64) -> Result<(), SimError> {
        let t = self.now();
        let from = self
            .planner
            .setpoint(t)
            .map(|(p, _)| p)
            .unwrap_or(self.believed);
        self.planner
            .start_from_point(from, target, speed_m_s, t)
            .map_err(|e| SimError::Control(e.to_string()))?;
        self.last_move_target = Some(target);
        Ok(())
    }

    /// Hold where the robot believes the sensor is over the surface, at the setpoint's
    /// height (the contact load stays as it was).
    fn hold_at_believed(&mut self) -> Result<(), SimError> {
        let t = self.now();
        let y = self
            .planner
            .setpoint(t)
            .map_or(self.believed.y, |(p, _)| p.y);
        let here = Point3::new(self.believed.x, y, self.believed.z);
        self.planner
            .hold_point(here, t)
            .map_err(|e| SimError::Control(e.to_string()))?;
        self.last_move_target = None;
        Ok(())
    }

    fn hold_here(&mut self) -> Result<(), SimError> {
        let t = self.now();
        let here = self
            .planner
            .setpoint(t)
            .map(|(p, _)| p)
            .unwrap_or(self.believed);
        self.planner
            .hold_point(here, t)
            .map_err(|e| SimError::Control(e.to_string()))?;
        self.last_move_target = None;
        Ok(())
    }

    /// Where the current move stands: the planner's verdict from the believed (encoder)
    /// position at the last frame, kept once decided; no motion at all counts as arrived.
    fn arrival(&self) -> Arrival {
        if self.planner.target().is_none() {
            return Arrival::Arrived;
        }
        self.planner.verdict()
    }

    fn settled(&self) -> bool {
        self.arrival() == Arrival::Arrived
    }

    /// The surgeon moves the sensor to a placement and waits for it to arrive, in the way
    /// the scene says ([`Placing`]). An arm that stops short ends the trial there: a mark
    /// is made only where the arm really is.
    fn place(&mut self, index: usize, at: SurfacePoint, placing: Placing) -> Result<(), Stop> {
        match placing {
            Placing::Robot => self
                .move_to(at, PLACEMENT_SPEED_M_S)
                .map_err(|e| Stop::Fault(e.to_string()))?,
            Placing::Eye => self.slide_onto(at)?,
        }
        loop {
            self.next_frame()?;
            match self.arrival() {
                Arrival::Arrived => return Ok(()),
                Arrival::Moving => {}
                Arrival::StoppedShort(shortfall) => {
                    return Err(self.stopped_short(format!("placement {}", index + 1), shortfall));
                }
            }
        }
    }

    /// Come to rest where the arm is (not where it could not get) and say so.
    fn stopped_short(&mut self, what: String, shortfall: Shortfall) -> Stop {
        let target = self
            .planner
            .target()
            .unwrap_or_else(|| self.believed_surface());
        if let Err(e) = self.hold_at_believed() {
            return Stop::Fault(e.to_string());
        }
        self.last_move_target = None;
        let kind = EventKind::stopped_short(what.clone(), target, &shortfall);
        self.log_event(kind);
        Stop::ShortOfTarget {
            what,
            target,
            shortfall,
        }
    }

    /// Slide the sensor onto `at` by eye: the arm moves straight toward the mark and on past
    /// it, and stops the moment the sensor itself (not where the robot believes it is)
    /// reaches the mark. The rod's compliance leaves the robot's belief ahead of the sensor
    /// along the approach, as a hand on the gimbal would leave it.
    fn slide_onto(&mut self, at: SurfacePoint) -> Result<(), Stop> {
        let from = self.bench.truth().sensor;
        let (dx, dz) = (at.x_m - from.x_m, at.z_m - from.z_m);
        let length = dx.hypot(dz);
        if length <= PLACEMENT_TOLERANCE_M {
            return self.hold_here().map_err(|e| Stop::Fault(e.to_string()));
        }
        let (ux, uz) = (dx / length, dz / length);
        let beyond = SurfacePoint::new(
            at.x_m + ux * PLACEMENT_OVERRUN_M,
            at.z_m + uz * PLACEMENT_OVERRUN_M,
        );
        self.move_to(beyond, PLACEMENT_SPEED_M_S)
            .map_err(|e| Stop::Fault(e.to_string()))?;
        loop {
            self.next_frame()?;
            let s = self.bench.truth().sensor;
            let to_go = (at.x_m - s.x_m) * ux + (at.z_m - s.z_m) * uz;
            let moving = self
                .planner
                .finish_time_s()
                .is_some_and(|end| self.now() < end);
            if to_go <= 0.0 || !moving {
                // The surgeon stops the arm where it is, not where its setpoint has run
                // ahead to.
                return self
                    .hold_at_believed()
                    .map_err(|e| Stop::Fault(e.to_string()));
            }
        }
    }

    /// Apply a tracker's motion command.
    fn apply(&mut self, motion: MotionCommand) -> Result<(), SimError> {
        match motion {
            MotionCommand::MoveTo { target, speed_m_s } => {
                if self.last_move_target != Some(target) {
                    // The target must be reachable, and well conditioned, before the arm
                    // is sent there.
                    let p = self.planner.contact_point(&target);
                    self.model.joint_setpoint(&p, &Vector3::zeros())?;
                    self.move_to(target, speed_m_s)?;
                }
            }
            MotionCommand::Hold => {
                let moving = self
                    .planner
                    .finish_time_s()
                    .is_some_and(|end| self.now() < end);
                if moving {
                    self.hold_here()?;
                }
            }
        }
        Ok(())
    }

    /// Log `event` with where the robot believes the sensor is and where it truly is.
    fn log_event(&mut self, event: EventKind) {
        let truth = self.bench.truth();
        let off = self.bench.path().nearest(truth.sensor);
        self.log.push(TrialEvent {
            t_s: self.now(),
            believed_sensor: SurfacePoint::new(self.believed.x, self.believed.z),
            true_sensor: truth.sensor,
            off_artery_m: off.offset_m,
            along_path_m: off.s_m,
            event,
        });
    }

    /// Feed one frame to the tracker and act on its answer; returns the event.
    fn feed(&mut self, frame: &TactileFrame) -> Result<Option<TrackerEvent>, Stop> {
        let corrected = self.calibration.as_ref().map(|c| c.correct_frame(frame));
        let input = TrackerInput {
            frame: corrected.as_ref().unwrap_or(frame),
            sensor: self.believed_surface(),
            settled: self.settled(),
            loaded_sensor: self.felt_surface(),
        };
        let out = self.tracker.step(&input);
        if let Err(e) = self.apply(out.motion) {
            match e {
                SimError::Kinematics(_) => self.tracker.target_unreachable(),
                other => return Err(Stop::Fault(other.to_string())),
            }
        }
        if let Some(ev) = out.event {
            self.log_event(EventKind::from(ev));
            match ev {
                TrackerEvent::Located(p) => {
                    let sensor = self.true_sensor_at(p.t_s);
                    self.located.push(LocatedSample {
                        t_s: p.t_s,
                        x_m: p.point.x_m,
                        z_m: p.point.z_m,
                        true_x_m: sensor.x_m + (p.point.x_m - p.sensor.x_m),
                        true_z_m: sensor.z_m + (p.point.z_m - p.sensor.z_m),
                        seed: p.seed,
                        lateral_error_m: 0.0,
                        along_path_m: 0.0,
                        sd_m: p.sd_m,
                    });
                }
                TrackerEvent::Backtracking { .. } => self.backtracks += 1,
                TrackerEvent::Missed { .. } => self.misses += 1,
                TrackerEvent::Pulse { .. }
                | TrackerEvent::Finished { .. }
                | TrackerEvent::Listening(_) => {}
            }
        }
        Ok(out.event)
    }

    /// Where the sensor truly was at the frame stamped nearest `t_s`.
    fn true_sensor_at(&mut self, t_s: f64) -> SurfacePoint {
        self.recent_truth
            .iter()
            .min_by(|a, b| (a.0 - t_s).abs().total_cmp(&(b.0 - t_s).abs()))
            .map(|&(_, s)| s)
            .unwrap_or_else(|| self.bench.truth().sensor)
    }

    /// Mark at the current placement until the tracker reports the seed point or a miss.
    fn mark(&mut self) -> Result<bool, Stop> {
        if let Some(mut trail) = self.approach.take() {
            trail.hand_to(self.tracker.as_mut());
        }
        for _ in 0..MARK_ATTEMPTS {
            self.tracker
                .mark()
                .map_err(|e| Stop::Fault(format!("mark refused: {e}")))?;
            loop {
                let frame = self.next_frame()?;
                // A move the tracker makes while marking (a seating stroke) that stops short
                // ends the trial as it does while tracking, and as the daemon ends it.
                if self.last_move_target.is_some()
                    && let Arrival::StoppedShort(shortfall) = self.arrival()
                {
                    self.tracker.stop();
                    return Err(self.stopped_short("move while marking".into(), shortfall));
                }
                match self.feed(&frame)? {
                    Some(TrackerEvent::Located(p)) if p.seed => return Ok(true),
                    Some(TrackerEvent::Missed { .. }) => break,
                    // Done marking and nothing left to report: the mark found nothing.
                    None if !matches!(self.tracker.phase(), TrackerPhase::Marking) => break,
                    _ => {}
                }
            }
        }
        Ok(false)
    }

    fn run(&mut self, scene: &Scene) -> Result<TrialResult, SimError> {
        self.bench.set_enabled(true);
        self.pd.reset();
        self.hold_here()?;
        let mut outcome = Outcome::default();
        let seeded = (|| -> Result<bool, Stop> {
            for (i, placement) in scene.placements.iter().enumerate() {
                self.place(i, *placement, scene.placed_by)?;
                self.recording_first = i == 0;
                let found = self.mark()?;
                self.recording_first = false;
                if !found {
                    return Ok(false);
                }
            }
            Ok(true)
        })();
        match seeded {
            Ok(true) => self.track(scene, &mut outcome),
            Ok(false) => {
                outcome.end_reason = "not_seeded".into();
                outcome.detail =
                    Some("a manual placement found no pulse after repeated marks".into());
            }
            Err(stop) => outcome.stopped(stop),
        }
        let t_end = self.now();
        let mut located = std::mem::take(&mut self.located);
        let lateral = TrialResult::score_moving(
            self.bench.path(),
            scene.tissue.breathing.as_ref(),
            &mut located,
        );
        let false_points = crate::trial::false_points(&located);
        let tracked_length_m = located
            .windows(2)
            .map(|w| (w[1].x_m - w[0].x_m).hypot(w[1].z_m - w[0].z_m))
            .sum();
        let (duration_s, beats) = match outcome.tracking_from_s {
            Some(t0) => {
                let b0 = outcome.beats_at_start;
                (
                    t_end - t0,
                    self.bench.beats_started_by(t_end).saturating_sub(b0),
                )
            }
            None => (0.0, 0),
        };
        Ok(TrialResult {
            seed: 0,
            located,
            duration_s,
            beats,
            backtracks: self.backtracks,
            misses: self.misses,
            completed: outcome.end_reason == EndReason::LengthReached.as_str(),
            end_reason: outcome.end_reason,
            detail: outcome.detail,
            shortfall: outcome.shortfall,
            lateral_error_m: lateral,
            false_points,
            tracked_length_m,
            simulated_s: t_end,
            wall_s: 0.0,
            first_acquisition: std::mem::take(&mut self.first_acquisition),
            sensor_track: std::mem::take(&mut self.sensor_track),
            log: std::mem::take(&mut self.log),
        })
    }

    /// Autonomous tracking from the two seed points to the tracker's end.
    fn track(&mut self, scene: &Scene, outcome: &mut Outcome) {
        let limit = TrackLimit {
            length_m: Some(scene.track.length_m),
        };
        if let Err(e) = self.tracker.start(limit) {
            outcome.end_reason = "not_seeded".into();
            outcome.detail = Some(format!("tracking refused to start: {e}"));
            return;
        }
        let t0 = self.now();
        outcome.tracking_from_s = Some(t0);
        outcome.beats_at_start = self.bench.beats_started_by(t0);
        loop {
            let step = self.next_frame().and_then(|f| {
                // A tracker's move that stops short ends the trial before the tracker could
                // take the frame as a fix from a place the arm did not reach.
                if self.last_move_target.is_some()
                    && let Arrival::StoppedShort(shortfall) = self.arrival()
                {
                    self.tracker.stop();
                    return Err(self.stopped_short("tracking target".into(), shortfall));
                }
                self.feed(&f)
            });
            match step {
                Ok(Some(TrackerEvent::Finished { reason, .. })) => {
                    outcome.end_reason = reason.as_str().to_string();
                    return;
                }
                Ok(_) => {}
                Err(stop) => {
                    outcome.stopped(stop);
                    return;
                }
            }
        }
    }
}

/// How the trial ended, collected while it runs.
#[derive(Debug, Default)]
struct Outcome {
    end_reason: String,
    detail: Option<String>,
    tracking_from_s: Option<f64>,
    beats_at_start: u64,
    shortfall: Option<crate::trial::ShortfallReport>,
}

/// The end reason of a trial whose arm stopped short of a placement or a tracking target.
pub const SHORT_OF_TARGET: &str = "short_of_target";

impl Outcome {
    fn stopped(&mut self, stop: Stop) {
        match stop {
            Stop::Timeout => {
                self.end_reason = "timeout".into();
                self.detail = Some(format!(
                    "the trial exceeded {TRIAL_TIME_LIMIT_S} s of simulated time"
                ));
            }
            Stop::Fault(m) => {
                self.end_reason = "fault".into();
                self.detail = Some(m);
            }
            Stop::ShortOfTarget {
                what,
                target,
                shortfall,
            } => {
                self.end_reason = SHORT_OF_TARGET.into();
                self.detail = Some(format!(
                    "{what} at ({:.2}, {:.2}) mm not reached: {shortfall}; nothing was marked or fixed there",
                    target.x_m * 1e3,
                    target.z_m * 1e3
                ));
                self.shortfall = Some(crate::trial::ShortfallReport {
                    what,
                    target_x_m: target.x_m,
                    target_z_m: target.z_m,
                    shortfall_m: shortfall.distance_m,
                    reason: shortfall.reason.as_str().into(),
                });
            }
        }
    }
}

#[cfg(test)]
#[path = "runner_tests.rs"]
mod tests;
