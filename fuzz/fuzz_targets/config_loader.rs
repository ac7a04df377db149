//! The daemon's RON config: arbitrary text through `config::load_str::<Config>` (parse and
//! validation). Nothing may panic. A refusal names the origin on every line of its message
//! and points only at lines and columns that exist. An accepted config validates again with
//! no problem, and everything the daemon builds from it at start-up builds (the arm model,
//! the servo's planner and PD, the tracker): a config that passes `check-config` must not
//! be refused when the daemon starts. Console limits derived from it are positive.
#![no_main]

use config::{Config, Validate, Validator};
use libfuzzer_sys::fuzz_target;

const ORIGIN: &str = "fuzz-config.ron";

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match config::load_str::<Config>(ORIGIN, text) {
        Err(e) => check_error(&e, text),
        Ok(c) => {
            let mut v = Validator::new();
            c.validate(&mut v);
            let again = v.into_problems();
            assert!(again.is_empty(), "accepted, then: {again:?}");
            daemon::rt::core_servo::build(&c).expect("a valid config builds the servo");
            let trackers = daemon::rt::core_servo::tracker_factory(&c)
                .expect("a valid config builds its tracker factory");
            trackers().expect("a valid config builds a tracker");
            let jog = c.operation.max_jog_m;
            let speed = c.control.motion.max_speed_m_s;
            assert!(jog.is_finite() && jog > 0.0, "max_jog_m {jog}");
            assert!(speed.is_finite() && speed > 0.0, "max_speed_m_s {speed}");
        }
    }
});

/// The error names the origin on every line, and every position it gives exists.
pub fn check_error(e: &config::ConfigError, text: &str) {
    assert_eq!(e.file, ORIGIN);
    assert!(!e.problems.is_empty(), "an error with no problem");
    let msg = e.to_string();
    for line in msg.lines() {
        assert!(
            line.starts_with(ORIGIN),
            "a line that names no file: {line:?}"
        );
    }
    let lines = text.split('\n').count();
    for p in &e.problems {
        assert!(!p.message.trim().is_empty(), "empty message: {p:?}");
        if let Some(l) = p.line {
            assert!(l >= 1 && l <= lines + 1, "line {l} of {lines}: {p:?}");
        }
        if let Some(c) = p.col {
            assert!(c >= 1, "column {c}: {p:?}");
        }
    }
}
