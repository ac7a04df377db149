//! A heart for the weak-pulse tests and their benchmark (`examples/weak_pulse_roc.rs`
//! includes this file by path): beat onsets whose intervals vary as a real heart's.

use crate::test_normals::Normals;

/// Beat onsets and intervals over `span_s` for a mean period `t0`: respiratory modulation
/// (4 %, 0.25 Hz), a slow wander (AR(1), 3 %) and beat-to-beat scatter (2 %): interval SD
/// about 4.6 %.
pub fn beats(t0: f64, span_s: f64, rng: &mut Normals) -> Vec<(f64, f64)> {
    let mut t = -t0 * rng.uniform();
    let (mut wander, psi) = (0.0, std::f64::consts::TAU * rng.uniform());
    let mut out = Vec::new();
    while t < span_s + 2.0 {
        wander = 0.95 * wander + 0.03 * (1.0f64 - 0.95 * 0.95).sqrt() * rng.next();
        let rsa = 0.04 * (std::f64::consts::TAU * 0.25 * t + psi).sin();
        let rr = t0 * (1.0 + rsa + wander + 0.02 * rng.next());
        out.push((t, rr));
        t += rr;
    }
    out
}

/// The beat under way at each time of a run of rising times, from [`beats`]' onsets.
pub struct BeatCursor {
    onsets: Vec<(f64, f64)>,
    beat: usize,
}

impl BeatCursor {
    pub fn new(onsets: Vec<(f64, f64)>) -> Self {
        Self { onsets, beat: 0 }
    }

    /// The onset and interval of the beat under way at `t` (none before the first, or with
    /// no beats); `t` must not go back.
    pub fn at(&mut self, t: f64) -> Option<(f64, f64)> {
        while self.beat + 1 < self.onsets.len() && self.onsets[self.beat + 1].0 <= t {
            self.beat += 1;
        }
        self.onsets
            .get(self.beat)
            .copied()
            .filter(|(t0, _)| *t0 <= t)
    }
}
