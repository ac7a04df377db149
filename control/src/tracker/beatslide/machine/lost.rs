//! `beatslide` after the pulse is lost while sliding: where can the artery be?
//!
//! 1. Stop and search at rest where it stopped. A pulse found there on the predicted path
//!    continues the track; one found off it (the array reaches ±9 mm) is a bend: the path
//!    model is re-seeded from the last fix to it. With `listen_returning`, a regular
//!    heart's clear pulse skips this search (`goes_back_at_once`).
//! 2. Nothing there: go back to the last fix and search there. With `listen_returning` it
//!    listens in windows on the way: a clear fix of this artery is placed as in 1, and the
//!    slide goes on from it (that fix steers, it is not reported).
//! 3. Found there: the heading that lost it is wrong, so do not leave along it again. Probe a
//!    short step ahead (`PROBE_M`; the array then sees turns of up to about 45 degrees) and
//!    search at rest, and re-seed the path model on the two points, as the surgeon's two
//!    placements seed it.
//!
//! Any search that finds nothing, or a pulse far weaker than this artery's, ends the track
//! `Lost`, at rest: a point is reported only where the array felt this artery.

use super::sliding::{ON_ARRAY_SNR_MARGIN, ON_ARRAY_USUAL_FRACTION};
use super::*;

/// How far ahead of the re-found last fix the probe is made, m.
const PROBE_M: f64 = 0.008;

impl BeatSlide {
    pub(super) fn step_stopping(&mut self, input: &TrackerInput<'_>, frames: u64, attempt: usize) {
        if attempt == 1
            && self.goes_back_at_once()
            && let Some(toward) = self.last_fix
        {
            return self.go_back(input.frame.t_s, toward);
        }
        if frames > 0 && input.settled {
            self.state = State::Searching {
                since_s: Some(input.frame.t_s),
                attempt,
            };
        } else {
            self.state = State::Stopping {
                frames: frames.saturating_add(1),
                attempt,
            };
        }
    }

    /// Back toward the last fix, `toward` (then a search there: attempt 2).
    fn go_back(&mut self, t_s: f64, toward: SurfacePoint) {
        self.emit(TrackerEvent::Backtracking { t_s, toward });
        self.state = State::Returning {
            target: toward,
            frames: 0,
            attempt: 2,
            from_s: None,
        };
    }

    /// Going back listening, without the search at rest where it stopped: for a regular
    /// heart's clear pulse (one beat per fix), whose loss while sliding is the artery
    /// leaving the array, not a beat the window missed. On the tuning families (seeds
    /// 1001-1060) that search found the pulse in none of 25 losses on smooth courses;
    /// skipping it for every heart cost the fast, irregular hearts 7 beats per 26 cm and
    /// seed-bench-mixed (weak pulses) 3 completions.
    fn goes_back_at_once(&self) -> bool {
        self.params.listen_returning && !self.heart_irregular() && self.beats_per_fix == 1
    }

    /// A search at rest since `since` that found this artery on the array, as an
    /// observation.
    fn refound(
        &mut self,
        since: f64,
    ) -> Result<(PulseFound, KernelFit, SurfacePoint, Observation), Miss> {
        let (found, fit, sensor) = self.search_at_rest(since)?;
        self.check_amplitude(&fit)?;
        self.check_on_array(&fit)?;
        let observation = Observation {
            point: SurfacePoint::new(sensor.x_m, sensor.z_m + fit.offset_z_m),
            sd_m: self.fix_sd(&fit),
            lag_dir: self.history.since(since).mean_lag(),
        };
        Ok((found, fit, sensor, observation))
    }

    /// Re-finding the artery needs it on the array, not at its edge: the fit's centre within
    /// half an element of the ends and its place known within two pitches.
    fn check_on_array(&self, fit: &KernelFit) -> Result<(), Miss> {
        let on = fit.element >= -0.5 && fit.element <= crate::types::ELEMENTS as f64 - 0.5;
        // A NaN SE fails the comparison: not placed.
        if on && fit.offset_se_m < 2.0 * self.geometry.pitch_m {
            Ok(())
        } else {
            Err(Miss::AtEdge {
                element: fit.element,
            })
        }
    }

