//! The lumen pressure over time: the seed's solenoid square wave, a physiological pulse with
//! beat-to-beat variability, or none.
//!
//! Only the pulsatile part drives the surface kernel: the diastolic (or vented) pressure is
//! carried by the tube wall and the tissue's prestress and appears as a constant that the
//! trackers' band-pass removes, so [`PulseSource::pressure_pa`] returns pressure above
//! diastole.

use rand::rngs::ChaCha8Rng;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::random::standard_normal;

/// A scene's pressure waveform.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum PulseSpec {
    /// The seed's bench: a latex tube inflated to `pressure_pa` and vented to the atmosphere
    /// through a solenoid valve every `period_s`, open for `duty` of each period. Inflation
    /// and venting are first-order with `time_constant_s` (tube compliance through the
    /// valve's orifice).
    Solenoid {
        pressure_pa: f64,
        period_s: f64,
        #[serde(default = "half")]
        duty: f64,
        #[serde(default = "valve_tau")]
        time_constant_s: f64,
    },
    /// A physiological arterial pulse: `diastolic_pa` to `systolic_pa`, mean heart rate
    /// `heart_rate_hz`, beat-to-beat variability as the SD of the beat interval
    /// (`interval_sd_s`) and of the pulse pressure (`pressure_sd_fraction`), optionally a
    /// change of the mean rate during the trial (`rate_change`) and premature (ectopic)
    /// beats (`ectopic`).
    Physiological {
        systolic_pa: f64,
        diastolic_pa: f64,
        heart_rate_hz: f64,
        #[serde(default)]
        interval_sd_s: f64,
        #[serde(default)]
        pressure_sd_fraction: f64,
        #[serde(default)]
        rate_change: Option<RateChange>,
        #[serde(default)]
        ectopic: Option<Ectopic>,
    },
    /// No pulse at all (a hard case: the tracker must end cleanly).
    Absent,
}

/// The mean heart rate goes linearly from the pulse's `heart_rate_hz` to `to_hz` between
/// `start_s` and `start_s + duration_s` of simulated time (from the trial's start), and
/// stays there.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RateChange {
    pub to_hz: f64,
    pub start_s: f64,
    pub duration_s: f64,
}

impl RateChange {
    /// The mean rate at `t_s` for a pulse whose rate is `from_hz` before the change.
    pub fn rate_hz(&self, from_hz: f64, t_s: f64) -> f64 {
        let w = if self.duration_s > 0.0 {
            ((t_s - self.start_s) / self.duration_s).clamp(0.0, 1.0)
        } else if t_s >= self.start_s {
            1.0
        } else {
            0.0
        };
        from_hz + (self.to_hz - from_hz) * w
    }
}

/// Premature (ectopic) beats: each beat is followed early, with `probability`, by a weak
/// premature beat and then a compensatory pause. The beat before it is cut short to
/// `1 − prematurity` of the mean interval (its contour compressed in time), the premature
/// beat has `pressure_fraction` of the pulse pressure and lasts `1 + prematurity` mean
/// intervals, so the pair spans two normal intervals (a full compensatory pause).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ectopic {
    pub probability: f64,
    #[serde(default = "ectopic_prematurity")]
    pub prematurity: f64,
    #[serde(default = "ectopic_pressure")]
    pub pressure_fraction: f64,
}

fn ectopic_prematurity() -> f64 {
    0.35
}

fn ectopic_pressure() -> f64 {
    0.5
}

fn half() -> f64 {
    0.5
}

fn valve_tau() -> f64 {
    0.03
}

/// One beat: when it starts, how long it lasts and its pulse pressure.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Beat {
    start_s: f64,
    period_s: f64,
    amplitude_pa: f64,
}

/// Generates the pulsatile pressure deterministically from a seed. Query times must not go
/// backwards by more than one beat (the simulation only moves forward).
#[derive(Debug)]
pub struct PulseSource {
    spec: PulseSpec,
    rng: ChaCha8Rng,
    previous: Beat,
    current: Beat,
    beats_started: u64,
    /// The next beat is the premature one (the current one was cut short for it).
    premature_next: bool,
}

