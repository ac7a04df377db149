//! A window at rest, beat by beat: did the artery move under the still sensor?
//!
//! A mark or a search at rest localizes over its whole window (4 s or more): where the
//! artery lay on average. Under breathing the tissue moves 1-4 mm across the course at
//! 0.2-0.3 Hz, a cycle per window, so that average is where the artery lay at no moment in
//! particular: first seed points were 2-3.4 mm from where the artery was at the window's
//! middle (16 of the breathing family's 48 points more than 2 mm off, tuning seeds). So the
//! window is also localized beat by beat with the pulse it just taught; if the beats'
//! places differ by more than their noise explains, the artery moved, and the point
//! reported is the median of the last three beats' places, at that beat's time (a single
//! beat spoiled by an irregular heart, its pulse cut by the window's edge, is then not the
//! one reported: reporting the last beat put 2 of 240 still marks 1.3-2.3 mm off on the
//! irregular-heart families). The whole window still steers: the mean course is what the
//! path model follows.
//!
//! The test is a chi-square of the beats' places about their weighted mean, at a false
//! alarm of `MOTION_FALSE_ALARM` on a still artery. A weak pulse gives one-beat places
//! too noisy to show motion: then the window is reported as before, and it can only be
//! caught later (`smeared`, once sliding fixes have measured the motion). Dropping the
//! beat farthest from the median before the test made it blind on four-second windows of
//! three or four beats (breathing's seed points 0.39 -> 1.07 mm RMS).

use super::*;
use crate::signal::detection_bound::chi2_quantile;

/// Beats localized at most (the window's last ones).
const MAX_BEATS: usize = 8;
/// Fewest beats for the test.
const MIN_BEATS: usize = 3;
/// False alarm of the test on a still artery.
const MOTION_FALSE_ALARM: f64 = 1e-3;
/// A one-beat place's error beyond its noise (the kernel's shape, the harmonic fit), m:
/// the test asks for motion beyond it.
const BEAT_FLOOR_M: f64 = 1.5e-4;

/// What the beats of a window at rest say.
#[derive(Debug, Clone, Copy, PartialEq)]
enum RestBeats {
    /// Still, or too few or too noisy beats to tell: the window's place stands.
    Still,
    /// The artery moved: the fix to report (the median of the last three beats), if they
    /// gave one on the array at this artery's amplitude.
    Moved(Option<BeatFix>),
}

impl BeatSlide {
    /// Localize the last beats of the window at rest from `since` to `t` (the pulse must
    /// have been learned) and test them for motion.
    fn rest_beats(&mut self, since: f64, t: f64) -> RestBeats {
        let Some(pulse) = self.pulse else {
            return RestBeats::Still;
        };
        let period = pulse.clock.period_s();
        // Newest first, with each one's place `(z, se)`; a beat that gave no fix on the
        // array is left out.
        let mut fixes = [None; MAX_BEATS];
        let mut places = [(0.0, 0.0); MAX_BEATS];
        let mut n = 0;
        let mut off_array = false;
        let last = (crate::types::ELEMENTS - 1) as f64;
        for k in 0..MAX_BEATS {
            let (from, to) = (t - (k + 1) as f64 * period, t - k as f64 * period + 1e-9);
            if from < since {
                break;
            }
            let Ok(fix) = self.analyse_span(from, to) else {
                continue;
            };
            // An artery beyond the array's end shows as its flank: a beat within
            // `FLANK_ELEMENTS` of the end (as for a sliding fix's report), here at less than
            // half this artery's usual SNR. (On a draw breathing 3.9 mm at 0.28 Hz the
            // artery lay 1-3 mm beyond the end for half a window; its beats were fitted at
            // elements 8.4-8.9 at a quarter to half the usual SNR, and the window's place
            // was reported 5.3 mm off.)
            let e = fix.kernel.element;
            let flank = e.min(last - e) < FLANK_ELEMENTS
                && fix.kernel.snr() < USUAL_SNR_FRACTION * pulse.snr_per_beat;
            if fix.kernel.at_edge || !(0.0..=last).contains(&e) || flank {
                off_array = true;
            } else if fix.kernel.offset_se_m.is_finite() {
                fixes[n] = Some(fix);
                places[n] = (fix.point().z_m, fix.kernel.offset_se_m.hypot(BEAT_FLOOR_M));
                n += 1;
            }
        }
        // A beat that put the artery beyond the outer elements: it was not on the array
        // for the whole window, and no beat's place can be trusted near that end.
        if off_array {
            return RestBeats::Moved(None);
        }
        if !moved(&places[..n]) {
            return RestBeats::Still;
        }
        // The median of the last three beats' places: one beat spoiled by an irregular
        // heart (its pulse cut by the window's edge) is not the one reported.
        let (Some(a), Some(b), Some(c)) = (fixes[0], fixes[1], fixes[2]) else {
            return RestBeats::Moved(None);
        };
        let mut last = [a, b, c];
        last.sort_by(|a, b| a.point().z_m.total_cmp(&b.point().z_m));
        let median = last[1];
        RestBeats::Moved(self.check_amplitude(&median.kernel).ok().map(|()| median))
    }

