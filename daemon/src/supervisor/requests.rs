//! The supervisor's answers to console requests: each verb accepted or refused for the
//! operating state, with the reason, and turned into commands for the control loop.

use super::*;
use crate::recording::messages::VerbRecord;

impl Supervisor {
    pub(super) fn on_request(&mut self, id: u64, verb: Verb, to: Responder) {
        if self.shutdown.is_some() {
            return self.reply_err(
                id,
                to,
                ErrorCode::Unavailable,
                "the daemon is shutting down",
            );
        }
        if let Verb::Status = verb {
            // Not recorded: a status changes nothing, and consoles poll it.
            let mut status = self.status_json();
            if let Value::Object(o) = &mut status {
                o.insert("state".into(), Value::from(self.state.as_str()));
            }
            let _ = self.links.recorder.send(RecorderMsg::Reply {
                to,
                reply: ok_reply(id, status),
                durable: false,
            });
            return;
        }
        if let Err(why) = state::admit(self.state, &verb, &self.context()) {
            return self.reply_err(id, to, ErrorCode::WrongState, &why);
        }
        // A trial or a search placed through a tissue frame that a later pivot calibration
        // or homing made untrue would report points off the artery.
        if matches!(verb, Verb::Mark | Verb::Track { .. } | Verb::Search { .. })
            && let Some(why) = self.tissue_stale()
        {
            return self.reply_err(id, to, ErrorCode::WrongState, &why);
        }
        let t = self.now_s();
        let verb_name = verb.name();
        let logged = serde_json::to_value(VerbRecord {
            event: "verb".into(),
            t_s: t,
            id,
            verb: verb_name.into(),
            args: verb.args(),
            client: to.client,
        })
        .unwrap_or_default();
        // A mark that starts a trial is recorded in that trial, once it is open.
        if !matches!(verb, Verb::Mark) {
            self.record(Topic::Events, t, &logged);
            self.log_line(
                t,
                level::INFO,
                format!("{verb_name} (request {id} from uid {})", to.client.uid),
            );
        }
        match verb {
            Verb::Status | Verb::Subscribe { .. } | Verb::Unsubscribe => {
                self.reply_ok(id, to, json!({}), false)
            }
            Verb::Enable => {
                let seq = self.seq();
                self.send(
                    ControlCommand::Enable { seq },
                    Purpose::Enable,
                    Some((id, to)),
                );
            }
            Verb::Disable => {
                self.search_abort();
                self.touches_failed("disabled");
                self.sweep_failed("disabled: the arm was powered off where it was");
                self.end_trial(TrialEnd::Disabled);
                let seq = self.seq();
                self.send(
                    ControlCommand::Disable { seq },
                    Purpose::Disable,
                    Some((id, to)),
                );
            }
            Verb::Estop => {
                let seq = self.seq();
                self.send(
                    ControlCommand::Estop { seq },
                    Purpose::Estop,
                    Some((id, to)),
                );
            }
            Verb::Reset => {
                let seq = self.seq();
                self.send(
                    ControlCommand::Reset { seq },
                    Purpose::Reset,
                    Some((id, to)),
                );
            }
            Verb::Home => {
                let target = self.s.home;
                self.manual_move(id, to, target, self.s.move_speed_m_s);
            }
            Verb::Move {
                x_m,
                z_m,
                speed_m_s,
            } => {
                let speed = speed_m_s.unwrap_or(self.s.move_speed_m_s);
                self.manual_move(id, to, SurfacePoint::new(x_m, z_m), speed);
            }
            Verb::Jog { dx_m, dz_m } => {
                let from = self
                    .links
                    .status
                    .read()
                    .map(|s| s.setpoint)
                    .unwrap_or_default();
                let target = SurfacePoint::new(from.x_m + dx_m, from.z_m + dz_m);
                self.manual_move(id, to, target, self.s.move_speed_m_s);
            }
            Verb::Mark => self.mark(id, to, t, &logged),
            Verb::Track { length_m, label } => self.track(id, to, t, length_m, label),
            Verb::Pause => {
                let seq = self.seq();
                self.motion_seq = seq;
                self.send(ControlCommand::Hold { seq }, Purpose::Pause, Some((id, to)));
            }
            Verb::Resume => {
                self.set_state(OpState::Tracking);
                if let Some(target) = self.tracker_target.take() {
                    self.tracker_move(target, self.s.move_speed_m_s);
                }
                self.reply_ok(id, to, json!({}), true);
            }
            Verb::Stop => {
                if self.sweeping.is_some() {
                    return self.sweep_stop(id, to);
                }
                self.calibration_stop();
                self.touches_failed("stopped");
                if !self.state.powered() {
                    // Only a calibration recording was running (the table admits nothing
                    // else here): there is no arm to hold.
                    return self.reply_ok(id, to, json!({}), false);
                }
                match self.state {
                    OpState::Searching => self.search_abort(),
                    OpState::Tracking | OpState::Paused => {
                        self.tracker_stop();
                        self.end_trial(TrialEnd::Tracker(control::tracker::EndReason::Stopped));
                    }
                    OpState::Seeding => self.end_trial(TrialEnd::Abandoned),
                    _ => {}
                }
                let seq = self.seq();
                self.motion_seq = seq;
                self.send(
                    ControlCommand::Hold { seq },
                    Purpose::StopHold,
                    Some((id, to)),
                );
            }
            Verb::Debug(DebugAction::SilenceTactile { duration_s }) => {
                let seq = self.seq();
                self.send(
                    ControlCommand::SilenceTactile { seq, duration_s },
                    Purpose::Debug,
                    Some((id, to)),
                );
            }
            Verb::Debug(DebugAction::PlaceArray { load_per_element_n }) => {
                self.place_array(id, to, load_per_element_n)
            }
            Verb::Calibrate(step) => self.calibrate(id, to, step),
            Verb::Search {
                region,
                method,
                heading_rad,
            } => self.search_start(id, to, region, method, heading_rad),
        }
    }