impl PulseSource {
    pub fn new(spec: &PulseSpec, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut premature_next = false;
        let first = Self::draw(spec, &mut rng, 0.0, &mut premature_next);
        Self {
            spec: spec.clone(),
            rng,
            previous: first,
            current: first,
            beats_started: 1,
            premature_next,
        }
    }

    /// The beat starting at `start_s`. Ectopic draws happen only when the scene names
    /// ectopic beats, so every other pulse draws the same stream as before they existed.
    fn draw(
        spec: &PulseSpec,
        rng: &mut ChaCha8Rng,
        start_s: f64,
        premature_next: &mut bool,
    ) -> Beat {
        match *spec {
            PulseSpec::Solenoid {
                pressure_pa,
                period_s,
                ..
            } => Beat {
                start_s,
                period_s,
                amplitude_pa: pressure_pa,
            },
            PulseSpec::Physiological {
                systolic_pa,
                diastolic_pa,
                heart_rate_hz,
                interval_sd_s,
                pressure_sd_fraction,
                rate_change,
                ectopic,
            } => {
                let rate = rate_change.map_or(heart_rate_hz, |c| c.rate_hz(heart_rate_hz, start_s));
                let mean = 1.0 / rate;
                // Keep intervals physiological: within ±40 % of the mean.
                let mut period =
                    (mean + interval_sd_s * standard_normal(rng)).clamp(0.6 * mean, 1.4 * mean);
                let mut amp = (systolic_pa - diastolic_pa)
                    * (1.0 + pressure_sd_fraction * standard_normal(rng)).clamp(0.5, 1.5);
                if let Some(e) = ectopic {
                    if *premature_next {
                        *premature_next = false;
                        period = (1.0 + e.prematurity) * mean;
                        amp *= e.pressure_fraction;
                    } else if crate::random::uniform_open(rng) < e.probability {
                        *premature_next = true;
                        period = (1.0 - e.prematurity) * mean;
                    }
                }
                Beat {
                    start_s,
                    period_s: period,
                    amplitude_pa: amp,
                }
            }
            PulseSpec::Absent => {
                // Draw nothing; a notional 1 s "beat" keeps the bookkeeping uniform.
                let _ = rng.next_u64();
                Beat {
                    start_s,
                    period_s: 1.0,
                    amplitude_pa: 0.0,
                }
            }
        }
    }

    fn advance_to(&mut self, t_s: f64) {
        while t_s >= self.current.start_s + self.current.period_s {
            let next_start = self.current.start_s + self.current.period_s;
            self.previous = self.current;
            self.current = Self::draw(
                &self.spec,
                &mut self.rng,
                next_start,
                &mut self.premature_next,
            );
            self.beats_started += 1;
        }
    }

    /// Pulsatile lumen pressure (above diastole / atmosphere) at `t_s`, Pa.
    pub fn pressure_pa(&mut self, t_s: f64) -> f64 {
        if t_s < 0.0 {
            return 0.0;
        }
        self.advance_to(t_s);
        match self.spec {
            PulseSpec::Absent => 0.0,
            PulseSpec::Solenoid {
                duty,
                time_constant_s,
                ..
            } => {
                // The first-order tube pressure at the start of a beat carries over from the
                // end of the previous one; with a time constant much shorter than a period it
                // is near zero, and computing it in closed form keeps queries order-free.
                let beat = self.current;
                let open = duty * beat.period_s;
                let tau = time_constant_s.max(1e-6);
                let carry = {
                    let prev = self.previous;
                    let prev_open = duty * prev.period_s;
                    let at_close = prev.amplitude_pa * (1.0 - (-prev_open / tau).exp());
                    at_close * (-(prev.period_s - prev_open) / tau).exp()
                };
                let tb = t_s - beat.start_s;
                if tb < open {
                    beat.amplitude_pa + (carry - beat.amplitude_pa) * (-tb / tau).exp()
                } else {
                    let at_close =
                        beat.amplitude_pa + (carry - beat.amplitude_pa) * (-open / tau).exp();
                    at_close * (-(tb - open) / tau).exp()
                }
            }
            PulseSpec::Physiological { .. } => {
                let beat = self.current;
                let phase = (t_s - beat.start_s) / beat.period_s;
                beat.amplitude_pa * physiological_shape(phase)
            }
        }
    }

