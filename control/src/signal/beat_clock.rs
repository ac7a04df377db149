//! Following the heart: the pulse's phase and period, corrected once per beat by how late
//! the beat arrived.
//!
//! A lock-in over one beat needs the beat's phase. A fixed period would drift off a real
//! heart within a few beats (a 5 % rate error is half a cycle after ten beats), so each
//! analysed beat reports how late it came against the prediction and the clock corrects
//! both phase and period, an alpha–beta (second-order phase-locked) loop:
//! `t_ref += α·late`, `period += β·late`, each weighted by the caller's confidence in that
//! beat. With the defaults `α = 0.5`, `β = 0.12` the loop is close to critically damped; a
//! period that changes by `δ` per beat is followed `δ/β` late (a heart going from 60 to 90
//! beats per minute over 40 beats: about 0.07 s), and irregular beats perturb it by `α`
//! times their own jitter.
//!
//! The loop alone can walk: beats that keep coming late (an irregular heart, a premature
//! beat and its compensatory pause, a window timed on the wrong beat) lengthen the period a
//! little each time, and nothing pulls it back, up to twice the heart's period, where every
//! other beat fits again. So the period stays within `max_drift_fraction` of the last
//! period measured at rest (the anchor, from [`BeatClock::new`] or [`BeatClock::reset`]),
//! and a lateness beyond `max_late_fraction` of a period is taken as that bound: a beat one
//! period early or late is the neighbouring beat, not a phase error.

use super::harmonic::PulsePhase;

/// Gains and bounds of the clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeatClockSettings {
    /// Fraction of a measured lateness applied to the phase (0 to 1).
    pub phase_gain: f64,
    /// Fraction of a measured lateness applied to the period (0 to 0.5).
    pub rate_gain: f64,
    pub min_period_s: f64,
    pub max_period_s: f64,
    /// The period stays within `anchor / (1 + f)` to `anchor · (1 + f)` of the last period
    /// measured at rest; below 1 so that neither half nor double the rate is reachable.
    pub max_drift_fraction: f64,
    /// The most lateness, in periods, one beat may apply (0 to 0.5).
    pub max_late_fraction: f64,
}

