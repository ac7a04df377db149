//! The supervisor: the operating state machine and the tracker, on one thread.
//!
//! It takes console requests, the loop's events and the stamped tactile frames, decides
//! what is allowed in the current state, drives the tracker through a trial, and sends
//! motion commands to the loop. Every reply and stream event leaves through the recorder, so
//! that what is acknowledged is on disk first.

mod artery_scene;
pub mod calibration;
mod joints_home;
pub mod joints_sweep;
mod live_view;
mod pivot_touch;
mod report;
mod requests;
mod search;
mod search_recording;
mod search_scene;
pub mod state;
mod tissue_stale;
mod tissue_touch;
mod touch_run;
mod tracking;
pub mod trial;

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender, select, tick};
use serde_json::{Value, json};

use control::frames::SurfacePoint;
use control::tracker::approach::ApproachTrail;
use control::tracker::{MotionCommand, TrackLimit, Tracker, TrackerEvent, TrackerInput};

use crate::backend::{BackendInfo, PathJudge, Truth};
use crate::console::hub::{Responder, StreamEvent};
use crate::console::protocol::{DebugAction, ErrorCode, Stream, Verb, error_reply, ok_reply};
use crate::live::tap::{LiveMsg, LiveTap};
use crate::live::topics::LiveTopic;
use crate::recording::foxglove_msgs::{self as fox, level};
use crate::recording::messages::{ReplyRecord, TrackerCall, TrackerInputRecord};
use crate::recording::naming::utc_stamp;
use crate::recording::provenance::MetadataRecord;
use crate::recording::recorder::{RecorderMsg, RecordingFailure};
use crate::recording::topics::{TISSUE_FRAME, Topic};
use crate::recording::trial_file::{Epoch, epoch_ns, epoch_offset_ns};
use crate::rt::fault::{Fault, FaultKind};
use crate::rt::flight_recorder::FlightRecorder;
use crate::rt::link::{
    ControlCommand, ControlEvent, ControlStatus, LoopSample, Refusal, StampedFrame,
};
use crate::rt::period_stats::PeriodSummary;
use crate::service::log_forward::{self, ALREADY_ON_LOG, ForwardedLine};
use crate::slot::Slot;
use state::{Context, OpState};
use trial::{Trial, TrialEnd};

/// Daemon log lines waiting for `/log`, and how many one tick moves there.
const LOG_LINES_QUEUE: usize = 256;
const LOG_LINES_PER_TICK: usize = 64;

/// Requests from the console and the daemon itself.
pub enum SupervisorInput {
    Request {
        id: u64,
        verb: Verb,
        reply: Responder,
    },
    /// A controlled stop: end any trial, come to rest, power off, close the recording.
    Shutdown { done: Sender<()> },
}

impl std::fmt::Debug for SupervisorInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SupervisorInput::Request { id, verb, .. } => write!(f, "Request({id}, {verb:?})"),
            SupervisorInput::Shutdown { .. } => f.write_str("Shutdown"),
        }
    }
}

/// Builds a fresh tracker for each trial, for the array as calibrated.
pub type TrackerFactory =
    Box<dyn Fn(&control::sensor::ArrayGeometry) -> Result<Box<dyn Tracker>, String> + Send>;

/// The supervisor's settings, from config.
#[derive(Debug, Clone)]
pub struct SupervisorSettings {
    pub tracker_name: String,
    pub home: SurfacePoint,
    pub move_speed_m_s: f64,
    pub max_speed_m_s: f64,
    pub workspace_x_m: [f64; 2],
    pub workspace_z_m: [f64; 2],
    pub debug_hooks: bool,
    pub recording_dir: PathBuf,
    /// Wall time the loop has to answer a command.
    pub command_timeout: Duration,
    /// Wall time a controlled stop may take before power is cut.
    pub stop_timeout: Duration,
    /// Context recorded with every trial (config file, backend, scene).
    pub trial_context: Value,
    /// A trial does not start with less free space than this in the recording folder, bytes.
    pub min_free_bytes: u64,
    /// Metadata records every trial file starts with (resolved config, scene, build, host).
    pub trial_metadata: Vec<MetadataRecord>,
    /// The arm's geometry, to record its frame tree (`None`: not recorded).
    pub arm: Option<control::kinematics::ArmModel>,
    /// How the `search` verb explores a region (the config's `search` section).
    pub search: control::search::SearchParams,
    /// How near its target a motion must come to rest to have arrived, m (the motion
    /// planner's `settle_tolerance_m`).
    pub arrival_tolerance_m: f64,
}

/// The channels the supervisor works with.
#[derive(Debug)]
pub struct SupervisorLinks {
    pub inputs: Receiver<SupervisorInput>,
    pub events: Receiver<ControlEvent>,
    pub samples: Receiver<LoopSample>,
    /// The recorder's word that the open trial's file cannot be written.
    pub recording_failures: Receiver<RecordingFailure>,
    pub commands: Sender<ControlCommand>,
    pub recorder: Sender<RecorderMsg>,
    pub status: Arc<Slot<ControlStatus>>,
    pub flight: FlightRecorder,
    /// Incremented on every supervisor tick: the watchdog's proof of life.
    pub heartbeat: Arc<AtomicU64>,
    /// The operating state for readers outside the supervisor (the console's hello).
    pub shared_state: Arc<AtomicU8>,
    /// The live view's queue (`None`: the live view is off).
    pub live: Option<LiveTap>,
}

