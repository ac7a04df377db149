//! One entry of a trial's event log: a tracker event, or a move that stopped short, with
//! where the robot believed the sensor was and where it truly was against the artery. One
//! JSON object each (`pulsetrack sim --events`, docs/sim-json.md), in SI units; `describe`
//! gives the line for people, in millimetres.

use control::frames::SurfacePoint;
use control::motion::Shortfall;
use control::tracker::{EndReason, TrackerEvent};
use serde::Serialize;

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrialEvent {
    /// Simulated time of the report, s.
    pub t_s: f64,
    /// Where the robot believed the sensor centre was (encoders through the arm model).
    pub believed_sensor: SurfacePoint,
    /// Where the sensor centre truly was.
    pub true_sensor: SurfacePoint,
    /// The true sensor's signed distance from the true artery, m.
    pub off_artery_m: f64,
    /// The nearest artery point's distance along the path, m.
    pub along_path_m: f64,
    #[serde(flatten)]
    pub event: EventKind,
}

/// What happened, tagged by `kind`, with the event's own fields.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum EventKind {
    /// The tracker located the artery.
    Located {
        /// When the localization applies (its acquisition), s.
        event_t_s: f64,
        point: SurfacePoint,
        /// The sensor centre the robot believed it was at when it localized.
        sensor: SurfacePoint,
        element: f64,
        amplitude_n: f64,
        /// A surgeon's manual placement.
        seed: bool,
        /// The point's uncertainty across the artery, one SD, m (absent: not estimated).
        #[serde(skip_serializing_if = "Option::is_none")]
        sd_m: Option<f64>,
    },
    /// An acquisition found no pulse.
    Missed { event_t_s: f64, at: SurfacePoint },
    /// Going back toward the last place the pulse was found.
    Backtracking {
        event_t_s: f64,
        toward: SurfacePoint,
    },
    /// The pulse period estimate changed.
    Pulse { event_t_s: f64, period_s: f64 },
    /// Tracking ended.
    Finished { event_t_s: f64, reason: EndReason },
    /// Listening at rest for a weak pulse: the evidence so far as an SNR, what a decision
    /// needs, the beats weighed and the beats still to go (absent while there is no
    /// evidence).
    Listening {
        event_t_s: f64,
        snr: f64,
        snr_needed: f64,
        beats: f64,
        #[serde(skip_serializing_if = "Option::is_none")]
        beats_to_go: Option<f64>,
    },
    /// A move the runner made (a placement, a tracker's step) stopped short of its target.
    StoppedShort {
        what: String,
        target: SurfacePoint,
        shortfall_m: f64,
        /// `stalled` or `not_at_rest`.
        shortfall_reason: &'static str,
    },
}

impl From<TrackerEvent> for EventKind {
    fn from(e: TrackerEvent) -> Self {
        match e {
            TrackerEvent::Located(p) => EventKind::Located {
                event_t_s: p.t_s,
                point: p.point,
                sensor: p.sensor,
                element: p.element,
                amplitude_n: p.amplitude_n,
                seed: p.seed,
                sd_m: p.sd_m,
            },
            TrackerEvent::Missed { t_s, at } => EventKind::Missed { event_t_s: t_s, at },
            TrackerEvent::Backtracking { t_s, toward } => EventKind::Backtracking {
                event_t_s: t_s,
                toward,
            },
            TrackerEvent::Pulse { t_s, period_s } => EventKind::Pulse {
                event_t_s: t_s,
                period_s,
            },
            TrackerEvent::Finished { t_s, reason } => EventKind::Finished {
                event_t_s: t_s,
                reason,
            },
            TrackerEvent::Listening(p) => EventKind::Listening {
                event_t_s: p.t_s,
                snr: p.snr,
                snr_needed: p.snr_needed,
                beats: p.beats,
                beats_to_go: p.beats_to_go,
            },
        }
    }
}

impl EventKind {
    pub fn stopped_short(what: String, target: SurfacePoint, shortfall: &Shortfall) -> Self {
        EventKind::StoppedShort {
            what,
            target,
            shortfall_m: shortfall.distance_m,
            shortfall_reason: shortfall.reason.as_str(),
        }
    }
}

