//! The `tactile-emulator` program: an emulated tactile array on a pseudo-terminal, for
//! running the daemon (or any serial tool) without the hardware. It prints the stable path
//! to configure as `backend.Hardware.tactile.path` and streams a synthetic pulsing artery
//! until interrupted.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use crate::tactile::emulator::{EmulatorSettings, Impairments, TactileEmulator};
use crate::tactile::pulse::{PulseScene, SyntheticPulse};
use clap::Parser;

#[derive(Debug, Parser)]
#[command(
    name = "tactile-emulator",
    about = "Emulated tactile array (docs/protocols/tactile-serial.md) on a pty"
)]
struct Args {
    /// Stable path to create for the device (a symlink to the pty).
    #[arg(long, default_value = "/tmp/pulsetrack-tactile")]
    link: PathBuf,
    /// Lateral position of the artery relative to the sensor centre, m.
    #[arg(long, default_value_t = 0.0)]
    artery_z_m: f64,
    /// Depth of the tube's axis, m.
    #[arg(long, default_value_t = 0.005)]
    depth_m: f64,
    /// Pulse pressure, Pa (the seed's tube: 100 kPa).
    #[arg(long, default_value_t = 100.0e3)]
    pulse_pressure_pa: f64,
    #[arg(long, default_value_t = 1.0)]
    heart_rate_hz: f64,
    /// Noise SD per element, N.
    #[arg(long, default_value_t = 0.012)]
    noise_sd_n: f64,
    /// Emulated seconds per wall second.
    #[arg(long, default_value_t = 1.0)]
    time_scale: f64,
    /// Corrupt every Nth frame's CRC (0: never).
    #[arg(long, default_value_t = 0)]
    corrupt_every: u64,
    /// Drop every Nth frame (0: never).
    #[arg(long, default_value_t = 0)]
    drop_every: u64,
    /// Stop after this many seconds (0: run until killed).
    #[arg(long, default_value_t = 0.0)]
    duration_s: f64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// The program: parse the command line, run until killed or `--duration-s`.
pub fn main() -> ExitCode {
    let args = Args::parse();
    let scene = PulseScene {
        artery_z_m: args.artery_z_m,
        depth_m: args.depth_m,
        pulse_pressure_pa: args.pulse_pressure_pa,
        heart_rate_hz: args.heart_rate_hz,
        noise_sd_n: args.noise_sd_n,
        seed: args.seed,
        ..PulseScene::default()
    };
    let nonzero = |n: u64| (n > 0).then_some(n);
    let mut settings = EmulatorSettings::new(&args.link);
    settings.time_scale = args.time_scale;
    settings.impairments = Impairments {
        corrupt_every: nonzero(args.corrupt_every),
        drop_every: nonzero(args.drop_every),
        ..Impairments::default()
    };
    let emu = match TactileEmulator::start(settings, Box::new(SyntheticPulse::new(scene))) {
        Ok(e) => e,
        Err(e) => {
            eprintln!(
                "tactile-emulator: cannot create the pty at {}: {e}",
                args.link.display()
            );
            return ExitCode::FAILURE;
        }
    };
    println!("{}", emu.path().display());
    let start = std::time::Instant::now();
    loop {
        std::thread::sleep(Duration::from_millis(100));
        if let Some(e) = emu.error() {
            eprintln!("tactile-emulator: {e}");
            return ExitCode::FAILURE;
        }
        if args.duration_s > 0.0 && start.elapsed().as_secs_f64() >= args.duration_s {
            emu.stop();
            return ExitCode::SUCCESS;
        }
    }
}
