//! `beatslide` while tracking: plan the next target from the path filter, slide, analyse
//! each window of beats, accept or refuse its fix, and update the path and the beat clock.

use super::*;

/// A fix whose beats were timed each on its own needs this many times `fix_snr`: the free
/// timing fits noise too (2 of 300 noise-only windows reach an SNR of 5, `beat_fix`'s
/// tests).
const PER_BEAT_SNR_MARGIN: f64 = 1.5;

/// A fix timed on the whole array needs this many times `fix_snr`, and this fraction of the
/// artery's usual SNR (more than any other fix's `USUAL_SNR_FRACTION`). Not for noise (300
/// noise-only windows stay below 4, `beat_fix`'s tests) but for what else pulses: on the
/// whole array a pulsating lump beside the artery can be the clearest pulse of a window that
/// missed the artery. At 1.5 × `fix_snr` alone, two weak arteries of the tuning draws
/// (seed-bench-mixed, 1001-1030) were left for a lump 4-6 elements away; one was reported
/// 11 mm off.
pub(super) const ON_ARRAY_SNR_MARGIN: f64 = 2.0;
pub(super) const ON_ARRAY_USUAL_FRACTION: f64 = 0.7;

impl BeatSlide {
    /// The next target and speed from the path filter, for the sensor at `sensor`.
    pub(super) fn plan(&self, sensor: SurfacePoint) -> Option<(SurfacePoint, f64)> {
        let filter = self.filter.as_ref()?;
        let period = self.pulse.map_or(1.0, |p| p.clock.period_s());
        let window_s = self.beats_per_fix as f64 * period;
        let (s_now, _) = filter.to_local(sensor);
        let s_now = s_now.max(0.0);
        let mut travel = self
            .params
            .max_travel_per_fix_m
            .min(self.speed_cap_m_s * window_s);
        // The step from the model's confidence: shorten it until the path one step past
        // the sensor is predicted within `prediction_sd_m`.
        for _ in 0..30 {
            if travel <= MIN_TRAVEL_PER_FIX_M
                || filter.predict(s_now + travel).sd_m <= self.params.prediction_sd_m
            {
                break;
            }
            travel *= 0.85;
        }
        let travel = travel.max(MIN_TRAVEL_PER_FIX_M);
        let speed = (travel / window_s).min(self.speed_cap_m_s);
        // Aim at least `MIN_LOOKAHEAD_M` ahead even when the steps are short (slow speed
        // settings): the motion then stays along the artery, so the lag, still uncertain
        // early on, trails along the path instead of across it.
        let s_target = (s_now + (2.0 * travel).max(MIN_LOOKAHEAD_M)).min(self.params.max_blind_m);
        let target = filter.predict(s_target).point;
        target.is_finite().then_some((target, speed))
    }

    pub(super) fn start_sliding(&mut self, sensor: SurfacePoint, t_s: f64) {
        match self.sliding_from(sensor) {
            Some(state) => self.state = state,
            None => self.finish(EndReason::Lost, t_s),
        }
    }

    /// A fresh slide toward the model's next target from `sensor`, or `None` when the model
    /// gives no target.
    pub(super) fn sliding_from(&self, sensor: SurfacePoint) -> Option<State> {
        let (target, speed_m_s) = self.plan(sensor)?;
        Some(State::Sliding {
            from_s: None,
            len_s: self.window_len_s(),
            misses: 0,
            spans_miss: false,
            target,
            speed_m_s,
        })
    }

    /// The window after one from `from_s` to `t_s` gave no fix (`weak`: too weak, not
    /// refused for its place or timing): where the next starts, how long it is, and whether
    /// it spans the missed one. An irregular heart's beat may fall outside a one-beat window:
    /// after a weak one the next analysis spans it and one more, so that it holds a beat
    /// whatever the interval, at no extra latency in declaring the pulse lost. Only for an
    /// irregular heart: at a bend the artery leaving the array also gives weak windows, and
    /// a fix spanning two places misled the path there (the bends family completed 8 of 60
    /// fewer on the tuning seeds when every weak window was spanned).
    pub(super) fn window_after_miss(&self, from_s: f64, t_s: f64, weak: bool) -> (f64, f64, bool) {
        if weak && self.heart_irregular() {
            (from_s, t_s - from_s + self.window_len_s(), true)
        } else {
            (t_s, self.window_len_s(), false)
        }
    }