    pub(super) fn manual_move(&mut self, id: u64, to: Responder, target: SurfacePoint, speed: f64) {
        if !self.in_workspace(target) {
            let why = format!(
                "target ({:.4}, {:.4}) m is outside the workspace x [{}, {}] m, z [{}, {}] m",
                target.x_m,
                target.z_m,
                self.s.workspace_x_m[0],
                self.s.workspace_x_m[1],
                self.s.workspace_z_m[0],
                self.s.workspace_z_m[1]
            );
            return self.reply_err(id, to, ErrorCode::OutOfRange, &why);
        }
        let speed = speed.min(self.s.max_speed_m_s);
        let seq = self.seq();
        self.send(
            ControlCommand::MoveTo {
                seq,
                target,
                speed_m_s: speed,
            },
            Purpose::ManualMove(target),
            Some((id, to)),
        );
    }

    /// A placement that was still moving when its settling time ran out has arrived after
    /// all: the hold that followed has come to rest (the loop's own verdict, from the
    /// encoders), and there the believed sensor centre is within the arrival tolerance of
    /// the placement's target. Judged afresh at each mark, not kept from the deadline.
    fn rests_on_placement(&self, short: super::StoppedShort) -> bool {
        let Some(target) = short.placement else {
            return false;
        };
        let Some(st) = self.links.status.read() else {
            return false;
        };
        st.settled
            && st.motion_seq == short.hold_seq
            && st.sensor.is_finite()
            && st.sensor.distance_to(&target) <= self.s.arrival_tolerance_m
    }

    pub(super) fn mark(&mut self, id: u64, to: Responder, t: f64, logged: &Value) {
        // A trial that could not be recorded is refused first: it is the lasting reason (a full
        // or read-only disk), where the arm's arrival below is a passing one.
        let starts_trial = self.state == OpState::Done || self.trial.is_none();
        if starts_trial
            && let Err(why) =
                crate::recording::space::check_room(&self.s.recording_dir, self.s.min_free_bytes)
        {
            return self.reply_err(id, to, ErrorCode::Refused, &why);
        }
        // Marks happen only where the arm has arrived (judged from the encoders).
        if let Some(short) = self.stopped_short
            && self.rests_on_placement(short)
        {
            self.stopped_short = None;
            self.log_line(
                t,
                level::INFO,
                format!(
                    "the arm came to rest within the arrival tolerance of its placement after its settling time ({}); marking",
                    short.shortfall
                ),
            );
        }
        if let Some(short) = self.stopped_short {
            let s = short.shortfall;
            let why = format!(
                "cannot mark here: {s} ({:.2} mm, more than the arrival tolerance); nothing was marked; move the arm onto the placement again (check the instrument's mass and the joints' friction)",
                s.distance_m * 1e3
            );
            return self.reply_err(id, to, ErrorCode::Refused, &why);
        }
        if let Some(st) = self.links.status.read()
            && !(st.settled && st.motion_seq == self.motion_seq)
        {
            return self.reply_err(
                id,
                to,
                ErrorCode::Refused,
                "cannot mark yet: the arm has not arrived at rest within the arrival tolerance of its target",
            );
        }
        if starts_trial {
            self.start_trial(t);
        }
        self.record(Topic::Events, t, logged);
        self.log_line(
            t,
            level::INFO,
            format!("mark (request {id} from uid {})", to.client.uid),
        );
        if self.tracker.is_none() {
            return self.reply_err(id, to, ErrorCode::Unavailable, "no tracker could be built");
        }
        self.record_tracker_call(TrackerCall::Mark);
        let Some(tracker) = self.tracker.as_mut() else {
            return self.reply_err(id, to, ErrorCode::Unavailable, "no tracker could be built");
        };
        match tracker.mark() {
            Ok(()) => {
                self.set_state(OpState::Seeding);
                self.reply_ok(id, to, json!({}), true);
            }
            Err(e) => self.reply_err(id, to, ErrorCode::WrongState, &e.to_string()),
        }
    }

    pub(super) fn track(
        &mut self,
        id: u64,
        to: Responder,
        t: f64,
        length_m: Option<f64>,
        label: Option<String>,
    ) {
        if self.tracker.is_none() {
            return self.reply_err(
                id,
                to,
                ErrorCode::WrongState,
                "no trial: mark two seed points first",
            );
        }
        self.record_tracker_call(TrackerCall::Start { length_m });
        let Some(tracker) = self.tracker.as_mut() else {
            return;
        };
        match tracker.start(TrackLimit { length_m }) {
            Ok(()) => {
                if let Some(trial) = self.trial.as_mut() {
                    trial.track_started_t_s = Some(t);
                    trial.length_m = length_m;
                    if label.is_some() {
                        trial.label = label.clone();
                    }
                }
                if let Some(label) = label {
                    let mut m = BTreeMap::new();
                    m.insert("label".to_string(), label);
                    m.insert("t_s".to_string(), json!(t).to_string());
                    let _ = self.links.recorder.send(RecorderMsg::Metadata {
                        record: ("label".to_string(), m),
                    });
                }
                self.tracker_target = None;
                self.set_state(OpState::Tracking);
                self.reply_ok(id, to, json!({"length_m": length_m}), true);
            }
            Err(e) => self.reply_err(id, to, ErrorCode::WrongState, &e.to_string()),
        }
    }

    // ----- trials -----
}