/// What a command sent to the loop was for.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Purpose {
    Enable,
    Disable,
    Reset,
    Estop,
    /// A surgeon's placement, with its target.
    ManualMove(SurfacePoint),
    Pause,
    StopHold,
    TrackerMove,
    TrackerHold,
    Debug,
    ShutdownHold,
    /// Coming to rest before a failed recording latches its fault.
    RecordingHold,
    Latch,
    /// A calibration procedure's own move (the tissue frame's or the pivot's touches).
    CalibrationMove,
    /// A tissue frame that passed and is written, handed to the loop.
    SetPlacement,
    /// A pivot that passed and is written, handed to the loop.
    SetPivot,
    /// An encoder zero that passed and is written, handed to the loop.
    SetJointZero,
    /// The joint stop sweep powering the arm in joint space.
    SweepStart,
    /// `stop` during the sweep: back where it started, then off.
    SweepStop,
}

/// A motion that stopped short of its target (see `Supervisor::stopped_short`).
#[derive(Debug, Clone, Copy)]
struct StoppedShort {
    /// The hold the loop rests on since.
    hold_seq: u64,
    shortfall: control::motion::Shortfall,
    /// The surgeon's placement it was going to; `None` for a tracker's move.
    placement: Option<SurfacePoint>,
}

struct Pending {
    seq: u64,
    purpose: Purpose,
    reply: Option<(u64, Responder)>,
    sent: Instant,
}

/// A failed recording waiting for the arm to come to rest before its fault latches.
struct PendingLatch {
    failure: RecordingFailure,
    hold_seq: Option<u64>,
    deadline: Instant,
    latch_sent: bool,
}

struct Shutdown {
    done: Sender<()>,
    deadline: Instant,
    hold_seq: Option<u64>,
}

pub struct Supervisor {
    s: SupervisorSettings,
    links: SupervisorLinks,
    info: BackendInfo,
    judge: Option<Box<dyn PathJudge>>,
    /// The simulator's true artery course, sampled once (empty off the sim).
    true_path: Vec<SurfacePoint>,
    factory: TrackerFactory,
    state: OpState,
    fault: Option<(Fault, Option<PathBuf>)>,
    /// Words the loop's fault cannot carry (the failed file and the OS error).
    fault_detail: Option<String>,
    pending_latch: Option<PendingLatch>,
    tracker: Option<Box<dyn Tracker>>,
    trial: Option<Trial>,
    last_trial: Option<Value>,
    next_seq: u64,
    /// The motion whose settling the tracker and the manual moves wait for.
    motion_seq: u64,
    /// The last manual move (or the trial's last move) stopped short of its target: no mark
    /// until a manual move arrives, or the arm comes to rest within the arrival tolerance of
    /// that placement after all. With the hold it rests on and the placement's target (none
    /// for a tracker's move).
    stopped_short: Option<StoppedShort>,
    /// The last manual move acknowledged by the loop, and its target.
    placement: Option<(u64, SurfacePoint)>,
    tracker_target: Option<SurfacePoint>,
    /// The believed sensor positions while no trial runs: the approach to the first
    /// placement, handed to the next trial's tracker at its first mark.
    approach: ApproachTrail,
    /// The autonomous search under way, if any (state `searching`), and its looks so far
    /// (where, and whether a pulse was placed there) for the live map.
    searcher: Option<control::search::Searcher>,
    search_looks: Vec<(SurfacePoint, bool)>,
    /// The search's own recording while it runs (`supervisor/search_recording.rs`).
    search_file: Option<search_recording::SearchFile>,
    /// The tissue-frame or pivot procedure's touches under way (state `calibrating`), and
    /// their results waiting for the loop to take the new placement or pivot.
    touching: Option<touch_run::TouchRun>,
    tissue_result: Option<(Value, config::calibration_file::TissueRecord)>,
    pivot_result: Option<(Value, config::calibration_file::PivotRecord)>,
    /// The homing's result waiting for the loop to take the new encoder zero.
    joints_result: Option<(Value, config::calibration_file::JointsRecord)>,
    /// The joint stop sweep under way (state `calibrating`).
    sweeping: Option<joints_sweep::SweepRun>,
    pending: Vec<Pending>,
    timing: Option<PeriodSummary>,
    overruns_reported: u64,
    truth: Option<Truth>,
    frames_seen: u64,
    shutdown: Option<Shutdown>,
    last_state_beat: Instant,
    /// State beats sent to the live view (it republishes the scene every few).
    live_beats: u64,
    /// The live view's drop count as last logged.
    live_dropped_logged: u64,
    /// The daemon's own log lines, for `/log` (`service::log_forward`).
    log_lines: crossbeam_channel::Receiver<ForwardedLine>,
    /// The rig's calibration: the tactile correction in use and the procedures' recordings.
    calibration: calibration::Calibration,
}

impl std::fmt::Debug for Supervisor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Supervisor")
            .field("state", &self.state)
            .finish()
    }
}

pub fn state_code(s: OpState) -> u8 {
    s as u8
}

pub fn state_from_code(c: u8) -> OpState {
    OpState::ALL
        .get(usize::from(c))
        .copied()
        .unwrap_or(OpState::Disabled)
}

impl Supervisor {
    pub fn new(
        s: SupervisorSettings,
        links: SupervisorLinks,
        info: BackendInfo,
        judge: Option<Box<dyn PathJudge>>,
        factory: TrackerFactory,
        calibration: calibration::Calibration,
    ) -> Self {
        links
            .shared_state
            .store(state_code(OpState::Disabled), Ordering::Release);
        let true_path = judge.as_ref().map(|j| j.path_points()).unwrap_or_default();
        Self {
            s,
            links,
            info,
            true_path,
            judge,
            factory,
            state: OpState::Disabled,
            fault: None,
            fault_detail: None,
            pending_latch: None,
            tracker: None,
            trial: None,
            last_trial: None,
            next_seq: 1,
            motion_seq: 0,
            stopped_short: None,
            placement: None,
            tracker_target: None,
            approach: ApproachTrail::default(),
            searcher: None,
            search_looks: Vec::new(),
            search_file: None,
            touching: None,
            tissue_result: None,
            pivot_result: None,
            joints_result: None,
            sweeping: None,
            pending: Vec::new(),
            timing: None,
            overruns_reported: 0,
            truth: None,
            frames_seen: 0,
            shutdown: None,
            last_state_beat: Instant::now(),
            live_beats: 0,
            live_dropped_logged: 0,
            log_lines: log_forward::connect(LOG_LINES_QUEUE),
            calibration,
        }
    }

