//! The `phantom-emulator` program: the Phantom's three joint amplifiers behind an emulated
//! slcan USB-CAN adapter on a pseudo-terminal. Configure the daemon with
//! `joints: (adapter: Slcan(path: "<printed path>", baud: 115200, bitrate_bps: 1000000))`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use crate::can::phantom_emulator::{PhantomEmulator, PhantomEmulatorSettings};
use clap::Parser;

#[derive(Debug, Parser)]
#[command(
    name = "phantom-emulator",
    about = "Emulated Phantom amplifiers (docs/protocols/phantom-can.md) behind slcan on a pty"
)]
struct Args {
    /// Stable path to create for the adapter (a symlink to the pty).
    #[arg(long, default_value = "/tmp/pulsetrack-slcan")]
    link: PathBuf,
    /// A daemon configuration whose `backend.Hardware.joints` to emulate (node ids,
    /// scaling); the defaults otherwise.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Initial joint angles, rad (three values).
    #[arg(
        long,
        num_args = 3,
        default_values_t = [0.0, 0.0, 0.0],
        allow_negative_numbers = true,
        conflicts_with = "initial_sensor_m"
    )]
    initial_rad: Vec<f64>,
    /// Start with the sensor centre resting on the tissue surface at this tissue-frame
    /// point `X Z`, m: the joint angles come from the `--config`'s robot geometry (the pose
    /// a surgeon would leave the rod in through the incision).
    #[arg(long, num_args = 2, requires = "config", allow_negative_numbers = true)]
    initial_sensor_m: Option<Vec<f64>>,
    /// Stop after this many seconds (0: run until killed).
    #[arg(long, default_value_t = 0.0)]
    duration_s: f64,
}

/// Joint angles that put the sensor centre on the surface at tissue-frame `[x, z]`.
pub fn pose_for_sensor(
    robot: &config::schema::RobotSection,
    at: &[f64],
) -> Result<[f64; 3], control::kinematics::KinematicsError> {
    let model = robot.arm_model()?;
    let (x_m, z_m) = (at.first().copied(), at.get(1).copied());
    let sensor = nalgebra::Point3::new(x_m.unwrap_or(f64::NAN), 0.0, z_m.unwrap_or(f64::NAN));
    model.joints_for_sensor(&sensor)
}

/// The program: parse the command line, run until killed or `--duration-s`.
pub fn main() -> ExitCode {
    let args = Args::parse();
    let mut settings = PhantomEmulatorSettings::new(&args.link);
    for (slot, v) in settings.initial_rad.iter_mut().zip(&args.initial_rad) {
        *slot = *v;
    }
    if let Some(path) = &args.config {
        match config::load_file::<config::Config>(path) {
            Ok(c) => match c.value.backend {
                config::schema::Backend::Hardware(hw) => {
                    settings.joints = hw.joints;
                    if let Some(at) = &args.initial_sensor_m {
                        match pose_for_sensor(&c.value.robot, at) {
                            Ok(q) => settings.initial_rad = q,
                            Err(e) => {
                                eprintln!(
                                    "phantom-emulator: --initial-sensor-m {at:?} with the robot \
                                     geometry of {}: {e}",
                                    path.display()
                                );
                                return ExitCode::FAILURE;
                            }
                        }
                    }
                }
                config::schema::Backend::Sim(_) => {
                    eprintln!(
                        "phantom-emulator: {} selects the simulator, not hardware",
                        path.display()
                    );
                    return ExitCode::FAILURE;
                }
            },
            Err(e) => {
                eprintln!("{e}");
                return ExitCode::FAILURE;
            }
        }
    }
    let emu = match PhantomEmulator::start(settings) {
        Ok(e) => e,
        Err(e) => {
            eprintln!(
                "phantom-emulator: cannot create the pty at {}: {e}",
                args.link.display()
            );
            return ExitCode::FAILURE;
        }
    };
    println!("{}", emu.path().display());
    let start = std::time::Instant::now();
    while args.duration_s <= 0.0 || start.elapsed().as_secs_f64() < args.duration_s {
        std::thread::sleep(Duration::from_millis(100));
    }
    match emu.stop() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("phantom-emulator: {e}");
            ExitCode::FAILURE
        }
    }
}
