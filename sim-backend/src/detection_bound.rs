//! The weakest pulse a scene lets an ideal detector feel (`pulsetrack bound`, issue 18).
//!
//! The scene's own physics gives the inputs of `control::signal::detection_bound`: the
//! pulsatile force on each element per pascal with the artery at each place across the
//! array (the simulator's kernel and coupling, at the first placement, level, under the
//! ideal arm's contact load), the pulse pressure's energy per beat at the sensor's sample
//! rate (the scene's pump, its beat-to-beat variability included), and the element noise.
//! The bound is then what no detector on this array can beat: a tracker is judged by how
//! close it comes (docs/signal-processing.md, "The detection bound").

use control::frames::SurfacePoint;
use control::signal::detection_bound::{
    BoundError, beats_for, glrt_threshold, known_position_threshold, per_beat, snr_needed,
    waveform_energy,
};
use control::types::ELEMENTS;
use serde::Serialize;

use crate::bench::Bench;
use crate::error::SimError;
use crate::random::{Stream, standard_normal, stream, stream_seed};
use crate::scene::{PulseSource, Scene};

/// Half the span of positions the unknown-position detector searches: the array's reach.
const REACH_M: f64 = 0.009;
/// Step of the position table, m.
const STEP_M: f64 = 0.000_25;
/// Beats of the pump sampled for the energy per beat.
const BEATS_SAMPLED: u64 = 40;
/// The SNR the issue quotes as "felt" (for comparison with its figures).
const REFERENCE_SNR: f64 = 8.0;

/// What is asked of the ideal detector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundOptions {
    /// False-alarm rate per decision.
    pub pfa: f64,
    /// Detection probability.
    pub pd: f64,
    /// Seeds the pump's variability and the threshold's Monte Carlo.
    pub seed: u64,
}

/// The bound with the artery at one place on the array.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PositionBound {
    /// The artery's offset from the element line's centre, m.
    pub offset_m: f64,
    /// The largest element's pulse (peak to peak over a beat), N.
    pub peak_element_pulse_n: f64,
    /// Matched-filter SNR of one beat, position known.
    pub snr_per_beat: f64,
    /// Beats to decide with the position known (the matched filter).
    pub beats_known_position: f64,
    /// Beats to decide with the position unknown (the generalized likelihood ratio over
    /// the array's reach; an upper bound on the ideal detector's, close to it).
    pub beats_unknown_position: f64,
    /// Beats for a matched-filter SNR of 8.
    pub beats_to_snr_8: f64,
    /// Seconds for `beats_unknown_position` at the mean heart period.
    pub seconds_unknown_position: f64,
    /// Cramér-Rao bound of the artery's position (1 SD) after `beats_unknown_position`
    /// beats, amplitude unknown, m.
    pub position_sd_m: f64,
}

/// The bound for one scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneBound {
    pub scene: String,
    pub pfa: f64,
    pub pd: f64,
    pub noise_sd_n: f64,
    /// Each element's length along the artery, m (its sensing area over the pitch): the
    /// pulse's force on an element grows with it, the element noise as the scene says.
    pub element_length_m: f64,
    pub sample_rate_hz: f64,
    pub mean_period_s: f64,
    /// The pump's pulse pressure energy per beat, its mean removed, Pa² × samples.
    pub pulse_energy_pa2: f64,
    /// The detectors' thresholds in unit-normal terms: position known, and unknown
    /// (measured on noise-only draws).
    pub threshold_known_position: f64,
    pub threshold_unknown_position: f64,
    /// Draws behind the unknown-position threshold.
    pub threshold_draws: usize,
    /// At the array's centre, then every millimetre out to the array's last element.
    pub positions: Vec<PositionBound>,
}

