//! The real serial driver against the emulated array on a pseudo-terminal: frames stream
//! end to end, every kind of bad input is counted and survived, an unplug reconnects, a
//! stall is reported stale, an incompatible device is refused with a reason.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use pulsetrack_drivers as drivers;

use config::schema::SerialTactile;
use control::ports::TactileArray;
use control::types::{ELEMENTS, TactileFrame};
use drivers::MonotonicClock;
use drivers::tactile::emulator::{EmulatorSettings, Impairments, TactileEmulator};
use drivers::tactile::{LinkState, SerialTactileArray, TactileError, TactileStats};

/// Generous limit on waiting for something that normally takes milliseconds; reaching it
/// fails the test (it is not a speed requirement).
const PATIENCE: Duration = Duration::from_secs(30);

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .expect("a tokio runtime")
}

fn device_path(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pulsetrack-drivers-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir.join(name)
}

fn settings(path: &std::path::Path) -> SerialTactile {
    SerialTactile {
        path: path.to_string_lossy().into_owned(),
        reconnect_initial_s: 0.01,
        reconnect_max_s: 0.05,
        queue_frames: 100_000,
        ..SerialTactile::default()
    }
}

/// A noise-free source whose every value encodes the device time and the element.
fn ramp(t_s: f64) -> [f64; ELEMENTS] {
    let mut f = [0.0; ELEMENTS];
    for (i, v) in f.iter_mut().enumerate() {
        *v = 0.01 * i as f64 + 0.1 * (t_s % 10.0);
    }
    f
}