    /// Do this heart's beats come off the clock by `IRREGULAR_LATE_FRACTION` of a period?
    pub(super) fn heart_irregular(&self) -> bool {
        self.pulse
            .is_some_and(|p| p.late_rms_s >= IRREGULAR_LATE_FRACTION * p.clock.period_s())
    }

    pub(super) fn window_len_s(&self) -> f64 {
        self.beats_per_fix as f64 * self.pulse.map_or(1.0, |p| p.clock.period_s())
    }

    pub(super) fn step_sliding(&mut self, input: &TrackerInput<'_>) {
        let State::Sliding {
            from_s,
            len_s,
            misses,
            spans_miss,
            target,
            speed_m_s,
        } = self.state
        else {
            return;
        };
        let t = input.frame.t_s;
        let from = from_s.unwrap_or(t);
        self.state = State::Sliding {
            from_s: Some(from),
            len_s,
            misses,
            spans_miss,
            target,
            speed_m_s,
        };
        // Never further than `max_blind_m` beyond the last fix along the path.
        if let Some(f) = &self.filter
            && f.to_local(input.sensor).0 > self.params.max_blind_m
        {
            self.window_missed(Miss::Blind);
            self.state = State::Stopping {
                frames: 0,
                attempt: 1,
            };
            return;
        }
        if t - from + 1e-9 < len_s || !self.events.has_room_for(EVENTS_PER_ANALYSIS) {
            return;
        }
        self.read_deflection_from_load(from);
        let timed = self.analyse(from).map_err(Miss::from).and_then(|fix| {
            let point = self.accept(&fix, false)?;
            Ok((fix, point))
        });
        // A window the prior's timing could not fix: timed again on the whole array, in
        // case the artery moved on it (`analyse_window_on_array`). Such a fix steers but is
        // not reported: on the tuning draws reporting them raised the lateral SD of sinusoids
        // and bends by 0.03-0.04 mm and gave a heavy instrument a point 2.2 mm off.
        let mut steer_only = false;
        let timed = match timed {
            Err(miss @ (Miss::Weak { .. } | Miss::Timing { .. })) => {
                let needed = (ON_ARRAY_SNR_MARGIN * self.params.fix_snr)
                    .max(ON_ARRAY_USUAL_FRACTION * self.usual_snr());
                let on_array = self.second_look(from, analyse_window_on_array, needed);
                steer_only = on_array.is_ok();
                on_array.or(Err(miss))
            }
            other => other,
        };
        let timed_weak = matches!(timed, Err(Miss::Weak { .. }));
        // An irregular heart's beats timed each on its own, when one delay for the window
        // did not give a fix.
        // Such a fix steers but is not reported: its beats' timing was chosen to fit the
        // window, and on the fresh fast-irregular draws one reported so lay 2.3 mm off.
        let timed = match timed {
            Err(miss @ (Miss::Weak { .. } | Miss::Timing { .. })) if self.heart_irregular() => {
                let needed = PER_BEAT_SNR_MARGIN * self.params.fix_snr;
                let per_beat = self.second_look(from, analyse_window_beat_by_beat, needed);
                steer_only = per_beat.is_ok();
                per_beat.or(Err(miss))
            }
            other => other,
        };
        // A beat the clock could not time (irregular beats): the pulse's spatial pattern
        // without any timing, from the window's coherent part (control::classify).
        let fix = match timed {
            Err(Miss::Weak { .. } | Miss::Timing { .. }) => {
                self.untimed_fix(from).and_then(|fix| {
                    let point = self.accept(&fix, true)?;
                    Ok((fix, point))
                })
            }
            other => other,
        };
        match fix {
            Ok((fix, point)) => {
                self.after_fix(&fix, point, input.sensor, t, spans_miss, steer_only);
                return;
            }
            Err(why) => self.window_missed(why),
        }
        if misses + 1 >= self.params.sliding_misses {
            self.state = State::Stopping {
                frames: 0,
                attempt: 1,
            };
        } else {
            let (from_s, len_s, span) = self.window_after_miss(from, t, timed_weak);
            self.state = State::Sliding {
                from_s: Some(from_s),
                len_s,
                misses: misses + 1,
                spans_miss: span,
                target,
                speed_m_s,
            };
        }
    }

