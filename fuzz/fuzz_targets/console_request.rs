//! The console's request parser: arbitrary bytes as one request line, under the limits the
//! daemon derives from the shipped simulator config. Nothing may panic; an accepted request
//! has finite numbers within the limits and no leftover argument; a refusal has a reason, and
//! its `id` only when the line was a JSON object with a valid `id`; both the reply and the
//! error reply serialize to JSON that reads back with the same id.
#![no_main]

use std::sync::LazyLock;

use daemon::console::protocol::{
    DebugAction, ErrorCode, ParseLimits, Verb, error_reply, ok_reply, parse_request,
};
use libfuzzer_sys::fuzz_target;
use serde_json::Value;

/// The limits `pulsetrackd` builds from its config (pulsetrackd.rs), from the shipped one.
static LIMITS: LazyLock<ParseLimits> = LazyLock::new(|| {
    let (name, text) = config::shipped::SIM_CONFIG;
    let c: config::Config = config::load_str(name, text).expect("the shipped config loads");
    ParseLimits {
        max_jog_m: c.operation.max_jog_m,
        max_speed_m_s: c.control.motion.max_speed_m_s,
        max_coordinate_m: 1.0,
        max_track_length_m: 2.0,
    }
});

fuzz_target!(|data: &[u8]| {
    let limits = &*LIMITS;
    match parse_request(data, limits) {
        Ok(req) => {
            check_verb(&req.verb, limits);
            // The line was a JSON object whose `id` is the request's.
            let v: Value = serde_json::from_slice(data).expect("accepted lines are JSON");
            assert_eq!(v.get("id").and_then(Value::as_u64), Some(req.id));
            let reply = ok_reply(req.id, serde_json::json!({"state": "holding", "id": 1}));
            let text = serde_json::to_string(&reply).expect("reply serializes");
            let back: Value = serde_json::from_str(&text).expect("reply reads back");
            assert_eq!(back["id"].as_u64(), Some(req.id));
            assert_eq!(back["ok"], Value::Bool(true));
        }
        Err(e) => {
            assert!(!e.reason.trim().is_empty(), "empty reason for {:?}", e.code);
            if e.code == ErrorCode::Malformed {
                assert_eq!(e.id, None);
            }
            if let Some(id) = e.id {
                let v: Value = serde_json::from_slice(data).expect("an id came from JSON");
                assert_eq!(v.get("id").and_then(Value::as_u64), Some(id));
            }
            let reply = error_reply(e.id, e.code, &e.reason);
            let text = serde_json::to_string(&reply).expect("error reply serializes");
            let back: Value = serde_json::from_str(&text).expect("error reply reads back");
            assert_eq!(back["id"].as_u64(), e.id);
            assert_eq!(back["reason"].as_str(), Some(e.reason.as_str()));
            assert!(back["error"].is_string());
        }
    }
});

fn check_verb(verb: &Verb, l: &ParseLimits) {
    match *verb {
        Verb::Jog { dx_m, dz_m } => {
            assert!(dx_m.is_finite() && dz_m.is_finite());
            assert!(dx_m.hypot(dz_m) <= l.max_jog_m, "jog {dx_m} {dz_m}");
        }
        Verb::Move {
            x_m,
            z_m,
            speed_m_s,
        } => {
            assert!(x_m.is_finite() && z_m.is_finite());
            assert!(x_m.abs() <= l.max_coordinate_m && z_m.abs() <= l.max_coordinate_m);
            if let Some(s) = speed_m_s {
                assert!(
                    s.is_finite() && s > 0.0 && s <= l.max_speed_m_s,
                    "speed {s}"
                );
            }
        }
        Verb::Track { length_m } => {
            if let Some(len) = length_m {
                assert!(len.is_finite() && len > 0.0 && len <= l.max_track_length_m);
            }
        }
        Verb::Subscribe { tactile_every, .. } => {
            assert!((1..=10_000).contains(&tactile_every));
        }
        Verb::Debug(DebugAction::SilenceTactile { duration_s }) => {
            assert!(duration_s.is_finite() && duration_s > 0.0 && duration_s <= 3600.0);
        }
        Verb::Status
        | Verb::Enable
        | Verb::Disable
        | Verb::Home
        | Verb::Mark
        | Verb::Pause
        | Verb::Resume
        | Verb::Stop
        | Verb::Estop
        | Verb::Reset
        | Verb::Unsubscribe => {}
    }
}