    /// Beats that have started at or before `t_s` (the first at t = 0). Counting beats in an
    /// interval is the difference of two calls.
    pub fn beats_started_by(&mut self, t_s: f64) -> u64 {
        if t_s < 0.0 {
            return 0;
        }
        self.advance_to(t_s);
        self.beats_started
    }

    /// True if the scene has any pulse.
    pub fn is_absent(&self) -> bool {
        matches!(self.spec, PulseSpec::Absent)
    }
}

/// A radial-artery-like pressure contour over one beat (`phase` in [0, 1)), normalized to
/// span 0 (end diastole) to 1 (systolic peak): a fast systolic upstroke, a reflected-wave
/// shoulder, the dicrotic wave and an exponential diastolic run-off (smooth bumps: systolic
/// wave, late-systolic reflection, dicrotic wave), tapered to zero at the beat's end so the
/// contour is continuous across beats.
pub fn physiological_shape(phase: f64) -> f64 {
    let p = phase.clamp(0.0, 1.0);
    (raw_shape(p) / *SHAPE_PEAK).clamp(0.0, 1.0)
}

fn raw_shape(p: f64) -> f64 {
    let bump = |centre: f64, width: f64| (-((p - centre) / width).powi(2)).exp();
    let raw = bump(0.16, 0.07) + 0.45 * bump(0.32, 0.08) + 0.22 * bump(0.52, 0.07);
    let decay = 0.18 * (-(p - 0.55).max(0.0) / 0.25).exp() * smooth_step(p, 0.35, 0.6);
    (raw + decay) * (1.0 - smooth_step(p, 0.85, 1.0))
}

/// The raw contour's maximum (at the systolic peak), for normalization.
static SHAPE_PEAK: std::sync::LazyLock<f64> = std::sync::LazyLock::new(|| {
    (0..=10_000)
        .map(|i| raw_shape(i as f64 / 10_000.0))
        .fold(f64::MIN, f64::max)
});