    /// A sliding window gave no fix: the point held from the last one is not reported (the
    /// artery may have been leaving the array while it was felt).
    pub(super) fn window_missed(&mut self, why: Miss) {
        self.last_miss = Some(why);
        self.held = None;
    }

    /// While sliding, the arm's load reads where the sensor is against the belief: along
    /// the lag's direction that is the lag itself ([`lag_read_by_load`]), and across it the
    /// rod's deflection that neither the tilt nor the lag model holds
    /// ([`felt_across_motion`]). The fixes alone hardly see the lag (moving along the artery
    /// leaves it unobserved), and its prior is one rig's: a heavy instrument on a soft
    /// incision trails by 8-11 mm against the prior's 4.5, and its sensor then slid beside
    /// the artery until it was lost. Across the motion the load puts the sensor 1 mm off the
    /// models on the seed's bench and 6-10 mm under a heavy instrument; that part is smoothed
    /// over windows (`FELT_ACROSS_WEIGHT`) and moves every fix ([`Self::accept`]).
    pub(super) fn read_deflection_from_load(&mut self, from_s: f64) {
        if self.params.load_gate_m <= 0.0 {
            return;
        }
        let window = self.history.since(from_s);
        let Some(felt) = window.mean_felt_offset() else {
            return;
        };
        let u = window.mean_lag();
        let (Some(lag), Some(across)) = (lag_read_by_load(felt, u), felt_across_motion(felt, u))
        else {
            return;
        };
        if let Some(f) = self.filter.as_mut() {
            f.measure_lag(lag, LOAD_LAG_SD_M);
        }
        let w = FELT_ACROSS_WEIGHT;
        self.felt_across = Some(match self.felt_across {
            Some(a) => [a[0] + w * (across[0] - a[0]), a[1] + w * (across[1] - a[1])],
            None => across,
        });
    }

    /// A fix from the window's coherent spatial pattern, with no timing model: the
    /// leading eigenvector of the elements' covariance (`control::classify`'s features),
    /// when the classifier calls the window an artery. Its sign is the one the kernel fits
    /// better.
    pub(super) fn untimed_fix(&mut self, from_s: f64) -> Result<BeatFix, Miss> {
        let window = self.history.since(from_s);
        let sensor = window.mean_sensor().ok_or(Miss::NoPosition)?;
        let (Some(t0), Some(t1)) = (window.first_t_s(), window.last_t_s()) else {
            return Err(Miss::NoPosition);
        };
        self.untimed.clear();
        for f in window.frames() {
            // Frames in the history are finite; a refusal only shortens the window.
            let _ = self.untimed.push(f);
        }
        let params = ClassifyParams {
            noise_sd_n: self.geometry.noise_sd_n,
            ..ClassifyParams::default()
        };
        let class = self
            .untimed
            .classify(&params, None)
            .map_err(|_| Miss::Beat(BeatMiss::Empty))?;
        if !matches!(class.kind, Kind::Artery | Kind::ArteryStenosisSuspected) {
            return Err(Miss::Untimed);
        }
        let f = class.features;
        // Each element's coherent swing has a standard error of about 2√2 σ/√n.
        let se = 2.0 * std::f64::consts::SQRT_2 * f.noise_sd_n / (f.frames.max(1) as f64).sqrt();
        let flipped = f.swing_n.map(|v| -v);
        let kernel = match (
            fit_kernel(&f.swing_n, se, &self.geometry),
            fit_kernel(&flipped, se, &self.geometry),
        ) {
            (Ok(a), Ok(b)) if b.chi2 < a.chi2 => b,
            (Ok(a), _) => a,
            (Err(_), Ok(b)) => b,
            (Err(e), Err(_)) => return Err(e.into()),
        };
        Ok(BeatFix {
            t_mid_s: 0.5 * (t0 + t1),
            late_s: 0.0,
            kernel,
            sensor,
            lag_dir: window.mean_lag(),
            felt_offset: window.mean_felt_offset(),
            noise_sd_n: f.noise_sd_n,
            aligned: Waveform::zeros(),
        })
    }

