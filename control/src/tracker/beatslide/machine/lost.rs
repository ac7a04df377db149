//! `beatslide` after the pulse is lost while sliding: stop, search at rest, go back to the
//! last fix and search there, and end `Lost` at rest if that fails too.

use super::*;

impl BeatSlide {
    pub(super) fn step_stopping(&mut self, input: &TrackerInput<'_>, frames: u64, attempt: usize) {
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

    pub(super) fn step_searching(
        &mut self,
        input: &TrackerInput<'_>,
        mut since_s: Option<f64>,
        attempt: usize,
    ) {
        let t = input.frame.t_s;
        let ready = self.rest_window(input, &mut since_s, self.params.search_window_s);
        self.state = State::Searching { since_s, attempt };
        let Some(since) = ready else {
            return;
        };
        let found = self.search_at_rest(since).and_then(|(found, fit, sensor)| {
            // Re-finding the artery needs it on the array, not at its edge.
            if !(fit.element >= -0.5 && fit.element <= crate::types::ELEMENTS as f64 - 0.5)
                || fit.offset_se_m >= 2.0 * self.geometry.pitch_m
            {
                return Err(Miss::AtEdge {
                    element: fit.element,
                });
            }
            let observation = Observation {
                point: SurfacePoint::new(sensor.x_m, sensor.z_m + fit.offset_z_m),
                sd_m: self.fix_sd(&fit),
                lag_dir: self.history.since(since).mean_lag(),
            };
            let filter = self.filter.as_mut().ok_or(Miss::NoModel)?;
            // The model may have drifted while the pulse was missing: widen it first.
            let mut widened = *filter;
            widened.inflate(2.0);
            widened.update(&observation)?;
            *filter = widened;
            Ok((found, fit, sensor, filter.corrected(&observation)))
        });
        match found {
            Ok((found, fit, sensor, point)) => {
                self.learn_pulse(&found, &fit, t - since, t);
                let located = self.located(t, point, sensor, &fit, false);
                self.record(point);
                self.emit(TrackerEvent::Located(located));
                if attempt > 1 {
                    self.returns += 1;
                    self.progress_mark_m = self.path_length_m;
                }
                if self.length_reached() {
                    self.finish(EndReason::LengthReached, t);
                } else if self.returns > self.params.max_returns {
                    self.last_miss = Some(Miss::NoProgress);
                    self.finish(EndReason::Lost, t);
                } else {
                    // Carry on more carefully.
                    self.speed_cap_m_s = (0.5 * self.speed_cap_m_s)
                        .max(MIN_TRAVEL_PER_FIX_M / self.window_len_s().max(1e-3));
                    self.start_sliding(input.sensor, t);
                    if let State::Sliding { from_s, .. } = &mut self.state {
                        *from_s = Some(t);
                    }
                }
            }
            Err(why) => {
                self.last_miss = Some(why);
                let at = self
                    .history
                    .since(since)
                    .mean_sensor()
                    .unwrap_or(input.sensor);
                self.emit(TrackerEvent::Missed { t_s: t, at });
                match (attempt, self.last_fix) {
                    (1, Some(toward)) => {
                        self.emit(TrackerEvent::Backtracking { t_s: t, toward });
                        self.state = State::Returning {
                            target: toward,
                            frames: 0,
                        };
                    }
                    _ => self.finish(EndReason::Lost, t),
                }
            }
        }
    }

    pub(super) fn step_returning(
        &mut self,
        input: &TrackerInput<'_>,
        target: SurfacePoint,
        frames: u64,
    ) {
        if frames > 0 && input.settled {
            self.state = State::Searching {
                since_s: Some(input.frame.t_s),
                attempt: 2,
            };
        } else {
            self.state = State::Returning {
                target,
                frames: frames.saturating_add(1),
            };
        }
    }
}
