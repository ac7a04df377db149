//! `beatslide` at a manual placement: acquire at rest, search the window for the pulse
//! (growing it while nothing is found), and make the mark's seed and reported point.

use super::*;

impl BeatSlide {
    /// One frame of a mark: once its window at rest is full, search it; a pulse found makes
    /// the seed (or a move over an artery felt beyond the array's end, `replacing.rs`),
    /// nothing found grows the window up to `mark_max_window_s`, then misses.
    pub(super) fn step_marking(
        &mut self,
        input: &TrackerInput<'_>,
        mut since_s: Option<f64>,
        window_s: f64,
    ) {
        let t = input.frame.t_s;
        let ready = self.rest_window(input, &mut since_s, window_s);
        self.state = State::Marking { since_s, window_s };
        let Some(since) = ready else {
            return;
        };
        // A mark must know which way its pulse points: at a weak pulse's noise the pattern
        // and its inverse can fit the kernel about equally well, at places 5-8 mm apart
        // (`sign_margin_chi2`). Such a window grows like one that found nothing.
        let searched = self.search_at_rest(since).and_then(|r| {
            let margin_chi2 = self.sign_margin_chi2(&r.0);
            if margin_chi2 < rest_search::SIGN_MARGIN_CHI2 {
                Err(Miss::SignAmbiguous { margin_chi2 })
            } else {
                Ok(r)
            }
        });
        match searched {
            Ok((found, fit, sensor)) => {
                let replaced = self.replaced.take();
                let Some(outcome) = self.mark_outcome(&found, &fit, sensor, since, t) else {
                    return;
                };
                match replaced {
                    // After a move onto the artery: the new mark, unless it found the artery
                    // on the array's far half (`machine/replacing.rs`).
                    Some(first) if fit.offset_z_m * first.side < 0.0 => {
                        self.accept_mark(first.outcome)
                    }
                    Some(first) => self.accept_mark(MarkOutcome {
                        placement: first.outcome.placement,
                        ..outcome
                    }),
                    None if self.should_replace(&fit) => {
                        self.begin_replacing(outcome, &fit, sensor, t)
                    }
                    None => self.accept_mark(outcome),
                }
            }
            Err(why) => {
                self.last_miss = Some(why);
                self.first_side = None;
                if window_s + self.params.mark_extend_s <= self.params.mark_max_window_s + 1e-9 {
                    self.state = State::Marking {
                        since_s: Some(since),
                        window_s: window_s + self.params.mark_extend_s,
                    };
                } else if let Some(first) = self.replaced.take() {
                    // Nothing after a move onto the artery: the placement's mark stands.
                    self.accept_mark(first.outcome);
                } else if self.can_listen() {
                    // Too weak for a window: listen on (`machine/weak.rs`).
                    self.begin_listening(ListenFor::Mark, since, t);
                } else {
                    let at = self
                        .history
                        .since(since)
                        .mean_sensor()
                        .unwrap_or(input.sensor);
                    self.emit(TrackerEvent::Missed { t_s: t, at });
                    self.state = State::Seeding;
                }
            }
        }
    }

    /// What a mark found in its window from `since` to `t`, as the seed it makes and the
    /// point it reports; `None` when it was the first side of a seated mark (the other
    /// side's stroke has begun).
    pub(super) fn mark_outcome(
        &mut self,
        found: &PulseFound,
        fit: &KernelFit,
        sensor: SurfacePoint,
        since: f64,
        t: f64,
    ) -> Option<MarkOutcome> {
        self.learn_pulse(found, fit, t - since, t);
        let lag_dir = self.history.since(since).mean_lag();
        let raw = SurfacePoint::new(sensor.x_m, sensor.z_m + fit.offset_z_m);
        let side = SideMark {
            raw,
            sd_m: self.fix_sd(fit),
        };
        let (raw, side_sd) = match self.seated_mark(side, t) {
            SeatedMark::OtherSide => return None,
            SeatedMark::Both { raw, sd_m } => (raw, Some(sd_m)),
            SeatedMark::NotSeated => (raw, None),
        };
        // A mark made from both sides has no lag left in it.
        let (lag_dir, known) = if side_sd.is_some() {
            ([0.0, 0.0], 1.0)
        } else {
            (lag_dir, lag_known(lag_dir))
        };
        let (observation, point) = self.mark_seed(
            raw,
            side_sd.unwrap_or_else(|| self.fix_sd(fit)),
            lag_dir,
            known,
        );
        let mut sd_m = self.point_sd(observation.sd_m, lag_dir);
        // Reported where the arm's load puts it, if read. A mark from both sides is two
        // windows and has no lag left in it: it stays as it is.
        let placed = self.placed_at_rest(since, raw, sensor);
        let (reported, at) = match placed.filter(|_| side_sd.is_none()) {
            Some(placed) => {
                sd_m = self.fix_sd(fit);
                placed
            }
            None => (point, sensor),
        };
        let located = self.located(0.5 * (since + t), reported, at, fit, true, sd_m);
        // Under moving tissue the window's average is no moment's place: report the beats'
        // (`machine/rest_beats.rs`). A mark from both sides stays. The mark must answer
        // (the runner and the daemon wait for its result), so where the beats give no
        // place the window's is reported, as on still tissue; so is a place beyond the
        // array's end, with its SD (`report`).
        let located = match side_sd {
            Some(_) => located,
            None => self
                .at_rest_reported(since, t, located, fit, raw)
                .unwrap_or(located),
        };
        Some(MarkOutcome {
            observation,
            point,
            placement: sensor,
            located,
        })
    }

    /// A mark's observation for the path filter and its seed point, from the place `raw`
    /// felt with the believed sensor positions, its fit's SD, the window's mean lag
    /// direction and how much of it is known (`lag_known`): the unknown part of the lag is
    /// uncertainty, the known part is taken off the point.
    pub(super) fn mark_seed(
        &self,
        raw: SurfacePoint,
        fix_sd_m: f64,
        lag_dir: [f64; 2],
        known: f64,
    ) -> (Observation, SurfacePoint) {
        let lag = self.params.lag_prior_m;
        let observation = Observation {
            point: raw,
            sd_m: fix_sd_m.hypot(lag * (1.0 - known)),
            lag_dir,
        };
        let point = SurfacePoint::new(raw.x_m - lag * lag_dir[0], raw.z_m - lag * lag_dir[1]);
        (observation, point)
    }

    /// Make a mark's outcome the next seed and report its point.
    pub(super) fn accept_mark(&mut self, outcome: MarkOutcome) {
        if self.seeds.len() == MAX_SEEDS {
            self.seeds.remove(0);
            self.seed_points.remove(0);
            self.seed_sensors.remove(0);
        }
        self.seeds.push(outcome.observation);
        self.seed_points.push(outcome.point);
        self.seed_sensors.push(outcome.placement);
        self.emit(TrackerEvent::Located(outcome.located));
        self.state = State::Seeding;
    }
}

/// How much of the sensor's lag at a mark is known: where it trailed before the mark is
/// unknown until the robot has been seen to move (the window's mean lag direction has unit
/// length only if it moved throughout).
pub(super) fn lag_known(lag_dir: [f64; 2]) -> f64 {
    lag_dir[0].hypot(lag_dir[1]).min(1.0)
}