fn mm(p: &SurfacePoint) -> String {
    format!("({:7.2}, {:7.2}) mm", p.x_m * 1e3, p.z_m * 1e3)
}

impl TrialEvent {
    /// One line for people.
    pub fn describe(&self) -> String {
        let what = match &self.event {
            EventKind::Located {
                point,
                element,
                amplitude_n,
                seed,
                ..
            } => format!(
                "located{} at {} (element {element:.2}, {:.4} N)",
                if *seed { " seed" } else { "" },
                mm(point),
                amplitude_n
            ),
            EventKind::Missed { at, .. } => format!("no pulse at {}", mm(at)),
            EventKind::Backtracking { toward, .. } => format!("backtracking toward {}", mm(toward)),
            EventKind::Pulse { period_s, .. } => format!("pulse period {period_s:.3} s"),
            EventKind::Finished { reason, .. } => format!("finished: {reason:?}"),
            EventKind::Listening {
                event_t_s,
                snr,
                snr_needed,
                beats,
                beats_to_go,
            } => control::tracker::ListenProgress {
                t_s: *event_t_s,
                snr: *snr,
                snr_needed: *snr_needed,
                beats: *beats,
                beats_to_go: *beats_to_go,
            }
            .describe(),
            EventKind::StoppedShort {
                what,
                target,
                shortfall_m,
                shortfall_reason,
            } => format!(
                "{what}: stopped {:.2} mm short of {} ({shortfall_reason})",
                shortfall_m * 1e3,
                mm(target)
            ),
        };
        format!(
            "{:8.2} s  believed {}  true {}  {:5.2} mm off the artery at {:5.1} mm  {what}",
            self.t_s,
            mm(&self.believed_sensor),
            mm(&self.true_sensor),
            self.off_artery_m * 1e3,
            self.along_path_m * 1e3,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use control::tracker::LocatedPoint;

    fn at(event: EventKind) -> TrialEvent {
        TrialEvent {
            t_s: 12.5,
            believed_sensor: SurfacePoint::new(0.01, -0.002),
            true_sensor: SurfacePoint::new(0.0105, -0.0021),
            off_artery_m: 0.0004,
            along_path_m: 0.03,
            event,
        }
    }

    #[test]
    fn every_kind_is_one_flat_json_object_in_si() {
        let located = at(EventKind::from(TrackerEvent::Located(LocatedPoint {
            t_s: 12.4,
            point: SurfacePoint::new(0.011, -0.002),
            sensor: SurfacePoint::new(0.01, -0.002),
            element: 5.5,
            amplitude_n: 0.03,
            seed: true,
            sd_m: Some(2e-4),
        })));
        let v = serde_json::to_value(&located).expect("serializes");
        assert_eq!(v["kind"], "located");
        assert_eq!(v["t_s"], 12.5);
        assert_eq!(v["event_t_s"], 12.4);
        assert_eq!(v["believed_sensor"]["x_m"], 0.01);
        assert_eq!(v["true_sensor"]["z_m"], -0.0021);
        assert_eq!(v["point"]["x_m"], 0.011);
        assert_eq!(v["sd_m"], 2e-4);
        assert_eq!(v["seed"], true);
        let finished = at(EventKind::from(TrackerEvent::Finished {
            t_s: 20.0,
            reason: EndReason::LengthReached,
        }));
        let v = serde_json::to_value(&finished).expect("serializes");
        assert_eq!(
            (v["kind"].as_str(), v["reason"].as_str()),
            (Some("finished"), Some("length_reached"))
        );
        assert!(
            finished.describe().contains("finished: LengthReached"),
            "{}",
            finished.describe()
        );
        let missed = at(EventKind::from(TrackerEvent::Missed {
            t_s: 1.0,
            at: SurfacePoint::new(f64::NAN, 0.0),
        }));
        // A non-finite coordinate is null, never invalid JSON.
        let line = serde_json::to_string(&missed).expect("serializes");
        let v: serde_json::Value = serde_json::from_str(&line).expect("parses");
        assert!(v["at"]["x_m"].is_null(), "{line}");
    }
}
