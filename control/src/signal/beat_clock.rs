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
}

impl Default for BeatClockSettings {
    fn default() -> Self {
        Self {
            phase_gain: 0.5,
            rate_gain: 0.12,
            min_period_s: 0.45,
            max_period_s: 2.2,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeatClock {
    phase: PulsePhase,
    settings: BeatClockSettings,
}

impl BeatClock {
    /// A clock started from a measured phase (its period clamped into the bounds).
    pub fn new(phase: PulsePhase, settings: BeatClockSettings) -> Self {
        let mut clock = Self { phase, settings };
        clock.phase.period_s = clock.clamp(phase.period_s);
        clock
    }

    pub fn phase(&self) -> PulsePhase {
        self.phase
    }

    pub fn period_s(&self) -> f64 {
        self.phase.period_s
    }

    fn clamp(&self, period_s: f64) -> f64 {
        if period_s.is_finite() {
            period_s.clamp(self.settings.min_period_s, self.settings.max_period_s)
        } else {
            self.phase.period_s
        }
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
        // A lateness beyond half a period is indistinguishable from an earliness.
        let late = late_s.clamp(-0.5 * p, 0.5 * p);
        self.phase.t_ref_s += self.settings.phase_gain * w * late;
        self.phase.period_s = self.clamp(p + self.settings.rate_gain * w * late);
    }

    /// Replace the phase and period (a new measurement at rest).
    pub fn reset(&mut self, phase: PulsePhase) {
        if phase.period_s.is_finite() && phase.t_ref_s.is_finite() {
            self.phase = PulsePhase {
                t_ref_s: phase.t_ref_s,
                period_s: self.clamp(phase.period_s),
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
}
