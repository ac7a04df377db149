//! `phantom-emulator`: the Phantom's three joint amplifiers behind an emulated slcan USB-CAN
//! adapter on a pseudo-terminal. Configure the daemon with
//! `joints: (adapter: Slcan(path: "<printed path>", baud: 115200, bitrate_bps: 1000000))`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use pulsetrack_drivers::can::phantom_emulator::{PhantomEmulator, PhantomEmulatorSettings};

#[derive(Debug, Parser)]
#[command(
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
    #[arg(long, num_args = 3, default_values_t = [0.0, 0.0, 0.0])]
    initial_rad: Vec<f64>,
    /// Stop after this many seconds (0: run until killed).
    #[arg(long, default_value_t = 0.0)]
    duration_s: f64,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let mut settings = PhantomEmulatorSettings::new(&args.link);
    if let Some(path) = &args.config {
        match config::load_file::<config::Config>(path) {
            Ok(c) => match c.value.backend {
                config::schema::Backend::Hardware(hw) => settings.joints = hw.joints,
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
    for (slot, v) in settings.initial_rad.iter_mut().zip(&args.initial_rad) {
        *slot = *v;
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
