//! The supervisor's side of a trial: tactile frames into the tracker, the tracker's moves
//! into bounded motion commands, and its events onto the console and the recording.

use super::*;

impl Supervisor {
    pub(super) fn on_frame(&mut self, f: StampedFrame) {
        self.frames_seen += 1;
        self.calibration_frame(&f.frame);
        if let Some(s) = f.shortfall
            && f.motion_seq == self.motion_seq
        {
            // Before the tracker sees the frame (and before the frame is recorded as one it
            // saw): a frame from a place the arm did not reach is never a mark or a fix.
            self.on_stopped_short(f.motion_seq, s);
        }
        let settled = f.settled && f.motion_seq == self.motion_seq;
        // The tracker sees every frame of its trial (it may still owe events from an
        // acquisition that just ended) except while paused: there the arm holds for the
        // operator, and `settled` would wrongly vouch for the tracker's interrupted move.
        // The state change below (moving -> holding) cannot pause, so this holds for both.
        let fed = self.tracker.is_some() && self.state != OpState::Paused;
        if self.tracker.is_none() {
            self.approach.push(f.sensor);
        }
        let sample = report::tactile_sample(&f, fed.then_some(settled));
        self.live_tactile(&sample);
        let mut ev = serde_json::to_value(&sample).unwrap_or_default();
        self.record_trial(Topic::Tactile, f.frame.t_s, &ev);
        if let Value::Object(o) = &mut ev {
            o.insert("event".into(), Value::from("tactile"));
        }
        self.publish(Stream::Tactile, f.frame.seq, &ev, false);

        if self.state == OpState::Moving && settled {
            self.set_state(OpState::Holding);
        }
        if self.searcher.is_some() {
            return self.search_frame(&f, settled);
        }
        if self.touching.is_some() {
            return self.touch_frame(&f, settled);
        }
        if !fed {
            return;
        }
        // The tracker reads the array as calibrated; the recording keeps the raw frame.
        let corrected = self
            .calibration
            .tactile()
            .map(|c| c.correct_frame(&f.frame));
        let Some(tracker) = self.tracker.as_mut() else {
            return;
        };
        let out = tracker.step(&TrackerInput {
            frame: corrected.as_ref().unwrap_or(&f.frame),
            sensor: f.sensor,
            settled,
            loaded_sensor: f.loaded_sensor,
        });
        if let Some(e) = out.event {
            self.on_tracker_event(e);
        }
        if self.state == OpState::Seeding {
            // The mark is over when its result (located or missed) has been reported,
            // which may be a frame or more after the tracker's phase went back.
            let result = matches!(
                out.event,
                Some(TrackerEvent::Located(_) | TrackerEvent::Missed { .. })
            );
            if result {
                self.set_state(OpState::Holding);
            }
        }
        // A mark may move the arm too (beatslide seats the sensor before its first).
        match self.state {
            OpState::Tracking | OpState::Seeding => match out.motion {
                MotionCommand::MoveTo { target, speed_m_s } => {
                    if self.tracker_target != Some(target) {
                        self.tracker_move(target, speed_m_s);
                    }
                }
                MotionCommand::Hold => {
                    if self.tracker_target.take().is_some() {
                        let seq = self.seq();
                        self.motion_seq = seq;
                        self.send(ControlCommand::Hold { seq }, Purpose::TrackerHold, None);
                    }
                }
            },
            _ => {}
        }
    }

    /// The current motion's settling time ran out short of its target (judged from the
    /// encoders): say so once, end a trial in progress as `short_of_target`, and hold where
    /// the arm is. A manual move that stopped short blocks `mark` until a move arrives.
    pub(super) fn on_stopped_short(&mut self, seq: u64, s: control::motion::Shortfall) {
        if self.stopped_short.is_some_and(|old| old.hold_seq == seq) {
            return;
        }
        let t = self.now_s();
        let v = json!({"event": "motion", "kind": "stopped_short", "t_s": t,
            "motion_seq": seq, "shortfall_m": s.distance_m, "reason": s.reason.as_str(),
            "message": s.to_string()});
        tracing::warn!("motion {seq}: {s}");
        self.record(Topic::Events, t, &v);
        self.publish(Stream::State, 0, &v, true);
        let tracking = matches!(
            self.state,
            OpState::Tracking | OpState::Seeding | OpState::Paused
        );
        if tracking {
            self.tracker_stop();
            self.end_trial(TrialEnd::ShortOfTarget);
        }
        let searching = self.searcher.is_some();
        self.touches_failed(&format!("the arm stopped short of a touch: {s}"));
        // The loop holds a stopped-short motion where the arm is, not at its target.
        let hold = self.seq();
        self.motion_seq = hold;
        self.tracker_target = None;
        self.send(
            ControlCommand::Hold { seq: hold },
            Purpose::TrackerHold,
            None,
        );
        // Remembered under the hold's number: `mark` stays refused while the arm rests here,
        // unless it rests within the arrival tolerance of the surgeon's placement after all.
        self.stopped_short = Some(super::StoppedShort {
            hold_seq: hold,
            shortfall: s,
            placement: self
                .placement
                .and_then(|(placed, target)| (placed == seq).then_some(target)),
        });
        if searching {
            // Not an end: the search looks elsewhere, from where the arm rests.
            self.search_stopped_short();
        } else if tracking {
            self.set_state(OpState::Done);
        } else if self.state == OpState::Moving {
            self.set_state(OpState::Holding);
        }
    }