    /// Start the path model afresh from two observations (the heading along their chord),
    /// keeping what it learned of the sensor's lag. Returns `to`'s artery point.
    fn reseed(&mut self, from: Observation, to: Observation) -> Result<SurfacePoint, Miss> {
        let filter = self.filter.as_ref().ok_or(Miss::NoModel)?;
        if from.point.distance_to(&to.point) < self.geometry.pitch_m {
            return Err(Miss::OffPath(PathFilterError::NoDirection));
        }
        let mut settings = filter_settings(&self.params);
        settings.lag_prior_m = filter.lag_m();
        settings.lag_prior_sd_m = filter.lag_sd_m().max(1e-4);
        let fresh = PathFilter::from_observations(&[from, to], f64::NAN, settings)?;
        let point = fresh.corrected(&to);
        self.filter = Some(fresh);
        Ok(point)
    }

    /// Where it stopped: on the predicted path (widened, as it may have drifted while the
    /// pulse was missing), or else a bend from the last fix.
    fn refound_where_stopped(&mut self, observation: Observation) -> Result<SurfacePoint, Miss> {
        let filter = self.filter.as_mut().ok_or(Miss::NoModel)?;
        let mut widened = *filter;
        widened.inflate(2.0);
        match widened.update(&observation) {
            Ok(_) => {
                *filter = widened;
                Ok(filter.corrected(&observation))
            }
            Err(PathFilterError::OutsideGate { .. }) => {
                let last = self.last_fix.ok_or(Miss::NoModel)?;
                let from = Observation {
                    point: last,
                    sd_m: self.params.fix_floor_m,
                    lag_dir: [0.0, 0.0],
                };
                self.reseed(from, observation)
            }
            Err(e) => Err(e.into()),
        }
    }

    pub(super) fn step_searching(
        &mut self,
        input: &TrackerInput<'_>,
        mut since_s: Option<f64>,
        attempt: usize,
    ) {
        let t = input.frame.t_s;
        // At least the beats a fix of this pulse takes: a weak pulse that needs twelve beats
        // per fix is not found in four seconds.
        let window_s = self.params.search_window_s.max(self.window_len_s());
        let ready = self.rest_window(input, &mut since_s, window_s);
        self.state = State::Searching { since_s, attempt };
        let Some(since) = ready else {
            return;
        };
        let found = self
            .refound(since)
            .and_then(|(found, fit, sensor, observation)| {
                let point = match attempt {
                    1 => self.refound_where_stopped(observation)?,
                    2 => {
                        let filter = self.filter.as_ref().ok_or(Miss::NoModel)?;
                        self.anchor = Some(observation);
                        filter.corrected(&observation)
                    }
                    _ => {
                        let anchor = self.anchor.take().ok_or(Miss::NoModel)?;
                        self.reseed(anchor, observation)?
                    }
                };
                Ok((found, fit, sensor, point, observation))
            });
        let (found, fit, sensor, point, observation) = match found {
            Ok(f) => f,
            Err(why) => {
                self.last_miss = Some(why);
                let at = self
                    .history
                    .since(since)
                    .mean_sensor()
                    .unwrap_or(input.sensor);
                self.emit(TrackerEvent::Missed { t_s: t, at });
                match (attempt, self.last_fix) {
                    (1, Some(toward)) => self.go_back(t, toward),
                    _ => self.finish(EndReason::Lost, t),
                }
                return;
            }
        };
        self.learn_pulse(&found, &fit, t - since, t);
        let mut sd_m = self.point_sd(observation.sd_m, observation.lag_dir);
        // At rest, as at a mark: reported where the arm's load puts it, if read.
        let (reported, at) = match self.placed_at_rest(since, observation.point, sensor) {
            Some(placed) => {
                sd_m = observation.sd_m;
                placed
            }
            None => (point, sensor),
        };
        let located = self.located(0.5 * (since + t), reported, at, &fit, false, sd_m);
        self.record(point);
        if !self.smeared(t - since)
            && let Some(located) = self.at_rest_reported(since, t, located, &fit, observation.point)
        {
            self.report(located, &fit, 0.0);
        }
        if self.length_reached() {
            self.finish(EndReason::LengthReached, t);
            return;
        }
        if attempt == 2 {
            self.returns += 1;
            self.progress_mark_m = self.path_length_m;
            if self.returns > self.params.max_returns {
                self.last_miss = Some(Miss::NoProgress);
                self.finish(EndReason::Lost, t);
                return;
            }
            // The probe: a short step ahead along the path as now modelled.
            let heading = self.filter.as_ref().map(|f| {
                let (s, _) = f.to_local(point);
                f.predict(s).heading_rad
            });
            match heading {
                Some(h) if h.is_finite() => {
                    self.state = State::Returning {
                        target: SurfacePoint::new(
                            point.x_m + PROBE_M * h.cos(),
                            point.z_m + PROBE_M * h.sin(),
                        ),
                        frames: 0,
                        attempt: 3,
                        from_s: None,
                    };
                }
                _ => self.finish(EndReason::Lost, t),
            }
            return;
        }
        // Carry on more carefully.
        self.speed_cap_m_s =
            (0.5 * self.speed_cap_m_s).max(MIN_TRAVEL_PER_FIX_M / self.window_len_s().max(1e-3));
        self.start_sliding(input.sensor, t);
        if let State::Sliding { from_s, .. } = &mut self.state {
            *from_s = Some(t);
        }
    }