fn smooth_step(x: f64, a: f64, b: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solenoid_reaches_pressure_and_vents() {
        let spec = PulseSpec::Solenoid {
            pressure_pa: 100e3,
            period_s: 1.0,
            duty: 0.5,
            time_constant_s: 0.03,
        };
        let mut p = PulseSource::new(&spec, 1);
        assert!((p.pressure_pa(0.45) - 100e3).abs() < 10.0);
        assert!(p.pressure_pa(0.95) < 10.0);
        assert!((p.pressure_pa(10.45) - 100e3).abs() < 10.0);
        assert_eq!(p.beats_started_by(10.5), 11);
    }

    #[test]
    fn physiological_shape_spans_zero_to_one() {
        let samples: Vec<f64> = (0..1000)
            .map(|i| physiological_shape(i as f64 / 1000.0))
            .collect();
        let max = samples.iter().cloned().fold(f64::MIN, f64::max);
        let min = samples.iter().cloned().fold(f64::MAX, f64::min);
        assert!((max - 1.0).abs() < 0.01, "peak {max}");
        assert!((0.0..0.01).contains(&min), "trough {min}");
        // Continuous across the beat boundary.
        assert!((physiological_shape(0.0) - physiological_shape(0.9999)).abs() < 0.01);
        // The peak is in early systole.
        let i_max = samples.iter().position(|&v| v == max).unwrap();
        assert!(
            (100..250).contains(&i_max),
            "peak at phase {}",
            i_max as f64 / 1000.0
        );
    }

    #[test]
    fn physiological_pulse_varies_beat_to_beat_but_is_seeded() {
        let spec = PulseSpec::Physiological {
            systolic_pa: 16_000.0,
            diastolic_pa: 10_667.0,
            heart_rate_hz: 1.2,
            interval_sd_s: 0.04,
            pressure_sd_fraction: 0.05,
            rate_change: None,
            ectopic: None,
        };
        let run = |seed| {
            let mut p = PulseSource::new(&spec, seed);
            (0..3000)
                .map(|i| p.pressure_pa(i as f64 * 0.01))
                .collect::<Vec<_>>()
        };
        assert_eq!(run(3), run(3));
        assert_ne!(run(3), run(4));
        let mut p = PulseSource::new(&spec, 3);
        let beats = p.beats_started_by(30.0);
        // 1.2 Hz for 30 s: about 36 beats.
        assert!((30..=42).contains(&beats), "{beats}");
    }

    #[test]
    fn heart_rate_changes_as_scheduled() {
        let spec = PulseSpec::Physiological {
            systolic_pa: 16_000.0,
            diastolic_pa: 10_667.0,
            heart_rate_hz: 1.0,
            interval_sd_s: 0.0,
            pressure_sd_fraction: 0.0,
            rate_change: Some(RateChange {
                to_hz: 1.5,
                start_s: 20.0,
                duration_s: 10.0,
            }),
            ectopic: None,
        };
        let mut p = PulseSource::new(&spec, 1);
        // Steady 1 Hz for 20 s, then faster, then 1.5 Hz.
        assert_eq!(p.beats_started_by(19.5), 20);
        let at_30 = p.beats_started_by(30.0);
        let at_50 = p.beats_started_by(50.0);
        assert!(
            (at_50 - at_30) as f64 >= 29.0 && at_50 - at_30 <= 31,
            "{at_30} {at_50}"
        );
        assert!((31..=34).contains(&at_30), "{at_30}");
        let c = RateChange {
            to_hz: 2.0,
            start_s: 5.0,
            duration_s: 0.0,
        };
        assert_eq!(c.rate_hz(1.0, 4.9), 1.0);
        assert_eq!(c.rate_hz(1.0, 5.0), 2.0);
    }

    #[test]
    fn ectopic_beats_come_early_weak_and_are_compensated() {
        let spec = |ectopic| PulseSpec::Physiological {
            systolic_pa: 16_000.0,
            diastolic_pa: 10_667.0,
            heart_rate_hz: 1.0,
            interval_sd_s: 0.0,
            pressure_sd_fraction: 0.0,
            rate_change: None,
            ectopic,
        };
        let beats = |spec: &PulseSpec| {
            let mut p = PulseSource::new(spec, 9);
            p.advance_to(0.0);
            let mut out = vec![p.current];
            while out.len() < 400 {
                let t = p.current.start_s + p.current.period_s;
                p.advance_to(t);
                out.push(p.current);
            }
            out
        };
        let regular = beats(&spec(None));
        assert!(regular.iter().all(|b| b.period_s == 1.0));
        let e = Ectopic {
            probability: 0.1,
            prematurity: 0.3,
            pressure_fraction: 0.4,
        };
        let irregular = beats(&spec(Some(e)));
        let short: Vec<usize> = (0..irregular.len() - 1)
            .filter(|&i| (irregular[i].period_s - 0.7).abs() < 1e-12)
            .collect();
        // About one beat in ten, each followed by the weak premature beat and its pause.
        assert!((20..=60).contains(&short.len()), "{}", short.len());
        for i in short {
            let next = irregular[i + 1];
            assert!((next.period_s - 1.3).abs() < 1e-12);
            assert!((next.amplitude_pa - 0.4 * 5_333.0).abs() < 1.0);
            assert!((next.start_s + next.period_s - irregular[i].start_s - 2.0).abs() < 1e-9);
        }
        assert!(irregular.iter().all(|b| {
            [0.7, 1.0, 1.3]
                .iter()
                .any(|p| (b.period_s - p).abs() < 1e-12)
        }));
    }

    #[test]
    fn absent_pulse_is_zero() {
        let mut p = PulseSource::new(&PulseSpec::Absent, 0);
        assert!((0..100).all(|i| p.pressure_pa(i as f64 * 0.1) == 0.0));
        assert!(p.is_absent());
    }
}