    /// Run until a shutdown completes or the inputs close.
    pub fn run(mut self) {
        if let Some(why) = self.tissue_stale() {
            let t = self.now_s();
            self.log_line(t, level::WARNING, why);
        }
        let ticker = tick(Duration::from_millis(50));
        let mut inputs = self.links.inputs.clone();
        loop {
            select! {
                recv(inputs) -> m => match m {
                    Ok(SupervisorInput::Request { id, verb, reply }) => self.on_request(id, verb, reply),
                    Ok(SupervisorInput::Shutdown { done }) => self.begin_shutdown(done),
                    Err(_) => {
                        // Every sender is gone (the daemon was dropped): stop as on SIGTERM,
                        // and stop listening to the closed channel.
                        inputs = crossbeam_channel::never();
                        let (tx, _rx) = crossbeam_channel::bounded(1);
                        self.begin_shutdown(tx);
                    }
                },
                recv(self.links.events) -> e => if let Ok(e) = e { self.on_event(e) },
                recv(self.links.samples) -> s => if let Ok(s) = s { self.on_sample(s) },
                recv(self.links.recording_failures) -> f => if let Ok(f) = f { self.on_recording_failed(f) },
                recv(ticker) -> _ => self.on_tick(),
            }
            if self.finish_shutdown_if_ready() {
                return;
            }
        }
    }

    // ----- plumbing -----

    fn seq(&mut self) -> u64 {
        let s = self.next_seq;
        self.next_seq += 1;
        s
    }

    fn now_s(&self) -> f64 {
        self.links.status.read().map(|s| s.t_s).unwrap_or(0.0)
    }

    fn send(&mut self, cmd: ControlCommand, purpose: Purpose, reply: Option<(u64, Responder)>) {
        let seq = cmd.seq();
        match self.links.commands.try_send(cmd) {
            Ok(()) => self.pending.push(Pending {
                seq,
                purpose,
                reply,
                sent: Instant::now(),
            }),
            Err(_) => {
                if let Some((id, to)) = reply {
                    self.reply_err(
                        id,
                        to,
                        ErrorCode::Unavailable,
                        "the control loop is not taking commands",
                    );
                }
            }
        }
    }

    /// Record into the open trial. Streamed samples may be dropped when the recorder lags
    /// (`try_send`); everything else waits for room, so that nothing later acknowledged as
    /// durable can be missing from the file.
    fn record(&self, topic: Topic, t_s: f64, v: &Value) {
        self.record_trial(topic, t_s, v);
        self.live_json(LiveTopic::Recorded(topic), t_s, v);
    }

    /// Record into the open trial only.
    fn record_trial(&self, topic: Topic, t_s: f64, v: &Value) {
        if self.recording_epoch().is_none() {
            return;
        }
        let msg = RecorderMsg::Write {
            topic,
            t_s,
            json: v.to_string().into_bytes(),
        };
        if matches!(topic, Topic::Events) {
            let _ = self.links.recorder.send(msg);
        } else {
            let _ = self.links.recorder.try_send(msg);
        }
    }

    /// Record a typed message into the open trial and publish it live.
    fn record_as<T: serde::Serialize>(&self, topic: Topic, t_s: f64, v: &T) {
        if !self.wanted(topic) {
            return;
        }
        match serde_json::to_value(v) {
            Ok(v) => self.record(topic, t_s, &v),
            Err(e) => tracing::error!("cannot serialize a {} record: {e}", topic.name()),
        }
    }

    /// Someone takes `topic`: the open trial's file, or a live subscriber.
    /// The open file's clock offset: the trial's, or a search's (`search_recording.rs`).
    fn recording_epoch(&self) -> Option<i128> {
        self.trial
            .as_ref()
            .map(|t| t.epoch_offset_ns)
            .or(self.search_file.as_ref().map(|f| f.epoch_offset_ns))
    }

    fn wanted(&self, topic: Topic) -> bool {
        self.recording_epoch().is_some()
            || self
                .links
                .live
                .as_ref()
                .is_some_and(|l| l.wants(LiveTopic::Recorded(topic)))
    }

    /// Record into the open trial and publish live a message that carries its own Foxglove
    /// times: built once per clock (the trial's file and the live view keep their own), by
    /// the same builder.
    fn emit<T: serde::Serialize>(&self, topic: Topic, t_s: f64, build: impl Fn(Epoch) -> T) {
        if let Some(offset_ns) = self.recording_epoch() {
            let epoch = Epoch { offset_ns };
            match serde_json::to_value(build(epoch)) {
                Ok(v) => self.record_trial(topic, t_s, &v),
                Err(e) => tracing::error!("cannot serialize a {} record: {e}", topic.name()),
            }
        }
        if let Some(live) = self.live_for(LiveTopic::Recorded(topic)) {
            self.offer_json(live, LiveTopic::Recorded(topic), t_s, &build(live.epoch()));
        }
    }

