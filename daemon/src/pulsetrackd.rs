//! `pulsetrackd`: wiring config -> backend -> tasks, running until SIGTERM/SIGINT (or, in
//! process, until [`Daemon::shutdown`]), then stopping in order: the trial ends, the arm
//! comes to rest and powers off, the loop stops, the recording closes.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, AtomicU64};
use std::time::Duration;

use clap::Parser;
use config::Config;
use control::frames::SurfacePoint;
use serde_json::json;

use crate::backend;
use crate::console::hub::StreamHub;
use crate::console::protocol::ParseLimits;
use crate::console::server::{self, ServerLinks, ServerSettings};
use crate::instance_lock::{InstanceLock, LockError};
use crate::live::server::{LiveError, LiveServer, LiveSettings};
use crate::recording::recorder::{Recorder, RecorderMsg, RecorderSettings};
use crate::recording::trial_file::{Epoch, epoch_offset_ns};
use crate::rt::control_loop::{ControlLoop, LoopLinks};
use crate::rt::flight_recorder::FlightRecorder;
use crate::rt::safety::SafetyLimits;
use crate::rt::thread::{LoopThread, Pacing};
use crate::service::{logging, systemd};
use crate::slot::Slot;
use crate::supervisor::{Supervisor, SupervisorInput, SupervisorLinks, SupervisorSettings};

#[derive(Debug, Parser)]
#[command(
    name = "pulsetrackd",
    version,
    about = "The pulsetrack tracking daemon"
)]
struct Args {
    /// Configuration file (RON). Without it, the embedded simulated bench (config/sim.ron).
    #[arg(long)]
    config: Option<PathBuf>,
}

/// A configuration and where it came from.
#[derive(Debug, Clone)]
pub struct LoadedConfig {
    pub config: Config,
    pub origin: String,
    /// Relative paths in the file resolve against this (None for the embedded default).
    pub dir: Option<PathBuf>,
}

impl LoadedConfig {
    /// The file given, or the embedded sim default, with `{runtime}` and `{state}` in its
    /// socket and recording paths resolved for this user ([`crate::runtime_paths`]).
    pub fn load(path: Option<&Path>) -> Result<Self, config::ConfigError> {
        let mut l = Self::load_unexpanded(path)?;
        let c = &mut l.config;
        c.console.socket_path = crate::runtime_paths::expand(&c.console.socket_path)
            .display()
            .to_string();
        c.recording.dir = crate::runtime_paths::expand(&c.recording.dir)
            .display()
            .to_string();
        // A relative calibration file lies beside the config file.
        let file = crate::runtime_paths::expand(&c.calibration.file);
        c.calibration.file = match &l.dir {
            Some(d) if file.is_relative() => d.join(file),
            _ => file,
        }
        .display()
        .to_string();
        Ok(l)
    }

    /// The file given, or the embedded default, with `{runtime}` and `{state}` left as written.
    pub fn load_unexpanded(path: Option<&Path>) -> Result<Self, config::ConfigError> {
        match path {
            Some(p) => {
                let l = config::load_file::<Config>(p)?;
                Ok(Self {
                    config: l.value,
                    origin: l.origin,
                    dir: l.dir,
                })
            }
            None => {
                let (name, text) = config::shipped::SIM_CONFIG;
                Ok(Self {
                    config: config::load_str::<Config>(name, text)?,
                    origin: format!("<embedded {name}>"),
                    dir: None,
                })
            }
        }
    }
}