/// The bound for `scene` on the rig `config` describes.
pub fn scene_bound(
    scene: &Scene,
    config: &config::Config,
    options: BoundOptions,
) -> Result<SceneBound, SimError> {
    let bad = |e: BoundError| SimError::Scene {
        scene: scene.name.clone(),
        message: format!("detection bound: {e}"),
    };
    let threshold_known = known_position_threshold(options.pfa).map_err(bad)?;
    let needed_known = snr_needed(threshold_known, options.pd).map_err(bad)?;
    let sample_rate_hz = config.sensor.sample_rate_hz;
    let noise_sd_n = scene.sensor.noise_sd_n;
    let pump = sample_pump(scene, sample_rate_hz, options.seed).ok_or(SimError::Scene {
        scene: scene.name.clone(),
        message: "detection bound: the scene has no pulse to detect".into(),
    })?;
    let (energy, mean_period_s) = (pump.energy_per_beat, pump.mean_period_s);
    let mut bench = Bench::new(scene, config, options.seed, true)?;
    let near = scene
        .placements
        .first()
        .copied()
        .unwrap_or(SurfacePoint::new(0.0, 0.0));
    let steps = (REACH_M / STEP_M).round() as i64;
    let offsets: Vec<f64> = (-steps..=steps).map(|k| k as f64 * STEP_M).collect();
    let table = bench.pulse_across(near, &offsets);
    // Enough noise-only draws for about a hundred false alarms, within reason.
    let draws = ((100.0 / options.pfa).ceil() as usize).clamp(20_000, 2_000_000);
    let mut rng = stream(options.seed, Stream::SensorNoise);
    let threshold_unknown = glrt_threshold(&table, options.pfa, draws, &mut || {
        standard_normal(&mut rng)
    })
    .map_err(bad)?;
    let needed_unknown = snr_needed(threshold_unknown, options.pd).map_err(bad)?;
    let pitch = scene.sensor.pitch_m;
    let last = (ELEMENTS as f64 - 1.0) / 2.0 * pitch;
    let waveform_pp = pump.peak_to_peak_pa;
    let mut positions = Vec::new();
    let mut offset = 0.0;
    while offset <= last + 1e-9 {
        let at = (offset / STEP_M).round() as i64 + steps;
        let at = usize::try_from(at).unwrap_or(0).min(table.len() - 1);
        let beat = per_beat(&table, at, energy, noise_sd_n).map_err(bad)?;
        let beats_unknown = beats_for(needed_unknown, beat.snr);
        let information = beat.position_information_per_m2 * beats_unknown;
        positions.push(PositionBound {
            offset_m: table[at].0,
            peak_element_pulse_n: table[at].1.iter().fold(0.0f64, |m, v| m.max(v.abs()))
                * waveform_pp,
            snr_per_beat: beat.snr,
            beats_known_position: beats_for(needed_known, beat.snr),
            beats_unknown_position: beats_unknown,
            beats_to_snr_8: beats_for(REFERENCE_SNR, beat.snr),
            seconds_unknown_position: beats_unknown * mean_period_s,
            position_sd_m: if information > 0.0 {
                information.recip().sqrt()
            } else {
                f64::INFINITY
            },
        });
        offset += 0.001;
    }
    Ok(SceneBound {
        scene: scene.name.clone(),
        pfa: options.pfa,
        pd: options.pd,
        noise_sd_n,
        element_length_m: scene.sensor.element_area_m2 / pitch,
        sample_rate_hz,
        mean_period_s,
        pulse_energy_pa2: energy,
        threshold_known_position: threshold_known,
        threshold_unknown_position: threshold_unknown,
        threshold_draws: draws,
        positions,
    })
}

/// The scene's pump over [`BEATS_SAMPLED`] beats at the sensor's sample rate.
struct Pump {
    /// Energy per beat with the mean removed, Pa² × samples.
    energy_per_beat: f64,
    mean_period_s: f64,
    peak_to_peak_pa: f64,
}