    pub(super) fn analyse(&mut self, from_s: f64) -> Result<BeatFix, BeatMiss> {
        self.analyse_span(from_s, f64::INFINITY)
    }

    /// A second look at a window the first analysis could not fix: `analyse` over the
    /// frames since `from_s`, a fix only at an SNR of `needed` (such analyses are freer, and
    /// fit noise more easily) and then as any other.
    fn second_look(
        &mut self,
        from_s: f64,
        analyse: WindowAnalysis,
        needed: f64,
    ) -> Result<(BeatFix, SurfacePoint), Miss> {
        let fix = self.analyse_with(from_s, f64::INFINITY, analyse)?;
        if fix.kernel.snr() < needed {
            return Err(Miss::Weak {
                snr: fix.kernel.snr(),
                needed,
            });
        }
        let point = self.accept(&fix, false)?;
        Ok((fix, point))
    }

    /// One fix over the frames from `from_s` up to (not including) `to_s`.
    pub(super) fn analyse_span(&mut self, from_s: f64, to_s: f64) -> Result<BeatFix, BeatMiss> {
        self.analyse_with(from_s, to_s, analyse_window)
    }

    pub(super) fn analyse_with(
        &mut self,
        from_s: f64,
        to_s: f64,
        analyse: WindowAnalysis,
    ) -> Result<BeatFix, BeatMiss> {
        let Some(pulse) = self.pulse else {
            return Err(BeatMiss::Empty);
        };
        let window = self.history.between(from_s, to_s);
        analyse(
            &window,
            pulse.clock.phase(),
            &pulse.template,
            self.spatial,
            MAX_DELAY_FRACTION,
            self.geometry.noise_sd_n,
            &self.geometry,
            &mut self.noise,
        )
    }

    /// The SNR this artery's fixes usually reach at the current beats per fix.
    pub(super) fn usual_snr(&self) -> f64 {
        self.pulse
            .map_or(0.0, |p| p.snr_per_beat * (self.beats_per_fix as f64).sqrt())
    }