    pub(super) fn step_returning(
        &mut self,
        input: &TrackerInput<'_>,
        target: SurfacePoint,
        frames: u64,
        attempt: usize,
        from_s: Option<f64>,
    ) {
        let t = input.frame.t_s;
        let mut from_s = from_s;
        if attempt == 2 && self.params.listen_returning {
            let from = from_s.unwrap_or(t);
            from_s = Some(from);
            if t - from + 1e-9 >= self.window_len_s()
                && self.events.has_room_for(EVENTS_PER_ANALYSIS)
            {
                match self.fix_while_returning(from) {
                    Ok((fix, point)) => {
                        self.refound_returning(&fix, point, input.sensor, t);
                        return;
                    }
                    Err(why) => {
                        self.last_miss = Some(why);
                        from_s = Some(t);
                    }
                }
            }
        }
        if frames > 0 && input.settled {
            self.state = State::Searching {
                since_s: Some(t),
                attempt,
            };
        } else {
            self.state = State::Returning {
                target,
                frames: frames.saturating_add(1),
                attempt,
                from_s,
            };
        }
    }

    /// A window heard while going back to the last fix: timed on the whole array (where
    /// the artery lies on it is not known), as clear as a second look must be, on the
    /// array and not at its edge, of this artery's amplitude. The artery point is placed
    /// as at a search where the sensor stopped: on the predicted path, or else a bend from
    /// the last fix.
    fn fix_while_returning(&mut self, from_s: f64) -> Result<(BeatFix, SurfacePoint), Miss> {
        let fix = self.analyse_with(from_s, f64::INFINITY, analyse_window_on_array)?;
        let point = self.judge_returning(&fix)?;
        Ok((fix, point))
    }

    /// Is a fix heard on the way back this artery? Its artery point if so.
    pub(super) fn judge_returning(&mut self, fix: &BeatFix) -> Result<SurfacePoint, Miss> {
        let k = &fix.kernel;
        let needed = (ON_ARRAY_SNR_MARGIN * self.params.fix_snr)
            .max(ON_ARRAY_USUAL_FRACTION * self.usual_snr());
        if k.snr().is_nan() || k.snr() < needed {
            return Err(Miss::Weak {
                snr: k.snr(),
                needed,
            });
        }
        if k.at_edge {
            return Err(Miss::AtEdge { element: k.element });
        }
        self.check_on_array(k)?;
        self.check_amplitude(k)?;
        let observation = Observation {
            point: fix.point(),
            sd_m: self.fix_sd(k).hypot(self.tissue.sd_m()),
            lag_dir: fix.lag_dir,
        };
        self.refound_where_stopped(observation)
    }

    /// The artery heard on the way back: slide on from there, more carefully, as after a
    /// search that found it; the fix steers and is not reported (it was timed freely).
    pub(super) fn refound_returning(
        &mut self,
        fix: &BeatFix,
        point: SurfacePoint,
        sensor: SurfacePoint,
        t: f64,
    ) {
        self.returns += 1;
        if self.returns > self.params.max_returns {
            self.last_miss = Some(Miss::NoProgress);
            self.finish(EndReason::Lost, t);
            return;
        }
        self.speed_cap_m_s =
            (0.5 * self.speed_cap_m_s).max(MIN_TRAVEL_PER_FIX_M / self.window_len_s().max(1e-3));
        self.after_fix(fix, point, sensor, t, false, true);
        self.progress_mark_m = self.path_length_m;
    }
}