    pub(super) fn tracker_move(&mut self, target: SurfacePoint, speed_m_s: f64) {
        self.tracker_target = Some(target);
        self.live_scene(self.now_s());
        if !self.in_workspace(target) {
            tracing::info!(
                "tracker target ({:.4}, {:.4}) m is outside the workspace",
                target.x_m,
                target.z_m
            );
            self.tracker_target_unreachable();
            return;
        }
        self.send_autonomous_move(target, speed_m_s);
    }

    /// A tracker's or a search's move to `target` (inside the workspace) at its asked speed,
    /// bounded by the motion limits; it becomes the motion frames are judged against.
    pub(super) fn send_autonomous_move(&mut self, target: SurfacePoint, speed_m_s: f64) {
        let seq = self.seq();
        self.motion_seq = seq;
        let speed = if speed_m_s.is_finite() && speed_m_s > 0.0 {
            speed_m_s.min(self.s.max_speed_m_s)
        } else {
            self.s.move_speed_m_s
        };
        self.send(
            ControlCommand::MoveTo {
                seq,
                target,
                speed_m_s: speed,
            },
            Purpose::TrackerMove,
            None,
        );
    }

    pub(super) fn on_tracker_event(&mut self, e: TrackerEvent) {
        let truth = self.truth;
        let (v, durable) = match e {
            TrackerEvent::Located(p) => {
                let rec = self
                    .trial
                    .as_mut()
                    .map(|t| t.add_located(&p, truth, self.judge.as_deref()));
                self.record_located_scene(p.t_s);
                self.log_line(
                    p.t_s,
                    level::INFO,
                    format!(
                        "located x {:.2} mm z {:.2} mm{}",
                        p.point.x_m * 1e3,
                        p.point.z_m * 1e3,
                        if p.seed { " (seed)" } else { "" }
                    ),
                );
                (
                    json!({"event": "detection", "kind": "located", "t_s": p.t_s, "point": rec}),
                    true,
                )
            }
            TrackerEvent::Missed { t_s, at } => {
                if let Some(t) = self.trial.as_mut() {
                    t.misses += 1;
                }
                (
                    json!({"event": "detection", "kind": "missed", "t_s": t_s, "x_m": at.x_m, "z_m": at.z_m}),
                    true,
                )
            }
            TrackerEvent::Backtracking { t_s, toward } => {
                if let Some(t) = self.trial.as_mut() {
                    t.backtracks += 1;
                }
                (
                    json!({"event": "detection", "kind": "backtracking", "t_s": t_s, "x_m": toward.x_m, "z_m": toward.z_m}),
                    false,
                )
            }
            TrackerEvent::Pulse { t_s, period_s } => {
                if let Some(t) = self.trial.as_mut() {
                    t.pulse_period_s = Some(period_s);
                }
                self.live_period(Some(period_s));
                (
                    json!({"event": "detection", "kind": "pulse", "t_s": t_s, "period_s": period_s}),
                    false,
                )
            }
            TrackerEvent::Listening(p) => {
                self.log_line(p.t_s, level::INFO, p.describe());
                let mut v = crate::recording::replay::listening_json(&p);
                v["event"] = "detection".into();
                (v, false)
            }
            TrackerEvent::Finished { t_s, reason } => {
                let v = json!({"event": "detection", "kind": "finished", "t_s": t_s, "reason": reason.as_str()});
                self.record(Topic::Events, t_s, &v);
                self.log_line(
                    t_s,
                    level::INFO,
                    format!("tracking finished: {}", reason.as_str()),
                );
                self.publish(Stream::Detections, 0, &v, true);
                self.end_trial(TrialEnd::Tracker(reason));
                let seq = self.seq();
                self.motion_seq = seq;
                self.send(ControlCommand::Hold { seq }, Purpose::TrackerHold, None);
                self.set_state(OpState::Done);
                return;
            }
        };
        let t = v["t_s"].as_f64().unwrap_or(0.0);
        self.record(Topic::Events, t, &v);
        self.publish(Stream::Detections, 0, &v, durable);
    }

    // ----- periodic work -----
}