fn sample_pump(scene: &Scene, sample_rate_hz: f64, seed: u64) -> Option<Pump> {
    let mut pump = PulseSource::new(&scene.pulse, stream_seed(seed, Stream::Pulse));
    if pump.is_absent() || !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return None;
    }
    // From the second beat's start, whole beats.
    let mut t = 0.0;
    while pump.beats_started_by(t) < 2 && t < 60.0 {
        t += 1.0 / sample_rate_hz;
    }
    let (start, first) = (t, pump.beats_started_by(t));
    let mut samples = Vec::new();
    while pump.beats_started_by(t) < first + BEATS_SAMPLED && samples.len() < 10_000_000 {
        samples.push(pump.pressure_pa(t));
        t = start + samples.len() as f64 / sample_rate_hz;
    }
    let (lo, hi) = samples
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let beats = BEATS_SAMPLED as f64;
    Some(Pump {
        energy_per_beat: waveform_energy(&samples) / beats,
        mean_period_s: samples.len() as f64 / sample_rate_hz / beats,
        peak_to_peak_pa: if hi >= lo { hi - lo } else { 0.0 },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{PulseSpec, load};

    fn sim_config() -> config::Config {
        let (name, text) = config::shipped::SIM_CONFIG;
        config::load_str::<config::Config>(name, text).expect("shipped config")
    }

    fn options() -> BoundOptions {
        BoundOptions {
            pfa: 0.01,
            pd: 0.9,
            seed: 1,
        }
    }

    #[test]
    fn beats_grow_as_the_square_of_a_weaker_pulse() {
        let config = sim_config();
        let strong = load("weak-pulse-6kpa.ron", None).expect("scene");
        let weak = load("weak-pulse-3kpa.ron", None).expect("scene");
        let a = scene_bound(&strong, &config, options()).expect("bound");
        let b = scene_bound(&weak, &config, options()).expect("bound");
        let (a0, b0) = (a.positions[0], b.positions[0]);
        // Half the pressure: half the SNR per beat, four times the beats (the kernel is
        // linear in the pressure; the thresholds are the same).
        let ratio = b0.beats_unknown_position / a0.beats_unknown_position;
        assert!((ratio - 4.0).abs() < 0.1, "{ratio}");
        assert!((a0.snr_per_beat / b0.snr_per_beat - 2.0).abs() < 0.05);
        assert!(a0.beats_known_position > 1.0, "not at the one-beat floor");
        // Not knowing where the artery is costs beats; the position is then known to a
        // fraction of the pitch, worse with a weaker pulse only through the beats it took.
        assert!(a0.beats_unknown_position > a0.beats_known_position);
        assert!(a.threshold_unknown_position > a.threshold_known_position);
        assert!(a0.position_sd_m > 0.0 && a0.position_sd_m < 0.5 * strong.sensor.pitch_m);
        assert!((a0.position_sd_m / b0.position_sd_m - 1.0).abs() < 0.05);
        // Out to the array's last element, the pulse falls and the beats rise.
        let edge = a.positions.last().expect("rows");
        assert!(edge.offset_m >= 0.008 && edge.beats_unknown_position > a0.beats_unknown_position);
    }

    #[test]
    fn quieter_or_longer_elements_shorten_the_bound_as_the_square_of_the_snr() {
        let config = sim_config();
        let seed = load("weak-pulse-3kpa.ron", None).expect("scene");
        let at = |scene: &Scene| scene_bound(scene, &config, options()).expect("bound");
        // Where the arc runs along x, the elements' long side lies along the artery.
        let mut aligned = seed.clone();
        aligned.placements[0] = SurfacePoint::new(0.0, 0.0272);
        let base = at(&aligned);
        let mut quiet = aligned.clone();
        quiet.sensor.noise_sd_n /= 2.0;
        let quiet = at(&quiet);
        let mut long = aligned.clone();
        long.sensor.element_area_m2 *= 2.0;
        let long = at(&long);
        assert!((long.element_length_m / base.element_length_m - 2.0).abs() < 1e-9);
        for (b, q, l) in rows_side_by_side(&base, &quiet, &long) {
            // Half the noise: twice the SNR per beat, a quarter of the beats.
            let ratio = b.beats_unknown_position / q.beats_unknown_position;
            assert!((ratio - 4.0).abs() < 0.01, "noise: {ratio}");
            // Twice the element's length along the artery: twice the pulsatile force (its
            // area times the pressure the tissue passes on) over the same per-element
            // noise (a readout-limited element).
            let ratio = b.beats_unknown_position / l.beats_unknown_position;
            assert!(
                (ratio - 4.0).abs() < 0.08,
                "length at {} m: {ratio}",
                b.offset_m
            );
            // The position is known as well after the (fewer) beats: the same SNR.
            assert!((q.position_sd_m / b.position_sd_m - 1.0).abs() < 0.05);
        }
        // At the seed's placement the arc crosses the element line obliquely (about 47°):
        // a longer element also spans the kernel across the artery, so it gains less.
        let oblique = at(&seed);
        let mut long = seed.clone();
        long.sensor.element_area_m2 *= 2.0;
        let long = at(&long);
        let ratio =
            oblique.positions[0].beats_unknown_position / long.positions[0].beats_unknown_position;
        assert!(ratio > 3.0 && ratio < 3.9, "oblique: {ratio}");
    }

    fn rows_side_by_side<'a>(
        a: &'a SceneBound,
        b: &'a SceneBound,
        c: &'a SceneBound,
    ) -> impl Iterator<Item = (&'a PositionBound, &'a PositionBound, &'a PositionBound)> {
        a.positions
            .iter()
            .zip(&b.positions)
            .zip(&c.positions)
            .map(|((x, y), z)| (x, y, z))
    }

    #[test]
    fn a_scene_without_a_pulse_or_bad_options_are_refused() {
        let config = sim_config();
        let mut scene = load("seed-arc-145.ron", None).expect("scene");
        let bad = BoundOptions {
            pfa: 0.0,
            ..options()
        };
        let e = scene_bound(&scene, &config, bad).expect_err("pfa 0");
        assert!(e.to_string().contains("false-alarm rate"), "{e}");
        scene.pulse = PulseSpec::Absent;
        let e = scene_bound(&scene, &config, options()).expect_err("no pulse");
        assert!(e.to_string().contains("no pulse"), "{e}");
    }
}