fn poll_until(
    port: &mut SerialTactileArray,
    frames: &mut Vec<TactileFrame>,
    mut done: impl FnMut(&[TactileFrame], &drivers::tactile::LinkStatus) -> bool,
) {
    let start = Instant::now();
    loop {
        while let Some(f) = port.poll_frame().expect("link alive") {
            frames.push(f);
        }
        if done(frames, &port.status()) {
            return;
        }
        assert!(
            start.elapsed() < PATIENCE,
            "gave up waiting; status {:?}",
            port.status()
        );
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[test]
fn frames_stream_end_to_end_with_device_timing() {
    let rt = runtime();
    let path = device_path("stream");
    let mut emu_settings = EmulatorSettings::new(&path);
    emu_settings.time_scale = 4.0;
    let emu = TactileEmulator::start(emu_settings, Box::new(ramp)).expect("emulator");
    let clock = Arc::new(MonotonicClock::scaled(4.0));
    let mut port =
        SerialTactileArray::spawn(rt.handle(), &settings(&path), 100.0, clock).expect("driver");
    let mut frames = Vec::new();
    poll_until(&mut port, &mut frames, |f, _| f.len() >= 200);

    let status = port.status();
    assert_eq!(status.state, LinkState::Streaming);
    let dev = status.device.expect("handshake recorded the device");
    assert_eq!(
        (dev.channels, dev.rate_hz, dev.serial_number),
        (10, 100, 4242)
    );
    // Stamped from the device clock: never more than the device's 10 ms apart (plus the
    // drift allowance), never backwards; only when a frame shows a new smallest transport
    // latency does a spacing come out shorter.
    let mut exact = 0;
    for w in frames.windows(2) {
        assert!(w[1].seq > w[0].seq);
        let spacing = w[1].t_s - w[0].t_s;
        assert!((0.0..=0.010 + 1e-5).contains(&spacing), "{w:?}");
        exact += usize::from((spacing - 0.010).abs() < 1e-5);
    }
    assert!(
        exact * 10 >= frames.len() * 8,
        "{exact} of {} spacings at 10 ms",
        frames.len()
    );
    // Values are the source's, quantized to 0.1 mN. Frame k was sampled at device time
    // k / 100 s.
    let first_seq = frames[0].seq;
    for f in &frames {
        let t = (f.seq - first_seq) as f64 * 0.01;
        let expected = ramp(t);
        for (i, (got, want)) in f.force_n.iter().zip(expected).enumerate() {
            assert!(
                (got - want).abs() <= 0.5e-4 + 1e-12,
                "frame {} element {i}: {got} vs {want}",
                f.seq
            );
        }
    }
    // On a clean line the only frames lost are those the pty refused while this process
    // was not scheduled (normally none); each such loss is seen as missing.
    let stats = status.stats;
    let unread = emu.counters().frames_unread.load(Ordering::Relaxed);
    let seen_span = frames[frames.len() - 1].seq - frames[0].seq + 1;
    assert_eq!(seen_span - frames.len() as u64, stats.missing_frames);
    assert!(stats.missing_frames <= unread, "{stats:?}, {unread} unread");
    assert_eq!(
        stats.duplicates + stats.wrong_channel_count + stats.out_of_range,
        0
    );
    drop(port);
    emu.stop();
}

#[test]
fn every_kind_of_bad_input_is_counted_and_the_stream_survives() {
    // Coprime periods whose pairwise products exceed the frame count: no frame carries two
    // impairments, so every counter has an exact expected value.
    const K: u64 = 480;
    let imp = Impairments {
        drop_every: Some(23),
        duplicate_every: Some(29),
        corrupt_every: Some(31),
        truncate_every: Some(37),
        wrong_channels_every: Some(41),
        element_fault_every: Some(43),
        garbage_every: Some(47),
    };
    let rt = runtime();
    let path = device_path("impaired");
    let mut emu_settings = EmulatorSettings::new(&path);
    emu_settings.time_scale = 3.0;
    emu_settings.max_frames = Some(K);
    emu_settings.impairments = imp;
    let emu = TactileEmulator::start(emu_settings, Box::new(ramp)).expect("emulator");
    let clock = Arc::new(MonotonicClock::scaled(3.0));
    let mut port =
        SerialTactileArray::spawn(rt.handle(), &settings(&path), 100.0, clock).expect("driver");

    let n = |p: u64| K / p;
    let lost = n(23) + n(31) + n(37); // dropped, CRC-damaged and truncated frames
    let rejected = n(41) + n(43);
    let expected_frames = K - lost - rejected;
    let mut frames = Vec::new();
    poll_until(&mut port, &mut frames, |f, s| {
        f.len() as u64 >= expected_frames
            && s.stats.duplicates >= n(29)
            && s.stats.crc_errors + s.stats.framing_errors >= n(31) + n(37) + n(47)
    });
    // Let anything still in flight arrive, then check nothing extra did.
    std::thread::sleep(Duration::from_millis(200));
    poll_until(&mut port, &mut frames, |_, _| true);
    assert_eq!(emu.counters().frames_generated.load(Ordering::Relaxed), K);
    assert_eq!(emu.counters().frames_unread.load(Ordering::Relaxed), 0);

    let s: TactileStats = port.status().stats;
    assert_eq!(frames.len() as u64, expected_frames);
    assert_eq!(s.frames, expected_frames);
    assert_eq!(s.duplicates, n(29));
    assert_eq!(s.wrong_channel_count, n(41));
    assert_eq!(s.element_faults, n(43));
    // A flipped bit is always a CRC error; a truncated frame or line noise is a framing
    // or a CRC error depending on where it was cut.
    assert!(s.crc_errors >= n(31));
    assert_eq!(s.crc_errors + s.framing_errors, n(31) + n(37) + n(47));
    assert_eq!(s.missing_frames, lost);
    // Adjacent lost frames make one gap.
    let is_lost = |k: u64| [23, 31, 37].iter().any(|&p| k.is_multiple_of(p));
    let gaps = (1..=K).filter(|&k| is_lost(k) && !is_lost(k - 1)).count() as u64;
    assert_eq!(s.gaps, gaps);
    assert_eq!(s.out_of_range + s.reordered + s.resyncs + s.queue_drops, 0);
    // What got through is intact and in order.
    for w in frames.windows(2) {
        assert!(w[1].seq > w[0].seq);
        assert!(w[1].t_s > w[0].t_s);
    }
    let first_seq = frames[0].seq;
    for f in &frames {
        let expected = ramp((f.seq - first_seq) as f64 * 0.01);
        assert!((f.force_n[9] - expected[9]).abs() <= 0.5e-4 + 1e-12);
    }
    drop(port);
    emu.stop();
}

#[test]
fn an_unplugged_array_is_reopened_at_its_stable_path() {
    let rt = runtime();
    let path = device_path("replug");
    let mut emu_settings = EmulatorSettings::new(&path);
    emu_settings.time_scale = 4.0;
    let emu = TactileEmulator::start(emu_settings, Box::new(ramp)).expect("emulator");
    let clock = Arc::new(MonotonicClock::scaled(4.0));
    let mut port =
        SerialTactileArray::spawn(rt.handle(), &settings(&path), 100.0, clock).expect("driver");
    let mut frames = Vec::new();
    poll_until(&mut port, &mut frames, |f, _| f.len() >= 20);

    emu.unplug();
    poll_until(&mut port, &mut frames, |_, s| {
        s.stats.unplugs == 1 && s.stats.open_failures >= 2
    });
    assert_eq!(port.status().state, LinkState::Opening);
    let before = frames.len();
    let last_seq = frames[before - 1].seq;

    emu.replug();
    poll_until(&mut port, &mut frames, |f, _| f.len() >= before + 20);
    let s = port.status();
    assert_eq!(s.state, LinkState::Streaming);
    assert!(s.stats.handshakes >= 2);
    // The device restarted its counter at 0; the consumer's sequence never goes back.
    assert!(frames[before].seq > last_seq);
    assert!(frames.windows(2).all(|w| w[1].seq > w[0].seq));
    drop(port);
    emu.stop();
}

#[test]
fn a_stalled_array_is_reported_stale_and_recovers() {
    let rt = runtime();
    let path = device_path("stall");
    let mut emu_settings = EmulatorSettings::new(&path);
    emu_settings.time_scale = 2.0;
    let emu = TactileEmulator::start(emu_settings, Box::new(ramp)).expect("emulator");
    let clock = Arc::new(MonotonicClock::scaled(2.0));
    let mut port =
        SerialTactileArray::spawn(rt.handle(), &settings(&path), 100.0, clock).expect("driver");
    let mut frames = Vec::new();
    poll_until(&mut port, &mut frames, |f, _| f.len() >= 10);

    emu.hang(true);
    poll_until(&mut port, &mut frames, |_, s| s.state == LinkState::Stale);
    assert!(port.status().stats.stale_events >= 1);
    assert_eq!(port.status().stats.unplugs, 0, "a stall is not an unplug");
    let configures = emu.counters().configures.load(Ordering::Relaxed);

    emu.hang(false);
    let n = frames.len();
    poll_until(&mut port, &mut frames, |f, s| {
        f.len() >= n + 10 && s.state == LinkState::Streaming
    });
    assert!(configures >= 1);
    drop(port);
    emu.stop();
}

#[test]
fn an_array_with_the_wrong_channel_count_is_refused_with_a_reason() {
    let rt = runtime();
    let path = device_path("eight");
    let mut emu_settings = EmulatorSettings::new(&path);
    emu_settings.channels = 8;
    let emu = TactileEmulator::start(emu_settings, Box::new(ramp)).expect("emulator");
    let clock = Arc::new(MonotonicClock::new());
    let mut port =
        SerialTactileArray::spawn(rt.handle(), &settings(&path), 100.0, clock).expect("driver");
    let start = Instant::now();
    let err = loop {
        match port.poll_frame() {
            Ok(None) => {}
            Ok(Some(f)) => panic!("no frame may come from an incompatible device: {f:?}"),
            Err(e) => break e,
        }
        assert!(start.elapsed() < PATIENCE);
        std::thread::sleep(Duration::from_millis(2));
    };
    match err {
        TactileError::Incompatible(why) => assert!(why.contains("8 channels"), "{why}"),
        other => panic!("unexpected error {other}"),
    }
    drop(port);
    emu.stop();
}

#[test]
fn a_missing_array_is_retried_until_it_appears() {
    let rt = runtime();
    let path = device_path("late");
    let _ = std::fs::remove_file(&path);
    let clock = Arc::new(MonotonicClock::new());
    let mut port =
        SerialTactileArray::spawn(rt.handle(), &settings(&path), 100.0, clock).expect("driver");
    let mut frames = Vec::new();
    poll_until(&mut port, &mut frames, |_, s| s.stats.open_failures >= 3);
    assert!(frames.is_empty());
    let last = port.status().last_problem.expect("a reason");
    assert!(last.contains("cannot open"), "{last}");

    let emu =
        TactileEmulator::start(EmulatorSettings::new(&path), Box::new(ramp)).expect("emulator");
    poll_until(&mut port, &mut frames, |f, _| f.len() >= 5);
    drop(port);
    emu.stop();
}

#[test]
fn a_non_integral_rate_is_refused() {
    let rt = runtime();
    let clock = Arc::new(MonotonicClock::new());
    let err = SerialTactileArray::spawn(rt.handle(), &settings(&device_path("x")), 99.5, clock)
        .expect_err("99.5 Hz cannot be requested");
    assert_eq!(err, TactileError::BadRate(99.5));
}
