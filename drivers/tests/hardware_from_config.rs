//! The rig as the daemon will open it: a configuration like config/lab.ron, with its device
//! paths pointed at the two emulators on pseudo-terminals (the tactile array, and the
//! Phantom's amplifiers behind an slcan adapter), opened with `drivers::hardware::open`.

use pulsetrack_drivers as drivers;

use std::sync::Arc;
use std::time::{Duration, Instant};

use config::Config;
use config::schema::Backend;
use control::ports::{Manipulator, TactileArray};
use control::types::JointTorques;
use drivers::MonotonicClock;
use drivers::can::DriveState;
use drivers::can::phantom_emulator::{PhantomEmulator, PhantomEmulatorSettings};
use drivers::tactile::emulator::{EmulatorSettings, TactileEmulator};
use drivers::tactile::pulse::{PulseScene, SyntheticPulse};

#[test]
fn lab_config_with_emulated_devices_runs_a_loop() {
    let dir = std::env::temp_dir().join(format!("pulsetrack-hw-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let tactile_path = dir.join("tactile");
    let can_path = dir.join("slcan");

    let (_, lab) = config::shipped::LAB_CONFIG;
    let text = lab
        .replace(
            "/dev/serial/by-id/usb-pulsetrack_tactile_array-if00",
            &tactile_path.to_string_lossy(),
        )
        .replace(
            "adapter: SocketCan(interface: \"can0\")",
            &format!(
                "adapter: Slcan(path: \"{}\", baud: 115200, bitrate_bps: 1000000)",
                can_path.display()
            ),
        )
        // A pty on a shared test machine delivers in bursts; the rig keeps 5 ms.
        .replace("feedback_timeout_s: 0.005", "feedback_timeout_s: 1.0");
    let cfg: Config =
        config::load_str::<Config>("lab-emulated.ron", &text).unwrap_or_else(|e| panic!("{e}"));
    let Backend::Hardware(hw) = &cfg.backend else {
        panic!("lab.ron selects hardware")
    };

    let tactile_emu = TactileEmulator::start(
        EmulatorSettings::new(&tactile_path),
        Box::new(SyntheticPulse::new(PulseScene::default())),
    )
    .expect("tactile emulator");
    let mut can_settings = PhantomEmulatorSettings::new(&can_path);
    can_settings.joints = hw.joints.clone();
    let can_emu = PhantomEmulator::start(can_settings).expect("phantom emulator");

    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .expect("runtime");
    let (mut arm, mut tactile) = drivers::hardware::open(
        hw,
        cfg.sensor.sample_rate_hz,
        rt.handle(),
        Arc::new(MonotonicClock::new()),
    )
    .unwrap_or_else(|e| panic!("{e}"));

    let start = Instant::now();
    let mut frames = 0;
    let mut enabled = false;
    while frames < 30 || !enabled {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "{:?} {:?}",
            arm.state(),
            tactile.status()
        );
        if arm.read_joints().is_ok() && matches!(arm.state(), DriveState::Disabled) {
            arm.enable().expect("enable");
        }
        enabled |= matches!(arm.state(), DriveState::Enabled);
        arm.write_torques(&JointTorques::ZERO).expect("torques");
        while let Some(f) = tactile.poll_frame().expect("tactile") {
            assert!(f.is_finite());
            frames += 1;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    arm.disable().expect("disable");
    drop(tactile);
    drop(arm);
    tactile_emu.stop();
    can_emu.stop().expect("emulator ran cleanly");
}