/// Entry point of the `pulsetrackd` program.
pub fn main() -> ExitCode {
    let args = Args::parse();
    crate::rt::os::ignore_file_size_signal();
    let sink = logging::init("info");
    let loaded = match LoadedConfig::load(args.config.as_deref()) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    tracing::info!(
        "pulsetrackd {} starting with {} (logging to {sink:?})",
        env!("CARGO_PKG_VERSION"),
        loaded.origin
    );
    let daemon = match Daemon::start(loaded) {
        Ok(d) => d,
        Err(e) => {
            tracing::error!("{e}");
            eprintln!("pulsetrackd: {e}");
            return ExitCode::from(e.exit_code());
        }
    };
    systemd::ready(&format!("console on {}", daemon.socket_path().display()));
    let signal = daemon.wait_for_signal();
    tracing::info!("{signal}: stopping");
    systemd::stopping();
    match daemon.shutdown() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            tracing::error!("shutdown: {e}");
            ExitCode::FAILURE
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum StartError {
    #[error(transparent)]
    Backend(#[from] backend::OpenError),
    #[error("control core: {0}")]
    Control(String),
    #[error("console socket {path}: {source}")]
    Socket {
        path: String,
        source: std::io::Error,
    },
    #[error("{what}: {source}")]
    Io {
        what: String,
        source: std::io::Error,
    },
    /// Another daemon holds this configuration, or a directory is not the daemon's own.
    #[error(transparent)]
    Lock(#[from] LockError),
    /// The live view could not start (its port taken, most often).
    #[error(transparent)]
    Live(#[from] LiveError),
}

impl StartError {
    /// 2 when the configuration itself is wrong (a restart cannot help: the shipped unit's
    /// `RestartPreventExitStatus=2`), 1 when a retry may succeed (a device not yet plugged
    /// in, another daemon still stopping).
    pub fn exit_code(&self) -> u8 {
        match self {
            StartError::Backend(backend::OpenError::Config(_))
            | StartError::Control(_)
            | StartError::Lock(LockError::Folder(_)) => 2,
            _ => 1,
        }
    }
}

fn io_err(what: impl Into<String>) -> impl FnOnce(std::io::Error) -> StartError {
    let what = what.into();
    move |source| StartError::Io { what, source }
}

/// The runtime for I/O: the console, signals, the watchdog, the serial driver.
fn io_runtime() -> std::io::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .thread_name("pulsetrack-io")
        .enable_all()
        .build()
}

/// What the daemon drives: the backend's ports, the servo and a tracker per trial.
pub struct Parts {
    pub backend: backend::Backend,
    pub servo: Box<dyn crate::rt::servo::Servo>,
    pub tracker: crate::supervisor::TrackerFactory,
}

impl std::fmt::Debug for Parts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Parts")
            .field("backend", &self.backend)
            .finish()
    }
}

/// A running daemon.
pub struct Daemon {
    runtime: tokio::runtime::Runtime,
    supervisor_tx: crossbeam_channel::Sender<SupervisorInput>,
    supervisor: Option<std::thread::JoinHandle<()>>,
    recorder_tx: crossbeam_channel::Sender<RecorderMsg>,
    recorder: Option<std::thread::JoinHandle<()>>,
    control: Option<LoopThread>,
    server: Option<tokio::task::JoinHandle<()>>,
    live: Option<LiveServer>,
    socket_path: PathBuf,
    stop_timeout: Duration,
    /// Released last, when the daemon is dropped.
    _lock: InstanceLock,
}

/// The calibration file's results that passed, applied from the start; a file that cannot
/// be read or used stops the start (exit 2), naming the file and the field: running on as if
/// uncalibrated would silently change what the trackers read.
fn calibration_at_start(
    c: &Config,
    time_scale: f64,
    bench: Option<Box<dyn crate::backend::ArrayBench>>,
) -> Result<crate::supervisor::calibration::Calibration, StartError> {
    use crate::supervisor::calibration::{Calibration, CalibrationSettings, usable_record};
    let settings = CalibrationSettings {
        file: PathBuf::from(&c.calibration.file),
        tolerances: c.calibration.tolerances,
        tactile: c.calibration.tactile,
        tactile_recording_s: c.calibration.tactile_recording_s,
        touch: c.calibration.tissue,
        sensor: c.sensor,
        time_scale,
        joints: c.calibration.joints,
        joint_limits: c.robot.joint_limits,
    };
    let file = config::calibration_file::load(&settings.file)
        .map_err(|e| StartError::Control(format!("calibration file: {e}")))?
        .map(|l| l.value)
        .unwrap_or_default();
    let unusable = |e: String| {
        StartError::Control(format!("calibration file {}: {e}", settings.file.display()))
    };
    let tissue = file
        .tissue
        .map(|r| {
            let p = crate::supervisor::calibration::usable_tissue(&r).map_err(unusable)?;
            tracing::info!(
                "tissue frame of {} from {} in use: origin {:?} m, yaw {:.3} deg",
                r.measured_utc,
                settings.file.display(),
                p.origin_in_base_m,
                p.yaw_rad.to_degrees()
            );
            Ok::<_, StartError>(r)
        })
        .transpose()?;
    let pivot = file
        .pivot
        .map(|r| {
            let p = crate::supervisor::calibration::usable_pivot(&r).map_err(unusable)?;
            tracing::info!(
                "pivot of {} from {} in use: {:?} m (moved {:+.2}, {:+.2} mm in base x, z)",
                r.measured_utc,
                settings.file.display(),
                p,
                r.offset_m[0] * 1e3,
                r.offset_m[1] * 1e3
            );
            Ok::<_, StartError>(r)
        })
        .transpose()?;
    let joints = file
        .joints
        .map(|r| {
            let o = crate::supervisor::calibration::usable_joints(&r).map_err(unusable)?;
            tracing::info!(
                "encoder zero of {} from {} in use: offsets {:?} rad",
                r.measured_utc,
                settings.file.display(),
                o
            );
            for line in crate::supervisor::joints_sweep::inside_limits(&r.stops) {
                tracing::warn!("{}: {line}", settings.file.display());
            }
            Ok::<_, StartError>(r)
        })
        .transpose()?;
    let tactile = match file.tactile {
        None => {
            tracing::info!(
                "no tactile calibration in {}: the array is read as configured",
                settings.file.display()
            );
            None
        }
        Some(r) => match usable_record(&r, &settings.sensor) {
            Ok(g) => {
                tracing::info!(
                    "tactile calibration of {} from {} in use: elements {:?} skipped, noise {:.4} N",
                    r.measured_utc,
                    settings.file.display(),
                    Vec::<usize>::from(g.skip_elements),
                    g.noise_sd_n
                );
                Some(r)
            }
            Err(e) => {
                return Err(StartError::Control(format!(
                    "calibration file {}: {e}",
                    settings.file.display()
                )));
            }
        },
    };
    Ok(Calibration::new(
        settings, tactile, tissue, pivot, joints, bench,
    ))
}

/// Take the configuration's instance lock (which also checks its directories).
fn lock_instance(c: &Config) -> Result<InstanceLock, StartError> {
    InstanceLock::acquire(
        Path::new(&c.console.socket_path),
        Path::new(&c.recording.dir),
    )
    .map_err(StartError::Lock)
}

impl std::fmt::Debug for Daemon {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Daemon")
            .field("socket_path", &self.socket_path)
            .finish()
    }
}