    /// A point found at rest over a window, `located` (its fix `window_fit`, placed from
    /// `window_raw`), as the beats say it should be reported: unchanged when still, moved
    /// to the reported beat's place and time (the window's lag and placement kept, its fix's
    /// SD swapped for the beat's) when the artery moved, none when no beat can say.
    pub(super) fn at_rest_reported(
        &mut self,
        since: f64,
        t: f64,
        located: LocatedPoint,
        window_fit: &KernelFit,
        window_raw: SurfacePoint,
    ) -> Option<LocatedPoint> {
        match self.rest_beats(since, t) {
            RestBeats::Still => Some(located),
            RestBeats::Moved(None) => None,
            RestBeats::Moved(Some(beat)) => {
                let shift = beat.point().z_m - window_raw.z_m;
                let (window_sd, beat_sd) = (self.fix_sd(window_fit), self.fix_sd(&beat.kernel));
                let sd_m = located.sd_m.unwrap_or(window_sd);
                let sd_m = (sd_m * sd_m - window_sd * window_sd + beat_sd * beat_sd)
                    .max(beat_sd * beat_sd)
                    .sqrt();
                Some(LocatedPoint {
                    t_s: beat.t_mid_s,
                    point: SurfacePoint::new(located.point.x_m, located.point.z_m + shift),
                    element: beat.kernel.element,
                    amplitude_n: self.amplitude_n(&beat.kernel),
                    sd_m: Some(sd_m),
                    ..located
                })
            }
        }
    }
}

