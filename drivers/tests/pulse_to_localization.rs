//! End to end over the serial line: a pulsing artery goes into the emulated array, frames
//! come out of the real driver, and the artery is localized on the array from them.
//!
//! The localization here is a stand-in until control's signal processing (`control::signal`,
//! the seed2002 tracker) lands: the element whose force varies most, refined by a parabola
//! through it and its neighbours.

use pulsetrack_drivers as drivers;

use std::sync::Arc;
use std::time::{Duration, Instant};

use config::schema::SerialTactile;
use control::ports::TactileArray;
use control::sensor::ArrayGeometry;
use control::types::{ELEMENTS, TactileFrame};
use drivers::MonotonicClock;
use drivers::tactile::SerialTactileArray;
use drivers::tactile::emulator::{EmulatorSettings, TactileEmulator};
use drivers::tactile::pulse::{PulseScene, SyntheticPulse};

/// Fractional element index of the artery from the per-element standard deviation.
fn localize(frames: &[TactileFrame]) -> f64 {
    let n = frames.len() as f64;
    let sd: Vec<f64> = (0..ELEMENTS)
        .map(|i| {
            let mean = frames.iter().map(|f| f.force_n[i]).sum::<f64>() / n;
            (frames
                .iter()
                .map(|f| (f.force_n[i] - mean).powi(2))
                .sum::<f64>()
                / n)
                .sqrt()
        })
        .collect();
    let k = (1..ELEMENTS - 1)
        .max_by(|&a, &b| sd[a].total_cmp(&sd[b]))
        .expect("elements");
    let (l, c, r) = (sd[k - 1], sd[k], sd[k + 1]);
    k as f64 + 0.5 * (l - r) / (l - 2.0 * c + r)
}

#[test]
fn a_pulse_goes_in_and_a_localization_comes_out() {
    let geometry = ArrayGeometry::default();
    // The artery 2.4 mm off the sensor centre: element 5.7.
    let artery_z_m = 0.0024;
    let truth = geometry.element_at(artery_z_m);
    assert!((truth - 5.7).abs() < 1e-12);
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
    let path = dir.join("tactile");
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

    // Four seconds of the array, as the seed's start-up acquisition.
    let mut frames = Vec::new();
    let start = Instant::now();
    while frames.len() < 400 {
        while let Some(f) = port.poll_frame().expect("link alive") {
            frames.push(f);
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "{:?}",
            port.status()
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    frames.truncate(400);
    let located = localize(&frames);
    // Within a third of an element (0.7 mm) of the truth; the 2 mm pitch alone would
    // allow 1 mm.
    assert!(
        (located - truth).abs() < 0.35,
        "located {located}, truth {truth}"
    );
    let z = geometry.offset_z_m(located);
    assert!((z - artery_z_m).abs() < 0.0007, "z {z}");
    drop(port);
    emu.stop();
}