impl Daemon {
    /// Open the backend the config names, start every task, bind the console socket.
    pub fn start(loaded: LoadedConfig) -> Result<Daemon, StartError> {
        let c = &loaded.config;
        // Before anything else: a second daemon on this config must not touch the first
        // one's trial files or devices.
        let lock = lock_instance(c)?;
        let runtime = io_runtime().map_err(io_err("starting the I/O runtime"))?;
        let parts = Parts {
            backend: backend::open(c, loaded.dir.as_deref(), runtime.handle())?,
            servo: crate::rt::core_servo::build(c).map_err(StartError::Control)?,
            tracker: crate::rt::core_servo::tracker_factory(c).map_err(StartError::Control)?,
        };
        Self::start_on(loaded, parts, runtime, lock)
    }

    /// Start with the given backend, servo and trackers (tests substitute doubles here).
    pub fn start_with(loaded: LoadedConfig, parts: Parts) -> Result<Daemon, StartError> {
        let lock = lock_instance(&loaded.config)?;
        let runtime = io_runtime().map_err(io_err("starting the I/O runtime"))?;
        Self::start_on(loaded, parts, runtime, lock)
    }

    fn start_on(
        loaded: LoadedConfig,
        parts: Parts,
        runtime: tokio::runtime::Runtime,
        lock: InstanceLock,
    ) -> Result<Daemon, StartError> {
        let c = &loaded.config;
        let Parts {
            backend: opened,
            mut servo,
            tracker: factory,
        } = parts;

        let recording_dir = PathBuf::from(&c.recording.dir);
        crate::recording::startup::recover_unfinished(&recording_dir);

        let (cmd_tx, cmd_rx) = crossbeam_channel::bounded(64);
        let (ev_tx, ev_rx) = crossbeam_channel::bounded(4096);
        let (sample_tx, sample_rx) = crossbeam_channel::bounded(16_384);
        let (sup_tx, sup_rx) = crossbeam_channel::bounded(256);
        let (rec_tx, rec_rx) = crossbeam_channel::bounded(65_536);
        let status = Arc::new(Slot::new());
        let rate_hz = c.control.rate_hz;
        let flight = FlightRecorder::new((c.safety.flight_recorder_s * rate_hz).ceil() as usize);
        let heartbeat = Arc::new(AtomicU64::new(0));
        let shared_state = Arc::new(AtomicU8::new(0));
        let hub = StreamHub::new();
        // Before the loop starts, so that its clock (0 at start) maps onto now.
        let (live, live_tap) = if c.live.enabled {
            let epoch = Epoch {
                offset_ns: epoch_offset_ns(std::time::SystemTime::now(), 0.0),
            };
            let settings = LiveSettings::from_config(c, epoch)?;
            let (server, tap) = LiveServer::start(&settings)?;
            (Some(server), Some(tap))
        } else {
            (None, None)
        };

        let (failure_tx, failure_rx) = crossbeam_channel::bounded(16);
        let recorder = Recorder::new(
            RecorderSettings {
                dir: recording_dir.clone(),
                flush_interval: Duration::from_secs_f64(c.recording.flush_interval_s),
                fsync_interval: Duration::from_secs_f64(c.recording.fsync_interval_s),
            },
            hub.clone(),
        )
        .on_failure(Box::new(move |f| {
            // At most one per trial: the channel never fills.
            let _ = failure_tx.try_send(f);
        }));
        let recorder = std::thread::Builder::new()
            .name("pulsetrack-rec".into())
            .spawn(move || recorder.run(rec_rx))
            .map_err(io_err("starting the recorder thread"))?;

        let info = opened.info.clone();
        let calibration = calibration_at_start(c, info.time_scale, opened.array_bench)?;
        // A calibrated pivot and tissue frame replace the configured ones for the kinematics
        // (the simulator's truth stays where the config and the scene put it).
        let mut arm = c.robot.arm_model().ok();
        if let Some(r) = calibration.pivot_record() {
            let pivot = control::kinematics::PivotGeometry {
                pivot_in_base_m: r.pivot_in_base_m,
                ..c.robot.pivot
            };
            servo.set_pivot(0.0, pivot, None).map_err(|e| {
                StartError::Control(format!(
                    "calibration file {}: its pivot cannot be used: {}",
                    c.calibration.file,
                    e.describe()
                ))
            })?;
            arm = arm.and_then(|a| a.with_pivot(pivot).ok());
        }
        if let Some(r) = calibration.tissue_record() {
            servo.set_placement(0.0, r.placement, None).map_err(|e| {
                StartError::Control(format!(
                    "calibration file {}: its tissue frame cannot be used: {}",
                    c.calibration.file,
                    e.describe()
                ))
            })?;
            arm = arm.and_then(|a| a.with_placement(r.placement).ok());
        }
        let wall_bound = info.wall_clock_bound;
        let time_scale = info.time_scale;
        let stop_timeout = Duration::from_secs_f64((5.0 / time_scale).clamp(0.5, 5.0));
        let control = ControlLoop::new(
            opened.arm,
            opened.tactile,
            servo,
            SafetyLimits::from_config(c),
            rate_hz,
            LoopLinks {
                commands: cmd_rx,
                events: ev_tx,
                samples: sample_tx,
                status: Arc::clone(&status),
                flight: flight.clone(),
                joint_every: c.recording.joint_decimation,
            },
        )
        .with_zero_offset(calibration.joint_zero());

        let settings = SupervisorSettings {
            tracker_name: c.tracker.name.clone(),
            home: SurfacePoint::new(c.operation.home_m[0], c.operation.home_m[1]),
            move_speed_m_s: c.operation.move_speed_m_s,
            max_speed_m_s: c.control.motion.max_speed_m_s,
            workspace_x_m: c.safety.workspace_x_m,
            workspace_z_m: c.safety.workspace_z_m,
            debug_hooks: c.console.debug_hooks,
            recording_dir: recording_dir.clone(),
            command_timeout: Duration::from_secs(5),
            stop_timeout,
            trial_context: json!({
                "config": loaded.origin,
                "backend": info,
                "tracker": c.tracker.name,
            }),
            min_free_bytes: c.recording.min_free_bytes,
            trial_metadata: crate::recording::provenance::static_records(&loaded),
            arm,
            search: c.search,
            arrival_tolerance_m: c.control.motion.settle_tolerance_m,
        };
        let sup = Supervisor::new(
            settings,
            SupervisorLinks {
                inputs: sup_rx,
                events: ev_rx,
                samples: sample_rx,
                recording_failures: failure_rx,
                commands: cmd_tx,
                recorder: rec_tx.clone(),
                status: Arc::clone(&status),
                flight,
                heartbeat: Arc::clone(&heartbeat),
                shared_state: Arc::clone(&shared_state),
                live: live_tap,
            },
            info.clone(),
            opened.judge,
            factory,
            calibration,
        );
        let supervisor = std::thread::Builder::new()
            .name("pulsetrack-sup".into())
            .spawn(move || sup.run())
            .map_err(io_err("starting the supervisor thread"))?;

        let control = LoopThread::spawn(
            control,
            Pacing {
                rate_hz,
                time_scale,
                fifo_priority: Some(c.realtime.priority),
                lock_memory: c.realtime.lock_memory,
                report_every_s: c.realtime.overrun_report_s,
                max_consecutive_overruns: wall_bound.then_some(c.safety.max_consecutive_overruns),
            },
        )
        .map_err(io_err("starting the control loop thread"))?;

        let socket_path = PathBuf::from(&c.console.socket_path);
        let listener = runtime
            .block_on(server::bind(&socket_path))
            .map_err(|source| StartError::Socket {
                path: socket_path.display().to_string(),
                source,
            })?;
        let server_settings = Arc::new(ServerSettings {
            socket_path: socket_path.clone(),
            allowed_uids: c.console.allowed_uids.clone(),
            allowed_gids: c.console.allowed_gids.clone(),
            max_line_bytes: c.console.max_line_bytes,
            max_requests_per_s: c.console.max_requests_per_s,
            max_clients: c.console.max_clients,
            idle_timeout: Duration::from_secs_f64(c.console.idle_timeout_s),
            limits: ParseLimits {
                max_jog_m: c.operation.max_jog_m,
                max_speed_m_s: c.control.motion.max_speed_m_s,
                max_coordinate_m: 1.0,
                max_track_length_m: 2.0,
            },
            backend_kind: info.kind,
            reply_timeout: Duration::from_secs(10),
        });
        let server = runtime.spawn(server::serve(
            listener,
            server_settings,
            ServerLinks {
                supervisor: sup_tx.clone(),
                hub,
                state: shared_state,
            },
        ));
        runtime.spawn(systemd::watchdog(Arc::clone(&status), heartbeat));
        tracing::info!(
            "ready: {} backend (time scale {}), console on {}",
            info.kind,
            time_scale,
            socket_path.display()
        );
        Ok(Daemon {
            runtime,
            supervisor_tx: sup_tx,
            supervisor: Some(supervisor),
            recorder_tx: rec_tx,
            recorder: Some(recorder),
            control: Some(control),
            server: Some(server),
            live,
            socket_path,
            stop_timeout,
            _lock: lock,
        })
    }