/// Do places `(z, se)` differ by more than their SEs explain?
fn moved(places: &[(f64, f64)]) -> bool {
    if places.len() < MIN_BEATS {
        return false;
    }
    let (sw, swz) = places.iter().fold((0.0, 0.0), |(sw, swz), &(z, se)| {
        (sw + 1.0 / (se * se), swz + z / (se * se))
    });
    let mean = swz / sw;
    let chi2: f64 = places
        .iter()
        .map(|&(z, se)| ((z - mean) / se).powi(2))
        .sum();
    chi2 > chi2_quantile(1.0 - MOTION_FALSE_ALARM, (places.len() - 1) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::harmonic::PulsePhase;
    use crate::signal::kernel_fit::element_kernel;
    use crate::tracker::beatslide::beat_fix::SpatialPrior;
    use crate::types::{ELEMENTS, TactileFrame};

    /// A still tracker that has learned a 1 Hz pulse (a pure cosine) of 0.05 N with the
    /// window's place at the median of `centres` (as the window's fit would put it), and has
    /// felt one beat per entry of `centres` at rest, the artery under that (fractional)
    /// element in that beat; a little deterministic noise on every element.
    fn at_rest(centres: &[f64]) -> BeatSlide {
        let geometry = ArrayGeometry::default();
        let mut t = BeatSlide::new(BeatSlideParams::default(), geometry).expect("defaults");
        let mut template = Waveform::zeros();
        template[0] = 1.0;
        t.pulse = Some(Pulse {
            clock: BeatClock::new(
                PulsePhase {
                    t_ref_s: 0.0,
                    period_s: 1.0,
                },
                BeatClockSettings::default(),
            ),
            template,
            template_pp: peak_to_peak(&template),
            snr_per_beat: 10.0,
            late_rms_s: 0.05,
            amplitude_n: 0.05,
            reported_period_s: 1.0,
        });
        let mut sorted = centres.to_vec();
        sorted.sort_by(f64::total_cmp);
        t.spatial = SpatialPrior {
            element: sorted[sorted.len() / 2].clamp(0.0, (ELEMENTS - 1) as f64),
            width_m: 0.005,
        };
        let (pitch, fs) = (geometry.pitch_m, geometry.sample_rate_hz);
        let mut noise = test_noise(12345, 0.004);
        let per_beat = fs.round() as usize;
        for (b, &c) in centres.iter().enumerate() {
            for i in 0..per_beat {
                let seq = (b * per_beat + i) as u64;
                let t_s = seq as f64 / fs;
                let pulse = 0.05 * (std::f64::consts::TAU * t_s).cos();
                let force_n: [f64; ELEMENTS] = std::array::from_fn(|e| {
                    0.4 + pulse * element_kernel((e as f64 - c) * pitch, 0.005, pitch) + noise()
                });
                let frame = TactileFrame { t_s, seq, force_n };
                t.history
                    .push(frame, SurfacePoint::new(0.0, 0.0), [0.0, 0.0], None);
            }
        }
        t
    }

    fn beats_say(centres: &[f64]) -> RestBeats {
        let mut t = at_rest(centres);
        let end = centres.len() as f64 - 0.005;
        t.rest_beats(0.0, end)
    }

    #[test]
    fn a_beat_beyond_the_arrays_end_leaves_the_window_no_place() {
        // Held still on the array, and still near its end: the window's place stands.
        assert_eq!(beats_say(&[4.2; 6]), RestBeats::Still);
        assert_eq!(beats_say(&[8.6; 6]), RestBeats::Still);
        // Swept along the array: the median of the last three beats.
        match beats_say(&[3.0, 4.0, 5.0, 6.0, 7.0, 8.0]) {
            RestBeats::Moved(Some(fix)) => assert!(
                (fix.kernel.element - 7.0).abs() < 0.3,
                "the middle of the last three beats, got element {:.2}",
                fix.kernel.element
            ),
            other => panic!("a sweep is motion: {other:?}"),
        }
        // Near the end, with one beat beyond it: the beats on the array are flanks of an
        // artery that was not held there.
        assert_eq!(
            beats_say(&[8.6, 8.7, 11.5, 8.8, 8.7, 8.6]),
            RestBeats::Moved(None)
        );
        assert_eq!(
            beats_say(&[0.4, 0.3, -2.5, 0.2, 0.3, 0.4]),
            RestBeats::Moved(None)
        );
    }

    /// A still window whose beats are `fraction` of this artery's usual one-beat SNR.
    fn beats_at_fraction_of_usual(centres: &[f64], fraction: f64) -> RestBeats {
        let mut t = at_rest(centres);
        let end = centres.len() as f64 - 0.005;
        let beat = t.analyse_span(end - 1.0, end).expect("a beat");
        assert!(
            !beat.kernel.at_edge,
            "fitted at the edge: {:?}",
            beat.kernel
        );
        if let Some(p) = t.pulse.as_mut() {
            p.snr_per_beat = beat.kernel.snr() / fraction;
        }
        t.rest_beats(0.0, end)
    }

    #[test]
    fn weak_beats_near_the_end_are_the_flank_of_an_artery_beyond_it() {
        // Held still near the end, at 0.4 of the artery's usual SNR: the flank of an artery
        // beyond the end, no place on the array.
        assert_eq!(
            beats_at_fraction_of_usual(&[8.7; 6], 0.4),
            RestBeats::Moved(None)
        );
        assert_eq!(
            beats_at_fraction_of_usual(&[0.3; 6], 0.4),
            RestBeats::Moved(None)
        );
        // As clear as usual near the end, or as weak in the middle: the window's place stands.
        assert_eq!(beats_at_fraction_of_usual(&[8.7; 6], 0.7), RestBeats::Still);
        assert_eq!(beats_at_fraction_of_usual(&[4.5; 6], 0.4), RestBeats::Still);
    }

    #[test]
    fn places_within_their_noise_are_still_and_a_swing_is_motion() {
        let se = 2e-4;
        let at = |d: &[f64], step: f64, se: f64| -> Vec<(f64, f64)> {
            d.iter().map(|d| (0.01 + d * step, se)).collect()
        };
        assert!(!moved(&at(&[0.1, -0.2, 0.15, -0.05, 0.0], se, se)));
        // A 2 mm swing across five beats, at 0.2 mm SE each, and across three.
        let swing = at(&[-1.0, -0.5, 0.0, 0.5, 1.0], 1e-3, se);
        assert!(moved(&swing));
        assert!(moved(&at(&[0.0, 1.0, 2.0], 1e-3, se)));
        // The same swing at 2 mm SE each is not shown.
        assert!(!moved(&at(&[-1.0, -0.5, 0.0, 0.5, 1.0], 1e-3, 2e-3)));
        // Two beats cannot tell.
        assert!(!moved(&swing[..2]));
    }
}
