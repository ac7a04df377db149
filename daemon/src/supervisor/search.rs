//! The supervisor's side of an autonomous search (the `search` verb, docs/search.md): the
//! searcher (control's `search`) fed every tactile frame while the state is `searching`,
//! its looks turned into bounded motion commands inside the workspace, and its looks and
//! end published on the `search` stream and recorded, with its map, in its own file
//! (`search_recording.rs`). A search opens no trial: it ends at rest, and its two seed
//! points are where the surgeon (or `pulsetrack search --then-track`) marks them.

use control::search::{SearchEvent, SearchOutcome, Searcher};

use super::*;

impl Supervisor {
    /// Start a search of `region` from where the arm rests.
    pub(super) fn search_start(
        &mut self,
        id: u64,
        to: Responder,
        region: control::search::Region,
        method: control::search::SearchMethod,
        heading_rad: Option<f64>,
    ) {
        for corner in [
            SurfacePoint::new(region.x0_m, region.z0_m),
            SurfacePoint::new(region.x1_m, region.z1_m),
        ] {
            if !self.in_workspace(corner) {
                return self.reply_err(
                    id,
                    to,
                    ErrorCode::Refused,
                    &format!(
                        "the region's corner ({:.1}, {:.1}) mm lies outside the workspace (safety.workspace_x_m, workspace_z_m)",
                        corner.x_m * 1e3,
                        corner.z_m * 1e3
                    ),
                );
            }
        }
        // A search is recorded: refused, as a trial's first mark is, where it cannot be.
        if let Err(why) =
            crate::recording::space::check_room(&self.s.recording_dir, self.s.min_free_bytes)
        {
            return self.reply_err(id, to, ErrorCode::Refused, &why);
        }
        let built = Searcher::new(self.s.search, self.calibration.sensor(), region, method)
            .and_then(|s| match heading_rad {
                Some(h) => s.expect_heading(h),
                None => Ok(s),
            });
        let searcher = match built {
            Ok(s) => s,
            Err(e) => return self.reply_err(id, to, ErrorCode::Refused, &e.to_string()),
        };
        self.searcher = Some(searcher);
        self.search_looks.clear();
        self.set_state(OpState::Searching);
        let t = self.now_s();
        let request =
            json!({"method": method.as_str(), "region": region, "heading_rad": heading_rad});
        self.open_search_recording(t, &request);
        let v = json!({"event": "search", "kind": "started", "t_s": t, "method": method.as_str(),
            "region": region, "heading_rad": heading_rad,
            "recording": self.search_recording_path()});
        self.record(Topic::Events, t, &v);
        self.publish(Stream::Search, 0, &v, true);
        self.reply_ok(
            id,
            to,
            json!({"region": region, "method": method.as_str()}),
            true,
        );
    }

    /// Feed one frame to the search; its move or hold goes to the loop.
    pub(super) fn search_frame(&mut self, f: &StampedFrame, settled: bool) {
        let corrected = self
            .calibration
            .tactile()
            .map(|c| c.correct_frame(&f.frame));
        let Some(searcher) = self.searcher.as_mut() else {
            return;
        };
        let out = searcher.step(&TrackerInput {
            frame: corrected.as_ref().unwrap_or(&f.frame),
            sensor: f.sensor,
            settled,
            loaded_sensor: f.loaded_sensor,
        });
        match out.motion {
            MotionCommand::MoveTo { target, speed_m_s } => {
                if self.tracker_target != Some(target) {
                    self.search_move(target, speed_m_s);
                }
            }
            MotionCommand::Hold => {
                if self.tracker_target.take().is_some() {
                    let seq = self.seq();
                    self.motion_seq = seq;
                    self.send(ControlCommand::Hold { seq }, Purpose::TrackerHold, None);
                }
            }
        }
        if let Some(e) = out.event {
            self.search_event(e);
        }
    }

    fn search_move(&mut self, target: SurfacePoint, speed_m_s: f64) {
        self.tracker_target = Some(target);
        if !self.in_workspace(target) {
            // The region lies inside the workspace, so this is a look the searcher must
            // not be sent to: it chooses another.
            if let Some(s) = self.searcher.as_mut() {
                s.target_unreachable();
            }
            self.tracker_target = None;
            return;
        }
        self.send_autonomous_move(target, speed_m_s);
    }

    fn search_event(&mut self, e: SearchEvent) {
        let (kind, t_s) = match &e {
            SearchEvent::Look(r) => ("look", r.t_s),
            SearchEvent::Finished(o) => (
                "finished",
                match o {
                    SearchOutcome::Found { t_s, .. }
                    | SearchOutcome::NotFound { t_s, .. }
                    | SearchOutcome::Stopped { t_s, .. } => *t_s,
                },
            ),
        };
        let mut v = serde_json::to_value(e).unwrap_or_default();
        if let Value::Object(o) = &mut v {
            o.insert("event".into(), Value::from("search"));
            o.insert("kind".into(), Value::from(kind));
            o.insert("t_s".into(), Value::from(t_s));
        }
        self.record(Topic::Events, t_s, &v);
        self.publish(Stream::Search, 0, &v, true);
        if let SearchEvent::Look(r) = &e {
            self.search_looks.push((r.at, r.felt.is_some()));
            self.live_search_map(t_s);
        }
        if let SearchEvent::Finished(o) = e {
            self.log_line(t_s, level::INFO, describe(&o));
            self.close_search_recording(&v);
            self.searcher = None;
            self.tracker_target = None;
            if self.state == OpState::Searching {
                self.set_state(OpState::Holding);
            }
        }
    }

    /// End a search now (stop, disable, a fault): its end is published as `stopped`.
    pub(super) fn search_abort(&mut self) {
        let Some(mut s) = self.searcher.take() else {
            return;
        };
        s.stop();
        if let Some(o) = s.outcome().copied() {
            self.searcher = Some(s);
            self.search_event(SearchEvent::Finished(o));
        }
    }

    /// The arm stopped short of a look: the searcher chooses another.
    pub(super) fn search_stopped_short(&mut self) {
        self.tracker_target = None;
        if let Some(s) = self.searcher.as_mut() {
            s.target_unreachable();
        }
    }
}

/// One line for the log.
fn describe(o: &SearchOutcome) -> String {
    match o {
        SearchOutcome::Found {
            seeds,
            heading_rad,
            looks,
            ..
        } => format!(
            "search found the artery after {looks} looks: seeds ({:.2}, {:.2}) and ({:.2}, {:.2}) mm, heading {:.1} deg",
            seeds[0].point.x_m * 1e3,
            seeds[0].point.z_m * 1e3,
            seeds[1].point.x_m * 1e3,
            seeds[1].point.z_m * 1e3,
            heading_rad.to_degrees()
        ),
        SearchOutcome::NotFound {
            reason,
            weakest_felt_n,
            looks,
            ..
        } => format!(
            "search found no artery after {looks} looks ({}); a pulse under {:.1} mN may have been missed",
            reason.as_str(),
            weakest_felt_n * 1e3
        ),
        SearchOutcome::Stopped { looks, .. } => format!("search stopped after {looks} looks"),
    }
}