impl Default for BeatClockSettings {
    fn default() -> Self {
        Self {
            phase_gain: 0.5,
            rate_gain: 0.12,
            min_period_s: 0.45,
            max_period_s: 2.2,
            max_drift_fraction: 0.55,
            max_late_fraction: 0.5,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeatClock {
    phase: PulsePhase,
    settings: BeatClockSettings,
    /// The last period measured at rest, s.
    anchor_s: f64,
}

impl BeatClock {
    /// A clock started from a measured phase (its period clamped into the bounds).
    pub fn new(phase: PulsePhase, settings: BeatClockSettings) -> Self {
        let mut clock = Self {
            phase,
            settings,
            anchor_s: f64::NAN,
        };
        clock.phase.period_s = clock.clamp(phase.period_s);
        clock.anchor_s = clock.phase.period_s;
        clock
    }

    pub fn phase(&self) -> PulsePhase {
        self.phase
    }

    pub fn period_s(&self) -> f64 {
        self.phase.period_s
    }

    /// The last period measured at rest, s.
    pub fn anchor_s(&self) -> f64 {
        self.anchor_s
    }

    fn clamp(&self, period_s: f64) -> f64 {
        if !period_s.is_finite() {
            return self.phase.period_s;
        }
        let (mut lo, mut hi) = (self.settings.min_period_s, self.settings.max_period_s);
        let drift = 1.0 + self.settings.max_drift_fraction.max(0.0);
        if self.anchor_s.is_finite() && drift.is_finite() {
            lo = lo.max(self.anchor_s / drift);
            hi = hi.min(self.anchor_s * drift);
        }
        period_s.clamp(lo.min(hi), hi)
    }

    /// The beat around `t_s` came `late_s` later than predicted; `weight` (0 to 1) is the
    /// confidence in that measurement. Non-finite input is ignored.
    pub fn correct(&mut self, t_s: f64, late_s: f64, weight: f64) {
        if !(t_s.is_finite() && late_s.is_finite() && weight.is_finite()) {
            return;
        }
        let w = weight.clamp(0.0, 1.0);
        let p = self.phase.period_s;
        // Anchor the phase at the beat measured, so that a new period turns the phase about
        // now rather than about some distant reference.
        self.phase.t_ref_s += ((t_s - self.phase.t_ref_s) / p).round() * p;
        // A lateness beyond half a period is indistinguishable from an earliness, and one
        // beyond the bound is a beat that did not belong where it was timed.
        let bound = self.settings.max_late_fraction.clamp(0.0, 0.5) * p;
        let late = late_s.clamp(-bound, bound);
        self.phase.t_ref_s += self.settings.phase_gain * w * late;
        self.phase.period_s = self.clamp(p + self.settings.rate_gain * w * late);
    }

    /// Replace the phase and period (a new measurement at rest).
    pub fn reset(&mut self, phase: PulsePhase) {
        if phase.period_s.is_finite() && phase.t_ref_s.is_finite() {
            // A new anchor: the bounds of the measurement alone apply to it.
            self.anchor_s = f64::NAN;
            let period_s = self.clamp(phase.period_s);
            self.anchor_s = period_s;
            self.phase = PulsePhase {
                t_ref_s: phase.t_ref_s,
                period_s,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Run the clock against true beat times: at each true beat, measure the lateness of
    /// the nearest predicted peak.
    fn follow(clock: &mut BeatClock, beats: &[f64]) -> Vec<f64> {
        beats
            .iter()
            .map(|&t| {
                let ph = clock.phase();
                let k = ((t - ph.t_ref_s) / ph.period_s).round();
                let predicted = ph.t_ref_s + k * ph.period_s;
                let late = t - predicted;
                clock.correct(t, late, 1.0);
                late
            })
            .collect()
    }

    #[test]
    fn locks_onto_a_steady_rate_from_a_wrong_start() {
        let mut clock = BeatClock::new(
            PulsePhase {
                t_ref_s: 0.15,
                period_s: 0.93,
            },
            BeatClockSettings::default(),
        );
        let beats: Vec<f64> = (0..40).map(|k| 0.1 + f64::from(k) * 0.83).collect();
        let late = follow(&mut clock, &beats);
        assert!(late[..3].iter().any(|l| l.abs() > 0.05), "{late:?}");
        assert!(late[30..].iter().all(|l| l.abs() < 0.002), "{late:?}");
        assert!((clock.period_s() - 0.83).abs() < 1e-3);
    }

    #[test]
    fn follows_a_changing_heart_rate() {
        // 60 to 90 beats per minute over 40 beats, then steady.
        let mut t = 0.0;
        let mut beats = Vec::new();
        for k in 0..80 {
            let rate_hz = 1.0 + 0.5 * (f64::from(k) / 40.0).min(1.0);
            t += 1.0 / rate_hz;
            beats.push(t);
        }
        let mut clock = BeatClock::new(
            PulsePhase {
                t_ref_s: 0.0,
                period_s: 1.0,
            },
            BeatClockSettings::default(),
        );
        let late = follow(&mut clock, &beats);
        // During the ramp the lag stays a small fraction of a beat; afterwards it vanishes.
        assert!(late.iter().all(|l| l.abs() < 0.1), "{late:?}");
        assert!(late[70..].iter().all(|l| l.abs() < 0.01), "{late:?}");
        assert!((clock.period_s() - 1.0 / 1.5).abs() < 0.01);
    }

    #[test]
    fn ignores_zero_weight_and_bad_numbers_and_keeps_bounds() {
        let start = PulsePhase {
            t_ref_s: 0.0,
            period_s: 1.0,
        };
        let mut clock = BeatClock::new(start, BeatClockSettings::default());
        clock.correct(5.0, 0.2, 0.0);
        assert_eq!(clock.period_s(), 1.0);
        clock.correct(f64::NAN, 0.2, 1.0);
        clock.correct(5.0, f64::INFINITY, 1.0);
        assert_eq!(clock.period_s(), 1.0);
        for k in 0..200 {
            clock.correct(f64::from(k), 0.5, 1.0);
        }
        assert!(clock.period_s() <= 2.2);
        let fast = BeatClock::new(
            PulsePhase {
                t_ref_s: 0.0,
                period_s: 0.1,
            },
            BeatClockSettings::default(),
        );
        assert_eq!(fast.period_s(), 0.45);
    }

    /// Beat times of a heart of period `t` whose intervals vary by `sd` (deterministic
    /// pseudo-normal from a xorshift), with a premature beat (35 % early, then a 35 %
    /// longer pause) every `ectopic_every` beats.
    fn irregular_beats(t: f64, sd: f64, ectopic_every: usize, n: usize, seed: u64) -> Vec<f64> {
        let mut state = seed.max(1);
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut time = 0.0;
        let mut pause = false;
        (0..n)
            .map(|k| {
                let normal = (-2.0 * uniform().max(1e-300).ln()).sqrt()
                    * (std::f64::consts::TAU * uniform()).cos();
                let interval = if pause {
                    pause = false;
                    1.35 * t
                } else if ectopic_every > 0 && k % ectopic_every == ectopic_every - 1 {
                    pause = true;
                    0.65 * t
                } else {
                    (t + sd * normal).clamp(0.6 * t, 1.4 * t)
                };
                time += interval;
                time
            })
            .collect()
    }

    /// As the tracker does: the beat timed is the one nearest the prediction, searched
    /// only within a quarter period (`analyse_window`'s delay range).
    fn follow_within_quarter(clock: &mut BeatClock, beats: &[f64]) {
        for &t in beats {
            let ph = clock.phase();
            let k = ((t - ph.t_ref_s) / ph.period_s).round();
            let late =
                (t - (ph.t_ref_s + k * ph.period_s)).clamp(-0.25 * ph.period_s, 0.25 * ph.period_s);
            clock.correct(t, late, 1.0);
        }
    }

    #[test]
    fn a_fast_irregular_heart_never_walks_to_half_or_double_rate() {
        // 1.6 Hz, interval SD 0.12 s, a premature beat every 7th: the period stays near
        // 0.625 s however the beats fall, and a clock started at twice the period (a
        // wrong search at rest) is never pulled to anything but its bounds.
        for seed in 1..40u64 {
            let beats = irregular_beats(0.625, 0.12, 7, 300, seed);
            let mut clock = BeatClock::new(
                PulsePhase {
                    t_ref_s: beats[0],
                    period_s: 0.625,
                },
                BeatClockSettings::default(),
            );
            let mut worst: f64 = 0.0;
            for chunk in beats.chunks(10) {
                follow_within_quarter(&mut clock, chunk);
                worst = worst.max((clock.period_s() / 0.625 - 1.0).abs());
            }
            assert!(
                worst < 0.55,
                "seed {seed}: period left the band ({worst:.2})"
            );
            assert!(
                clock.period_s() < 1.55 * 0.625 && clock.period_s() > 0.625 / 1.55,
                "seed {seed}: {}",
                clock.period_s()
            );
        }
    }

    #[test]
    fn the_period_stays_within_its_anchor_band_and_reset_moves_the_band() {
        let mut clock = BeatClock::new(
            PulsePhase {
                t_ref_s: 0.0,
                period_s: 1.0,
            },
            BeatClockSettings::default(),
        );
        // Beats always a quarter period late would lengthen the period without end.
        for k in 0..500 {
            clock.correct(f64::from(k), 0.25 * clock.period_s(), 1.0);
        }
        assert!(
            (clock.period_s() - 1.55).abs() < 1e-9,
            "{}",
            clock.period_s()
        );
        for k in 0..500 {
            clock.correct(f64::from(k), -0.25 * clock.period_s(), 1.0);
        }
        assert!((clock.period_s() - 1.0 / 1.55).abs() < 1e-9);
        // A new measurement at rest moves the anchor.
        clock.reset(PulsePhase {
            t_ref_s: 0.0,
            period_s: 1.2,
        });
        assert_eq!(clock.period_s(), 1.2);
        assert_eq!(clock.anchor_s(), 1.2);
        // A beat one whole period late is not a phase error beyond the bound.
        let bounded = BeatClockSettings {
            max_late_fraction: 0.2,
            ..BeatClockSettings::default()
        };
        let mut clock = BeatClock::new(
            PulsePhase {
                t_ref_s: 0.0,
                period_s: 1.0,
            },
            bounded,
        );
        clock.correct(10.0, 1.0, 1.0);
        assert!((clock.period_s() - 1.0).abs() <= 0.12 * 0.2 + 1e-12);
    }
}
