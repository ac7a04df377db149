//! A recorded trial served on the live view (`pulsetrack replay FILE --live`): every message
//! of a channel the live view has goes out at its recorded log time (so the timeline shows the
//! trial's own date), paced at real time or faster, through the same publisher as the daemon's
//! (band-passed frames and the pulse included), so a trial is reviewed in the same layout.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use crate::live::tap::{LiveMsg, LiveTap};
use crate::live::topics::LiveTopic;
use crate::recording::messages::TactileSample;
use crate::recording::recover::{ReadBack, ReadMessage};
use crate::recording::topics::Topic;
use crate::recording::trial_file::Epoch;

/// What a replay published.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReplayReport {
    /// Messages handed to the publisher.
    pub messages: u64,
    /// Messages of channels the live view does not have, by topic (not published).
    pub skipped: BTreeMap<String, u64>,
    /// Recorded span, s of log time.
    pub span_s: f64,
}

/// The messages to serve, in log-time order (the recorder writes each channel in order; the
/// channels interleave).
pub fn schedule(back: &ReadBack) -> Vec<&ReadMessage> {
    let mut m: Vec<&ReadMessage> = back.messages.iter().collect();
    m.sort_by_key(|m| m.log_time_ns);
    m
}

/// The recording's mapping of daemon time onto log time, from its first tactile frame
/// (`None`: no frame with a time).
pub fn epoch_of(back: &ReadBack) -> Option<Epoch> {
    back.on(Topic::Tactile).find_map(|m| {
        let t_s = m.json.get("t_s")?.as_f64()?;
        Some(Epoch {
            offset_ns: i128::from(m.log_time_ns) - (t_s * 1e9) as i128,
        })
    })
}

/// Serve `messages` through `tap` at `speed` times real time (blocking: a replay never drops).
pub fn serve(messages: &[&ReadMessage], tap: &LiveTap, speed: f64) -> ReplayReport {
    let mut report = ReplayReport::default();
    let (Some(first), Some(last)) = (messages.first(), messages.last()) else {
        return report;
    };
    report.span_s = (last.log_time_ns.saturating_sub(first.log_time_ns)) as f64 * 1e-9;
    let start = Instant::now();
    for m in messages {
        let due = (m.log_time_ns.saturating_sub(first.log_time_ns)) as f64 * 1e-9 / speed;
        let wait = due - start.elapsed().as_secs_f64();
        if wait > 0.0 {
            std::thread::sleep(Duration::from_secs_f64(wait));
        }
        let Some(topic) = Topic::from_name(&m.topic) else {
            *report.skipped.entry(m.topic.clone()).or_default() += 1;
            continue;
        };
        for msg in messages_for(topic, m) {
            if tap.send(msg) {
                report.messages += 1;
            }
        }
    }
    report
}

/// What the publisher is handed for one recorded message.
fn messages_for(topic: Topic, m: &ReadMessage) -> Vec<LiveMsg> {
    if topic == Topic::Tactile
        && let Ok(sample) = serde_json::from_value::<TactileSample>(m.json.clone())
    {
        return vec![LiveMsg::Tactile {
            log_time_ns: m.log_time_ns,
            sample,
        }];
    }
    let mut out = vec![LiveMsg::Json {
        topic: LiveTopic::Recorded(topic),
        log_time_ns: m.log_time_ns,
        json: m.data.clone(),
    }];
    if topic == Topic::Events
        && m.json.get("kind").and_then(|k| k.as_str()) == Some("pulse")
        && let Some(p) = m.json.get("period_s").and_then(|p| p.as_f64())
    {
        out.push(LiveMsg::Period(Some(p)));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::trial_file::TrialFile;

    fn recording(dir: &std::path::Path) -> ReadBack {
        let path = dir.join("t.mcap");
        let offset: i128 = 1_700_000_000_000_000_000;
        let mut f = TrialFile::create(&path, &[], offset).expect("create");
        for i in 0..50u64 {
            let t = 10.0 + i as f64 * 0.01;
            let s = TactileSample {
                t_s: t,
                seq: i,
                force_n: [0.5; control::types::ELEMENTS],
                sensor_x_m: Some(0.0),
                sensor_z_m: Some(0.0),
                settled: true,
                contact_n: Some(5.0),
                tracker_settled: None,
                loaded_x_m: None,
                loaded_z_m: None,
            };
            f.write(Topic::Tactile, t, &serde_json::to_vec(&s).expect("json"))
                .expect("write");
        }
        f.write(
            Topic::Events,
            10.2,
            br#"{"event":"detection","kind":"pulse","t_s":10.2,"period_s":0.9}"#,
        )
        .expect("write");
        f.finish().expect("finish");
        crate::recording::recover::read(&path).expect("read")
    }

    #[test]
    fn serves_every_message_in_time_order_with_the_recordings_clock() {
        let dir = tempfile::tempdir().expect("tmp");
        let back = recording(dir.path());
        let epoch = epoch_of(&back).expect("epoch");
        assert_eq!(
            epoch.ns(10.0),
            back.on(Topic::Tactile)
                .next()
                .map(|m| m.log_time_ns)
                .unwrap_or(0)
        );
        let (tap, rx, _) = LiveTap::new(1024, epoch, "ws://x".into());
        let schedule = schedule(&back);
        assert!(
            schedule
                .windows(2)
                .all(|w| w[0].log_time_ns <= w[1].log_time_ns)
        );
        let report = serve(&schedule, &tap, 100.0);
        // 50 frames, one event, and the period it carries.
        assert_eq!(report.messages, 52);
        assert!((report.span_s - 0.49).abs() < 1e-6, "{}", report.span_s);
        let got: Vec<LiveMsg> = rx.try_iter().collect();
        assert_eq!(got.len(), 52);
        assert!(matches!(got[0], LiveMsg::Tactile { ref sample, .. } if sample.seq == 0));
        assert!(
            got.iter()
                .any(|m| matches!(m, LiveMsg::Period(Some(p)) if *p == 0.9))
        );
    }
}