    /// A line on `/log` (foxglove.Log), in the trial's file and live.
    fn log_line(&self, t_s: f64, level: u8, message: String) {
        self.emit(Topic::Log, t_s, |epoch| fox::Log {
            timestamp: epoch.time(t_s),
            level,
            message: message.clone(),
            name: "pulsetrackd".into(),
            file: String::new(),
            line: 0,
        });
    }

    /// The daemon's own log lines since the last tick, onto `/log` at the supervisor's
    /// clock (a bounded number per tick: a burst waits for the next, or is dropped and
    /// counted by the queue).
    fn forward_log_lines(&self) {
        let t = self.now_s();
        for l in self.log_lines.try_iter().take(LOG_LINES_PER_TICK) {
            self.emit(Topic::Log, t, |epoch| fox::Log {
                timestamp: epoch.time(t),
                level: l.level,
                message: l.message.clone(),
                name: l.target.clone(),
                file: l.file.clone(),
                line: l.line,
            });
        }
    }

    /// Record a call into the trial's tracker (other than a frame), in order with the
    /// frames, for offline replay.
    fn record_tracker_call(&self, call: TrackerCall) {
        let t = self.now_s();
        self.record_as(
            Topic::Events,
            t,
            &TrackerInputRecord {
                event: "tracker_input".into(),
                t_s: t,
                call,
            },
        );
    }

    /// Tell the trial's tracker that its target cannot be reached.
    fn tracker_target_unreachable(&mut self) {
        if self.tracker.is_none() {
            return;
        }
        self.record_tracker_call(TrackerCall::TargetUnreachable);
        if let Some(tr) = self.tracker.as_mut() {
            tr.target_unreachable();
        }
    }

    /// Tell the trial's tracker to stop.
    fn tracker_stop(&mut self) {
        if self.tracker.is_none() {
            return;
        }
        self.record_tracker_call(TrackerCall::Stop);
        if let Some(tr) = self.tracker.as_mut() {
            tr.stop();
        }
    }

    /// Send a reply through the recorder, recording it (with who asked) in the open trial.
    fn answer(&self, to: Responder, reply: Value, durable: bool) {
        if self.recording_epoch().is_some() {
            let t = self.now_s();
            let record = ReplyRecord {
                event: "reply".into(),
                t_s: t,
                id: reply.get("id").and_then(Value::as_u64),
                reply: reply.as_object().cloned().unwrap_or_default(),
                client: to.client,
            };
            self.record_as(Topic::Events, t, &record);
            if reply.get("ok") != Some(&Value::Bool(true)) {
                self.log_line(
                    t,
                    level::WARNING,
                    format!(
                        "request {} from uid {} refused: {}",
                        record.id.map(|i| i.to_string()).unwrap_or("-".into()),
                        to.client.uid,
                        reply.get("reason").and_then(Value::as_str).unwrap_or("")
                    ),
                );
            }
        }
        let _ = self
            .links
            .recorder
            .send(RecorderMsg::Reply { to, reply, durable });
    }

    fn publish(&self, stream: Stream, counter: u64, v: &Value, durable: bool) {
        let _ = self.links.recorder.send(RecorderMsg::Publish {
            event: StreamEvent::new(stream, counter, v),
            durable,
        });
    }

    fn reply_ok(&self, id: u64, to: Responder, result: Value, durable: bool) {
        let mut result = result;
        if let Value::Object(o) = &mut result {
            o.insert("state".into(), Value::from(self.state.as_str()));
        }
        self.answer(to, ok_reply(id, result), durable);
    }

    fn reply_err(&self, id: u64, to: Responder, code: ErrorCode, reason: &str) {
        let mut r = error_reply(Some(id), code, reason);
        if let Value::Object(o) = &mut r {
            o.insert("state".into(), Value::from(self.state.as_str()));
        }
        self.answer(to, r, false);
    }

    fn set_state(&mut self, s: OpState) {
        if s == self.state {
            return;
        }
        let from = self.state;
        self.state = s;
        self.links
            .shared_state
            .store(state_code(s), Ordering::Release);
        let t = self.now_s();
        let v = json!({
            "event": "state",
            "t_s": t,
            "state": s.as_str(),
            "from": from.as_str(),
            "seeds": self.trial.as_ref().map(|t| t.seeds()).unwrap_or(0),
        });
        tracing::info!(target: ALREADY_ON_LOG, "state {} -> {}", from.as_str(), s.as_str());
        self.record(Topic::Events, t, &v);
        let lvl = if s == OpState::Fault {
            level::ERROR
        } else {
            level::INFO
        };
        self.log_line(t, lvl, format!("state {} -> {}", from.as_str(), s.as_str()));
        self.live_state(t);
        self.publish(Stream::State, 0, &v, false);
    }

    fn context(&self) -> Context {
        Context {
            seeds: self.trial.as_ref().map(|t| t.seeds()).unwrap_or(0),
            seeds_needed: 2,
            debug_hooks: self.s.debug_hooks,
            trial_open: self.trial.is_some(),
            calibrating: self.calibration.recording(),
        }
    }

    fn in_workspace(&self, p: SurfacePoint) -> bool {
        p.is_finite()
            && (self.s.workspace_x_m[0]..=self.s.workspace_x_m[1]).contains(&p.x_m)
            && (self.s.workspace_z_m[0]..=self.s.workspace_z_m[1]).contains(&p.z_m)
    }

    // ----- console requests -----