    pub fn socket_path(&self) -> &Path {
        &self.socket_path
    }

    /// The live view's address (`ws://ADDRESS:PORT`), when it is on.
    pub fn live_url(&self) -> Option<&str> {
        self.live.as_ref().map(|l| l.url())
    }

    /// Block until SIGTERM or SIGINT; returns which.
    pub fn wait_for_signal(&self) -> &'static str {
        self.runtime.block_on(async {
            use tokio::signal::unix::{SignalKind, signal};
            let (Ok(mut term), Ok(mut int)) = (
                signal(SignalKind::terminate()),
                signal(SignalKind::interrupt()),
            ) else {
                tracing::error!("cannot install signal handlers; stopping");
                return "no signal handlers";
            };
            tokio::select! {
                _ = term.recv() => "SIGTERM",
                _ = int.recv() => "SIGINT",
            }
        })
    }

    /// The controlled stop. Waits for every task.
    pub fn shutdown(mut self) -> Result<(), String> {
        if let Some(s) = self.server.take() {
            s.abort();
        }
        let (done_tx, done_rx) = crossbeam_channel::bounded(1);
        let asked = self
            .supervisor_tx
            .send(SupervisorInput::Shutdown { done: done_tx })
            .is_ok();
        let mut problems = Vec::new();
        if asked
            && done_rx
                .recv_timeout(self.stop_timeout + Duration::from_secs(5))
                .is_err()
        {
            problems.push("the supervisor did not finish its controlled stop in time".to_string());
        }
        if let Some(c) = self.control.take() {
            c.stop();
        }
        if let Some(s) = self.supervisor.take()
            && s.join().is_err()
        {
            problems.push("the supervisor thread panicked".into());
        }
        let (rec_done_tx, rec_done_rx) = crossbeam_channel::bounded(1);
        if self
            .recorder_tx
            .send(RecorderMsg::Shutdown { done: rec_done_tx })
            .is_ok()
            && rec_done_rx.recv_timeout(Duration::from_secs(30)).is_err()
        {
            problems.push("the recorder did not close in time".into());
        }
        if let Some(r) = self.recorder.take()
            && r.join().is_err()
        {
            problems.push("the recorder thread panicked".into());
        }
        // The supervisor (the publisher's only feeder) has stopped: the publisher ends.
        if let Some(l) = self.live.take() {
            l.stop();
        }
        let _ = std::fs::remove_file(&self.socket_path);
        if problems.is_empty() {
            tracing::info!("stopped cleanly");
            Ok(())
        } else {
            Err(problems.join("; "))
        }
    }
}