    /// Is this fix the artery? A clear pulse, placed on the array, on the predicted path.
    /// Returns the artery point with the sensor's lag removed.
    pub(super) fn accept(&mut self, fix: &BeatFix, untimed: bool) -> Result<SurfacePoint, Miss> {
        let k = &fix.kernel;
        // A pulse much weaker than this artery's usual is the artery leaving the array (or
        // something else): not a fix.
        let usual = self.usual_snr();
        let needed = self.params.fix_snr.max(USUAL_SNR_FRACTION * usual);
        if k.snr().is_nan() || k.snr() < needed {
            return Err(Miss::Weak {
                snr: k.snr(),
                needed,
            });
        }
        if k.at_edge || !k.offset_se_m.is_finite() {
            return Err(Miss::AtEdge { element: k.element });
        }
        if !untimed {
            self.check_amplitude(k)?;
        }
        // A beat far off the clock, for a clock that usually keeps time, and weaker than
        // usual, is a window spoiled by something else (the artery sweeping across the
        // array, a lump). A clear beat off the clock is the heart changing its rate.
        let period = self.window_len_s() / self.beats_per_fix as f64;
        let usual_late = self.pulse.map_or(0.0, |p| p.late_rms_s);
        let late_limit = (LATE_FACTOR * usual_late)
            .max(MIN_LATE_FRACTION * period)
            .min(0.95 * MAX_DELAY_FRACTION * period);
        if fix.late_s.abs() > late_limit && k.snr() < SPOILED_SNR_FRACTION * usual {
            return Err(Miss::Timing { late_s: fix.late_s });
        }
        let own_sd = self.fix_sd(k);
        // Where the load puts the sensor across its motion, smoothed over windows: the rod's
        // deflection that neither the tilt nor the lag model holds.
        let at = match self.felt_across {
            Some(a) => SurfacePoint::new(fix.point().x_m + a[0], fix.point().z_m + a[1]),
            None => fix.point(),
        };
        let observation = Observation {
            point: at,
            sd_m: own_sd.hypot(self.tissue.sd_m()),
            lag_dir: fix.lag_dir,
        };
        let moving = self.tissue_moving();
        let filter = self.filter.as_mut().ok_or(Miss::NoModel)?;
        filter.hold_lag(moving);
        let mut updated = *filter;
        let surprise = updated.update(&observation)?;
        let nis = surprise.nis();
        // An untimed fix is used when the clock could not time the window: nothing but its
        // spatial pattern says it is this artery's pulse. When the pulse is fading (the
        // timed amplitude collapsed) the window's leading pattern need not be the pulse's:
        // in the occlusion scene one lay at the array's edge, 6.4 mm off the artery, with a
        // normalized innovation squared of 11, while those from irregular beats stay below
        // 0.3. So an untimed fix may confirm the predicted path but never surprise it.
        if untimed && nis > SURPRISE_NIS {
            return Err(Miss::UntimedSurprise { nis });
        }
        *filter = updated;
        self.tissue.push(surprise.innovation_m, own_sd.powi(2));
        let corrected = filter.corrected(&observation);
        // A surprising fix means the path turned away from the model: slow down (like the
        // seed's halving of the step); clear fixes speed up again.
        if nis > SURPRISE_NIS {
            self.speed_cap_m_s = (self.speed_cap_m_s * SURPRISE_SLOWDOWN)
                .max(MIN_TRAVEL_PER_FIX_M / self.window_len_s().max(1e-3));
        }
        Ok(corrected)
    }