    fn start_trial(&mut self, t: f64) {
        if self.trial.is_some() {
            self.end_trial(TrialEnd::Abandoned);
        }
        let tracker = match (self.factory)(&self.calibration.sensor()) {
            Ok(tr) => tr,
            Err(e) => {
                tracing::error!("building tracker {}: {e}", self.s.tracker_name);
                return;
            }
        };
        let (id, epoch_offset_ns) = self.new_recording("", t);
        let mut trial_meta = BTreeMap::new();
        trial_meta.insert("trial".to_string(), id.clone());
        trial_meta.insert("tracker".to_string(), tracker.name().to_string());
        trial_meta.insert("backend".to_string(), self.info.kind.to_string());
        trial_meta.insert("context".to_string(), self.s.trial_context.to_string());
        trial_meta.insert(
            "calibration".to_string(),
            self.calibration
                .describe(self.tissue_stale().as_deref())
                .to_string(),
        );
        if let Some(cal) = self.calibration.tactile()
            && let Ok(j) = serde_json::to_string(&calibration::json_safe(cal))
        {
            // What replay needs to feed the frames through as the tracker saw them.
            trial_meta.insert("tactile_calibration".to_string(), j);
        }
        self.open_recording(&id, "trial", trial_meta, t, epoch_offset_ns);
        let trial = Trial::new(id.clone(), tracker.name().to_string(), t, epoch_offset_ns);
        let mut tracker = tracker;
        let approach = self.approach.hand_to(tracker.as_mut());
        self.tracker = Some(tracker);
        self.trial = Some(trial);
        let v = json!({"event": "trial", "phase": "started", "t_s": t, "trial": id,
            "recording": self.s.recording_dir.join(format!("{id}.mcap"))});
        self.record(Topic::Events, t, &v);
        // In order, before the first frame the tracker sees: what replay hands it too.
        for p in approach {
            self.record_tracker_call(TrackerCall::Approach {
                x_m: p.x_m,
                z_m: p.z_m,
            });
        }
        self.log_line(t, level::INFO, format!("trial {id} started"));
        self.record_true_path(t);
        self.live_scene(t);
        self.publish(Stream::Trials, 0, &v, true);
    }

    /// A new recording's name (`<prefix><UTC stamp>-<n>`) and its clock offset for daemon
    /// time `t`.
    fn new_recording(&self, prefix: &str, t: f64) -> (String, i128) {
        let now = std::time::SystemTime::now();
        let id = format!("{prefix}{}-{}", utc_stamp(now), self.next_seq);
        (id, epoch_offset_ns(now, t))
    }

    /// Open the recorder's file `<id>.mcap` with `meta` as its `kind` metadata record (the
    /// clock's entries added) and the configured records after it.
    fn open_recording(
        &self,
        id: &str,
        kind: &str,
        mut meta: BTreeMap<String, String>,
        t: f64,
        epoch_offset_ns: i128,
    ) {
        meta.insert("started_t_s".to_string(), json!(t).to_string());
        meta.insert("epoch_offset_ns".to_string(), epoch_offset_ns.to_string());
        meta.insert(
            "clock".to_string(),
            "log and publish times are Unix ns = epoch_offset_ns + t_s * 1e9; t_s in each message is the daemon clock (simulated time on the sim backend)".to_string(),
        );
        let mut metadata = vec![(kind.to_string(), meta)];
        metadata.extend(self.s.trial_metadata.iter().cloned());
        let _ = self.links.recorder.send(RecorderMsg::Open {
            id: id.to_string(),
            metadata,
            epoch_offset_ns,
        });
    }

    fn end_trial(&mut self, end: TrialEnd) {
        let Some(trial) = self.trial.take() else {
            return;
        };
        self.tracker = None;
        self.tracker_target = None;
        let t = self.now_s();
        let recording = self.s.recording_dir.join(format!("{}.mcap", trial.id));
        let summary = trial.summary(
            end,
            t,
            self.judge.as_deref(),
            &recording.display().to_string(),
            self.s.trial_context.clone(),
        );
        let ev = json!({"event": "trial", "phase": "ended", "t_s": t, "trial": trial.id,
            "end_reason": end.as_str(), "summary": summary});
        // Record the end into the file, then close it, then announce.
        let _ = self.links.recorder.send(RecorderMsg::Write {
            topic: Topic::Events,
            t_s: t,
            json: ev.to_string().into_bytes(),
        });
        tracing::info!(target: ALREADY_ON_LOG, "trial {} ended: {}", trial.id, end.as_str());
        // The trial is closed: these reach the live view only (the file gets its own below).
        self.live_json(LiveTopic::Recorded(Topic::Events), t, &ev);
        self.log_line(
            t,
            level::INFO,
            format!("trial {} ended: {}", trial.id, end.as_str()),
        );
        self.live_period(None);
        let line = fox::Log {
            timestamp: fox::Time::from_ns(epoch_ns(trial.epoch_offset_ns, t)),
            level: level::INFO,
            message: format!("trial {} ended: {}", trial.id, end.as_str()),
            name: "pulsetrackd".into(),
            file: String::new(),
            line: 0,
        };
        if let Ok(json) = serde_json::to_vec(&line) {
            let _ = self.links.recorder.send(RecorderMsg::Write {
                topic: Topic::Log,
                t_s: t,
                json,
            });
        }
        self.last_trial = Some(summary.clone());
        let _ = self.links.recorder.send(RecorderMsg::Close {
            summary,
            then: Some(StreamEvent::new(Stream::Trials, 0, &ev)),
        });
    }

    // ----- the loop's events -----

