//! End to end over the serial line: a pulsing artery goes into the emulated array, frames
//! come out of the real driver, and control's seed2002 tracker localizes the artery from them
//! exactly as at a surgeon's manual placement (`mark`, then one frame per step until it
//! reports the seed point).

use pulsetrack_drivers as drivers;

use std::sync::Arc;
use std::time::{Duration, Instant};

use config::schema::SerialTactile;
use control::frames::SurfacePoint;
use control::ports::TactileArray;
use control::sensor::ArrayGeometry;
use control::tracker::{TrackerEvent, TrackerInput, TrackerParams};
use drivers::MonotonicClock;
use drivers::tactile::SerialTactileArray;
use drivers::tactile::emulator::{EmulatorSettings, TactileEmulator};
use drivers::tactile::pulse::{PulseScene, SyntheticPulse};

/// Mark at a placement with the artery `artery_z_m` off the sensor centre; the tracker's
/// seed point and the element it found.
fn mark_over(artery_z_m: f64, name: &str) -> (SurfacePoint, f64) {
    let geometry = ArrayGeometry::default();
    let scene = PulseScene {
        artery_z_m,
        ..PulseScene::default()
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .expect("runtime");
    let dir = std::env::temp_dir().join(format!("pulsetrack-e2e-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let path = dir.join(name);
    let scale = 8.0;
    let mut emu_settings = EmulatorSettings::new(&path);
    emu_settings.time_scale = scale;
    let emu = TactileEmulator::start(emu_settings, Box::new(SyntheticPulse::new(scene)))
        .expect("emulator");
    let settings = SerialTactile {
        path: path.to_string_lossy().into_owned(),
        queue_frames: 10_000,
        ..SerialTactile::default()
    };
    let mut port = SerialTactileArray::spawn(
        rt.handle(),
        &settings,
        geometry.sample_rate_hz,
        Arc::new(MonotonicClock::scaled(scale)),
    )
    .expect("driver");

    let mut tracker = control::tracker::build("seed2002", &TrackerParams::default(), &geometry)
        .expect("seed2002");
    // The sensor centre sits at the tissue origin; the artery runs along x.
    let sensor = SurfacePoint::new(0.0, 0.0);
    tracker.mark().expect("seeding");
    let start = Instant::now();
    let located = 'frames: loop {
        while let Some(frame) = port.poll_frame().expect("link alive") {
            let out = tracker.step(&TrackerInput {
                frame: &frame,
                sensor,
                settled: true,
                loaded_sensor: None,
            });
            match out.event {
                Some(TrackerEvent::Located(p)) => break 'frames p,
                Some(TrackerEvent::Missed { .. }) => {
                    panic!("the tracker found no pulse; link {:?}", port.status())
                }
                _ => {}
            }
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "{:?}",
            port.status()
        );
        std::thread::sleep(Duration::from_millis(2));
    };
    assert!(located.seed);
    drop(port);
    emu.stop();
    (located.point, located.element)
}

#[test]
fn a_pulse_goes_in_and_a_localization_comes_out() {
    let geometry = ArrayGeometry::default();
    for (artery_z_m, name) in [(0.0024, "e2e-a"), (-0.0050, "e2e-b")] {
        let truth = geometry.element_at(artery_z_m);
        let (point, element) = mark_over(artery_z_m, name);
        // The seed's localization: the centre of the run of elements whose pulse exceeds
        // 2 σ, "to within one or two sensor elements"; here within half an element (1 mm).
        assert!(
            (element - truth).abs() <= 0.5 + 1e-9,
            "artery at element {truth}, located at {element}"
        );
        assert!(point.x_m.abs() < 1e-12);
        assert!(
            (point.z_m - artery_z_m).abs() <= 0.001 + 1e-12,
            "artery at z {artery_z_m}, located at {}",
            point.z_m
        );
    }
}