    /// `steer_only`: the fix steers the track and is never reported. `spans_miss`: the fix's
    /// window also holds a missed one; it steers the track but is not reported (the sensor moved between the two, and one of them held no clear beat).
    /// An untimed fix of a regular heart steers but is not reported either: that the clock
    /// could not time its window says the window holds no beat when this heart beats, and
    /// nothing but its spatial pattern says it is this artery's pulse. Beside a pulsating
    /// lump under a weak pulse two such points lay 6-7 mm off the artery (seed-bench-mixed,
    /// fresh seeds). An irregular heart explains a window the clock could not time: there it
    /// is reported. On 150 fresh seed-bench-mixed draws (seeds 7001 and 5001) reporting
    /// every untimed fix gave 9 and 11 points more than 2 mm off, the farthest 9.9 and 8.4 mm;
    /// this rule, 5 and 6, the farthest 4.3 and 3.0 mm, for 6 % fewer points there (none,
    /// 13-16 % fewer, took no more off points away).
    pub(super) fn after_fix(
        &mut self,
        fix: &BeatFix,
        point: SurfacePoint,
        sensor: SurfacePoint,
        t_s: f64,
        spans_miss: bool,
        steer_only: bool,
    ) {
        // This window found the artery: the last one's point was felt on it.
        self.release_held();
        let fix_sd = self.fix_sd(&fix.kernel).hypot(self.tissue.sd_m());
        let sd_m = self.point_sd(fix_sd, fix.lag_dir);
        let located = self.located(fix.t_mid_s, point, fix.sensor, &fix.kernel, false, sd_m);
        self.record(point);
        // While sliding, the load's reading scatters by 0.3-1 mm (the joints' friction, the
        // servo's transients): where it disagrees with the tracker's place for the point,
        // neither is trusted, and the fix steers the track without being reported.
        let disputed = self
            .load_disagrees(fix.point(), point, fix.felt_offset)
            .is_some();
        if !self.smeared(self.window_len_s())
            && !disputed
            && !spans_miss
            && !steer_only
            && (fix.is_timed() || self.heart_irregular())
        {
            // The artery's place on the array moved from the last fix's to this one's over
            // about a window (more, after a miss: a wider margin then, on the safe side).
            let sweep = (fix.kernel.element - self.spatial.element).abs();
            self.hold(
                located,
                &fix.kernel,
                if sweep.is_finite() { sweep } else { 0.0 },
            );
        }
        self.spatial = SpatialPrior {
            element: fix.kernel.element,
            width_m: fix.kernel.width_m,
        };
        let beats = self.beats_per_fix as f64 * if spans_miss { 2.0 } else { 1.0 };
        if let Some(p) = &mut self.pulse {
            let confidence = (fix.kernel.snr() / self.params.target_snr).powi(2).min(1.0);
            p.clock.correct(fix.t_mid_s, fix.late_s, confidence);
            p.late_rms_s = (0.8 * p.late_rms_s.powi(2) + 0.2 * fix.late_s.powi(2)).sqrt();
            if fix.is_timed() {
                // Timed fixes only: an untimed one's amplitude is a swing, not a peak.
                p.amplitude_n = 0.8 * p.amplitude_n + 0.2 * fix.kernel.amplitude * p.template_pp;
            }
            let snr_beat = fix.kernel.snr() / beats.sqrt();
            p.snr_per_beat = 0.7 * p.snr_per_beat + 0.3 * snr_beat;
            let norm = fix.aligned.norm();
            if norm > 0.0 && confidence >= 1.0 {
                let learned =
                    p.template * (1.0 - TEMPLATE_RATE) + fix.aligned / norm * TEMPLATE_RATE;
                let n = learned.norm();
                if n > 0.0 {
                    p.template = learned / n;
                    p.template_pp = peak_to_peak(&p.template);
                }
            }
        }
        self.report_period(t_s);
        self.choose_beats_per_fix();
        self.speed_cap_m_s = (self.speed_cap_m_s * SPEED_RECOVERY).min(self.params.max_speed_m_s);
        if self.length_reached() {
            self.finish(EndReason::LengthReached, t_s);
            return;
        }
        self.start_sliding(sensor, t_s);
        if let State::Sliding { from_s, .. } = &mut self.state {
            *from_s = Some(t_s);
        }
    }
}

/// The lag a window's mean felt offset (where the load put the sensor less where it was
/// believed) gives along the window's mean lag direction `u`: the sensor sits at the belief
/// less `lag·u`. `None` unless `u` was steady over the window (the mean of its unit
/// directions at least `LOAD_LAG_MIN_DIRECTION` long): while it swings round, the deflection
/// is not yet a lag along it.
pub(super) fn lag_read_by_load(felt: [f64; 2], u: [f64; 2]) -> Option<f64> {
    let n2 = u[0] * u[0] + u[1] * u[1];
    let lag = -(felt[0] * u[0] + felt[1] * u[1]) / n2;
    (n2 >= LOAD_LAG_MIN_DIRECTION.powi(2) && lag.is_finite()).then_some(lag)
}

/// The part of a window's mean felt offset across its mean lag direction `u` (what the lag
/// does not explain); `None` under the same condition as [`lag_read_by_load`].
pub(super) fn felt_across_motion(felt: [f64; 2], u: [f64; 2]) -> Option<[f64; 2]> {
    let along = -lag_read_by_load(felt, u)?;
    Some([felt[0] - along * u[0], felt[1] - along * u[1]])
}