    fn on_event(&mut self, e: ControlEvent) {
        match e {
            ControlEvent::Done { seq, .. } => self.on_answer(seq, None),
            ControlEvent::Refused { seq, why, .. } => self.on_answer(seq, Some(why)),
            ControlEvent::Faulted(f) => self.on_fault(f),
            ControlEvent::Timing { summary, .. } => {
                if summary.overruns > self.overruns_reported {
                    let new = summary.overruns - self.overruns_reported;
                    if summary.batched {
                        tracing::warn!(
                            "simulation slower than asked: {:.1}x real time instead of {}x ({} of its 1 ms batches fell behind, {new} new; {} control cycles of simulated time not run)",
                            summary.achieved_time_scale,
                            self.info.time_scale,
                            summary.overruns,
                            summary.skipped
                        );
                    } else {
                        tracing::warn!(
                            "control loop: {} overruns so far ({new} new), {} deadlines skipped; period p50 {:.0} us, p99 {:.0} us, p99.9 {:.0} us, max {:.0} us over {} cycles",
                            summary.overruns,
                            summary.skipped,
                            summary.p50_us,
                            summary.p99_us,
                            summary.p999_us,
                            summary.max_us,
                            summary.cycles
                        );
                    }
                    self.overruns_reported = summary.overruns;
                }
                self.timing = Some(summary);
            }
            ControlEvent::Stopped { .. } => {}
            ControlEvent::StopFound { t_s, found } => self.sweep_found(t_s, found),
            ControlEvent::SweepEnded {
                findings,
                aborted,
                at_rad,
                ..
            } => self.sweep_ended(findings, aborted, at_rad),
        }
    }

    fn on_answer(&mut self, seq: u64, refused: Option<Refusal>) {
        let Some(i) = self.pending.iter().position(|p| p.seq == seq) else {
            return;
        };
        let p = self.pending.swap_remove(i);
        let reply = p.reply;
        if let Some(why) = refused {
            let reason = why.describe();
            match p.purpose {
                Purpose::TrackerMove => {
                    tracing::info!("tracker target refused: {reason}");
                    self.tracker_target_unreachable();
                }
                Purpose::CalibrationMove => {
                    self.touches_failed(&format!("the loop refused a move: {reason}"))
                }
                Purpose::SetPlacement => self.tissue_applied(Some(reason.clone())),
                Purpose::SetPivot => self.pivot_applied(Some(reason.clone())),
                Purpose::SetJointZero => self.joints_applied(Some(reason.clone())),
                Purpose::SweepStart => self.sweeping = None,
                Purpose::ShutdownHold => {}
                _ => {}
            }
            if let Some((id, to)) = reply {
                self.reply_err(id, to, ErrorCode::Refused, &reason);
            }
            return;
        }
        let mut durable = false;
        match p.purpose {
            Purpose::Enable => self.set_state(OpState::Holding),
            Purpose::Disable => self.set_state(OpState::Disabled),
            Purpose::Reset => {
                self.fault = None;
                self.fault_detail = None;
                self.set_state(OpState::Disabled);
            }
            Purpose::Estop => {}
            Purpose::ManualMove(target) => {
                self.motion_seq = seq;
                self.placement = Some((seq, target));
                self.stopped_short = None;
                self.set_state(OpState::Moving);
            }
            Purpose::Pause => self.set_state(OpState::Paused),
            Purpose::StopHold => {
                durable = true;
                if self.state == OpState::Moving {
                    self.set_state(OpState::Holding);
                } else if matches!(
                    self.state,
                    OpState::Tracking | OpState::Paused | OpState::Seeding
                ) {
                    self.set_state(OpState::Done);
                }
            }
            Purpose::TrackerMove
            | Purpose::TrackerHold
            | Purpose::Debug
            | Purpose::ShutdownHold
            | Purpose::RecordingHold
            | Purpose::CalibrationMove
            | Purpose::Latch => {}
            Purpose::SetPlacement => self.tissue_applied(None),
            Purpose::SetPivot => self.pivot_applied(None),
            Purpose::SetJointZero => self.joints_applied(None),
            Purpose::SweepStart => self.sweep_started(),
            Purpose::SweepStop => {}
        }
        if let Some((id, to)) = reply {
            let result = match p.purpose {
                Purpose::ManualMove(_) => json!({"motion_seq": seq}),
                Purpose::SweepStart => self.sweep_reply(),
                _ => json!({}),
            };
            self.reply_ok(id, to, result, durable);
        }
    }

    fn on_fault(&mut self, f: Fault) {
        let mut reason = f.describe();
        // Whatever latched, a failed recording waiting for its own fault is part of the story.
        if let Some(p) = self.pending_latch.take() {
            self.fault_detail = Some(p.failure.describe());
        }
        if let Some(d) = &self.fault_detail {
            reason = format!("{reason}: {d}");
        }
        tracing::error!(target: ALREADY_ON_LOG, "FAULT latched: {reason}");
        self.log_line(f.t_s, level::ERROR, format!("FAULT latched: {reason}"));
        let dump = self.dump_flight_recorder(&f);
        self.search_abort();
        self.touches_failed(&format!("the arm faulted: {reason}"));
        self.sweep_failed(&format!("the arm faulted: {reason}"));
        self.end_trial(TrialEnd::Fault);
        self.fault = Some((f, dump.clone()));
        self.set_state(OpState::Fault);
        for p in self.pending.drain(..).collect::<Vec<_>>() {
            let Some((id, to)) = p.reply else { continue };
            // The estop did what it was asked: its own reply says so, with the state it left.
            if p.purpose == Purpose::Estop {
                self.reply_ok(id, to, json!({"fault": f.kind}), false);
                continue;
            }
            let mut r = error_reply(Some(id), ErrorCode::Refused, &format!("fault: {reason}"));
            if let Value::Object(o) = &mut r {
                o.insert("state".into(), Value::from("fault"));
            }
            self.answer(to, r, false);
        }
        let v = json!({"event": "fault", "t_s": f.t_s, "fault": f.kind, "reason": reason,
            "axis": f.axis, "value": finite_or_null(f.value), "limit": finite_or_null(f.limit),
            "flight_recorder": dump});
        self.publish(Stream::Faults, 0, &v, true);
    }

    /// The trial's recording cannot be written: stop the trial, bring the arm to rest, then
    /// latch `recording_failed` (on the tick that sees it settled, or at the stop timeout).
    fn on_recording_failed(&mut self, failure: RecordingFailure) {
        tracing::error!(
            "{}: stopping the trial, holding, then latching recording_failed",
            failure.describe()
        );
        self.tracker_stop();
        self.end_trial(TrialEnd::RecordingFailed);
        self.search_abort();
        if self.fault.is_some() || self.pending_latch.is_some() {
            return;
        }
        let hold_seq = if self.state.powered() {
            let seq = self.seq();
            self.motion_seq = seq;
            self.send(ControlCommand::Hold { seq }, Purpose::RecordingHold, None);
            if matches!(
                self.state,
                OpState::Tracking | OpState::Paused | OpState::Seeding | OpState::Moving
            ) {
                self.set_state(OpState::Holding);
            }
            Some(seq)
        } else {
            None
        };
        self.pending_latch = Some(PendingLatch {
            failure,
            hold_seq,
            deadline: Instant::now() + self.s.stop_timeout,
            latch_sent: false,
        });
        self.latch_if_rested();
    }

    fn latch_if_rested(&mut self) {
        let Some(p) = self.pending_latch.as_ref() else {
            return;
        };
        if p.latch_sent {
            return;
        }
        let rested = self.at_rest_after(p.hold_seq);
        if !rested && Instant::now() < p.deadline {
            return;
        }
        if let Some(p) = self.pending_latch.as_mut() {
            p.latch_sent = true;
        }
        let seq = self.seq();
        self.send(
            ControlCommand::Latch {
                seq,
                kind: FaultKind::RecordingFailed,
            },
            Purpose::Latch,
            None,
        );
    }

    /// Dump the frozen ring to a new `fault-<utc>-<kind>[-N].jsonl`: two faults in the same
    /// second get two files, and a planted link is never followed.
    fn dump_flight_recorder(&self, f: &Fault) -> Option<PathBuf> {
        let dir = &self.s.recording_dir;
        if let Err(e) = crate::private_fs::ensure_private_dir(dir) {
            tracing::error!("flight recorder: {e}");
            return None;
        }
        let stem = format!(
            "fault-{}-{}",
            utc_stamp(std::time::SystemTime::now()),
            f.kind.as_str()
        );
        let (path, file) = match crate::private_fs::create_unique(dir, &stem, "jsonl") {
            Ok(x) => x,
            Err(e) => {
                tracing::error!(
                    "flight recorder: cannot create {stem}.jsonl in {}: {e}",
                    dir.display()
                );
                return None;
            }
        };
        match self.links.flight.dump_to(file) {
            Ok(n) => {
                tracing::error!(
                    "flight recorder: {n} cycles before the fault in {}",
                    path.display()
                );
                Some(path)
            }
            Err(e) => {
                tracing::error!("flight recorder dump to {} failed: {e}", path.display());
                None
            }
        }
    }

    // ----- frames and joint samples -----

    fn on_sample(&mut self, s: LoopSample) {
        match s {
            LoopSample::Joints { status, truth } => {
                self.truth = truth;
                self.record_as(
                    Topic::Joints,
                    status.t_s,
                    &report::joint_sample(&status, self.state),
                );
                self.record_frame_tree(&status);
                if status.sensor.is_finite() {
                    self.record_pose(
                        Topic::SensorBelieved,
                        status.t_s,
                        status.sensor.x_m,
                        status.sensor.z_m,
                    );
                }
                if let Some(t) = truth {
                    self.record_as(Topic::Truth, t.t_s, &t.sample());
                    self.record_pose(Topic::SensorTrue, t.t_s, t.sensor_x_m, t.sensor_z_m);
                }
            }
            LoopSample::Frame(f) => self.on_frame(f),
        }
    }

    /// The arm as Foxglove frames under `base` (the Phantom's own frame): the tissue frame
    /// (fixed, from the configured placement), the gimbal point from the encoders, the pivot
    /// (fixed), and the sensor centre (a child of `tissue`, where it is computed). The 3D
    /// panel then shows the gimbal, the pivot and the sensor on the line of the rod.
    fn record_frame_tree(&self, status: &ControlStatus) {
        use control::kinematics::{phantom, pivot};
        let Some(arm) = self.s.arm.as_ref() else {
            return;
        };
        if !self.wanted(Topic::Transforms) {
            return;
        }
        let q = &status.position_rad;
        let (Ok(gimbal), Ok(sensor)) = (
            phantom::forward(arm.phantom(), q),
            arm.sensor_from_joints(q),
        ) else {
            return;
        };
        let pivot = pivot::pivot_point(arm.pivot()).0;
        let placement = arm.placement();
        let v = |p: &nalgebra::Point3<f64>| fox::Vector3 {
            x: p.x,
            y: p.y,
            z: p.z,
        };
        let half = placement.yaw_rad / 2.0;
        let [ox, oy, oz] = placement.origin_in_base_m;
        self.emit(Topic::Transforms, status.t_s, |epoch| {
            let timestamp = epoch.time(status.t_s);
            let frame = |child: &str, translation: fox::Vector3, rotation: fox::Quaternion| {
                fox::FrameTransform {
                    timestamp,
                    parent_frame_id: "base".into(),
                    child_frame_id: child.into(),
                    translation,
                    rotation,
                }
            };
            // The sensor centre is computed in the tissue frame.
            let sensor_in_tissue = fox::FrameTransform {
                parent_frame_id: TISSUE_FRAME.into(),
                ..frame("sensor", v(&sensor), fox::Quaternion::IDENTITY)
            };
            fox::FrameTransforms {
                transforms: vec![
                    frame(
                        TISSUE_FRAME,
                        fox::Vector3 {
                            x: ox,
                            y: oy,
                            z: oz,
                        },
                        fox::Quaternion {
                            x: 0.0,
                            y: half.sin(),
                            z: 0.0,
                            w: half.cos(),
                        },
                    ),
                    frame("gimbal", v(&gimbal.0), fox::Quaternion::IDENTITY),
                    frame("pivot", v(&pivot), fox::Quaternion::IDENTITY),
                    sensor_in_tissue,
                ],
            }
        });
    }

    fn record_pose(&self, topic: Topic, t_s: f64, x_m: f64, z_m: f64) {
        if !self.wanted(topic) {
            return;
        }
        self.emit(topic, t_s, |epoch| fox::PoseInFrame {
            timestamp: epoch.time(t_s),
            frame_id: TISSUE_FRAME.into(),
            pose: fox::Pose::at_surface(x_m, z_m),
        });
    }

    fn on_tick(&mut self) {
        self.links.heartbeat.fetch_add(1, Ordering::Relaxed);
        self.calibration_tick();
        self.forward_log_lines();
        let now = Instant::now();
        let timeout = self.s.command_timeout;
        let mut expired = Vec::new();
        self.pending.retain_mut(|p| {
            if now.duration_since(p.sent) > timeout {
                expired.push(p.reply.take());
                false
            } else {
                true
            }
        });
        for (id, to) in expired.into_iter().flatten() {
            self.reply_err(
                id,
                to,
                ErrorCode::Unavailable,
                "the control loop did not answer in time",
            );
        }
        if self.pending_latch.is_some() {
            self.latch_if_rested();
        }
        if self.state == OpState::Moving
            && let Some(st) = self.links.status.read()
            && st.motion_seq == self.motion_seq
        {
            if st.settled {
                self.set_state(OpState::Holding);
            } else if let Some(s) = st.shortfall {
                self.on_stopped_short(st.motion_seq, s);
            }
        }
        if now.duration_since(self.last_state_beat) >= Duration::from_millis(250) {
            self.last_state_beat = now;
            if let Some(st) = self.links.status.read() {
                let v = report::state_beat(&st, self.state, self.trial.as_ref());
                self.publish(Stream::State, 0, &v, false);
                self.live_beat(&st);
            }
        }
    }

    // ----- shutdown -----

    fn begin_shutdown(&mut self, done: Sender<()>) {
        if self.shutdown.is_some() {
            let _ = done.send(());
            return;
        }
        tracing::info!("controlled stop: ending the trial, coming to rest, powering off");
        match self.state {
            OpState::Tracking | OpState::Paused | OpState::Seeding => self.tracker_stop(),
            _ => {}
        }
        self.end_trial(TrialEnd::Shutdown);
        self.search_abort();
        let sweeping = self.sweeping.is_some();
        if sweeping {
            // The joint sweep holds no Cartesian pose to rest at: power off where it is.
            self.sweep_failed("the daemon is stopping: the arm was powered off where it was");
            let seq = self.seq();
            self.send(ControlCommand::Disable { seq }, Purpose::Disable, None);
        }
        let hold_seq = if self.state.powered() && !sweeping {
            let seq = self.seq();
            self.motion_seq = seq;
            self.send(ControlCommand::Hold { seq }, Purpose::ShutdownHold, None);
            Some(seq)
        } else {
            None
        };
        self.shutdown = Some(Shutdown {
            done,
            deadline: Instant::now() + self.s.stop_timeout,
            hold_seq,
        });
    }

    /// The hold with this sequence number has settled, or the arm is no longer powered
    /// (nothing to wait for without a hold).
    fn at_rest_after(&self, hold_seq: Option<u64>) -> bool {
        let Some(seq) = hold_seq else {
            return true;
        };
        self.links
            .status
            .read()
            .map(|s| {
                s.motion_seq == seq && s.settled || s.mode != crate::rt::link::LoopMode::Enabled
            })
            .unwrap_or(true)
    }

    fn finish_shutdown_if_ready(&mut self) -> bool {
        let Some(sd) = self.shutdown.as_ref() else {
            return false;
        };
        let rested = self.at_rest_after(sd.hold_seq);
        if !rested && Instant::now() < sd.deadline {
            return false;
        }
        if self.state.powered() {
            let seq = self.seq();
            let _ = self
                .links
                .commands
                .try_send(ControlCommand::Disable { seq });
            self.set_state(OpState::Disabled);
        }
        if let Some(sd) = self.shutdown.take() {
            let _ = sd.done.send(());
        }
        true
    }

    fn status_json(&self) -> Value {
        let mut v = report::status_json(
            self.links.status.read().unwrap_or_default(),
            self.fault.as_ref(),
            &self.info,
            self.trial.as_ref(),
            self.last_trial.as_ref(),
            self.timing,
            self.frames_seen,
        );
        if let (Some(d), Some(f)) = (&self.fault_detail, v.get_mut("fault"))
            && let Value::Object(o) = f
        {
            o.insert("detail".into(), Value::from(d.as_str()));
        }
        if let Value::Object(o) = &mut v {
            o.insert("live".into(), self.live_status());
            let stale = self.tissue_stale();
            o.insert(
                "calibration".into(),
                self.calibration.describe(stale.as_deref()),
            );
        }
        v
    }
}

fn finite_or_null(v: f64) -> Value {
    if v.is_finite() { json!(v) } else { Value::Null }
}
