//! Beat times for the live view's `/pulse`: the peaks of one band-passed element trace.
//!
//! A display aid, not a detector the tracker trusts: any tracker (and a replay, which runs
//! none) gets the same marks, so they come from the trace the surgeon sees. A beat is a
//! sample that is the trace's largest within `spacing_s` either side (a confirmed peak: its
//! whole neighbourhood is in the window) and above the window's midrange, so the ripple
//! between two beats is not a beat. On a trace with no pulse these are the noise's own
//! peaks; the tracker's period (`/pulse.period_s`, null until it reports one) says whether
//! it felt a pulse.

/// Shortest spacing when no period is known, s: a heart at 200 beats per minute.
pub const MIN_SPACING_S: f64 = 0.3;

/// The spacing for a heart whose period is `period_s` (beats come no closer than 60 % of
/// it, which still admits the irregular hearts the simulator draws).
pub fn spacing_s(period_s: Option<f64>) -> f64 {
    period_s
        .filter(|p| p.is_finite() && *p > 0.0)
        .map_or(MIN_SPACING_S, |p| (0.6 * p).max(MIN_SPACING_S))
}

/// Times of the confirmed peaks of `trace` (time s, value), oldest first.
pub fn beat_times(trace: &[(f64, f64)], spacing_s: f64) -> Vec<f64> {
    let (lo, hi) = trace
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &(_, v)| {
            (lo.min(v), hi.max(v))
        });
    if trace.len() < 3 || hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return Vec::new();
    }
    let (first, last) = (trace[0].0, trace[trace.len() - 1].0);
    let mid = 0.5 * (lo + hi);
    let mut beats = Vec::new();
    for (i, &(t, v)) in trace.iter().enumerate() {
        if v <= mid || t - first < spacing_s || last - t < spacing_s {
            continue;
        }
        // Earlier equal samples win, so a flat top gives one beat.
        let peak = trace
            .iter()
            .enumerate()
            .filter(|(_, (u, _))| (u - t).abs() <= spacing_s)
            .all(|(j, &(_, w))| w < v || (w == v && j >= i));
        if peak {
            beats.push(t);
        }
    }
    beats
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace(f: impl Fn(f64) -> f64, seconds: f64) -> Vec<(f64, f64)> {
        (0..(seconds * 100.0) as usize)
            .map(|i| {
                let t = i as f64 / 100.0;
                (t, f(t))
            })
            .collect()
    }

    #[test]
    fn a_pulse_gives_one_beat_per_period_at_its_peaks() {
        // A 1.25 Hz pulse with a dicrotic bump (a second, smaller maximum each beat).
        let w = 2.0 * std::f64::consts::PI * 1.25;
        let tr = trace(|t| (w * t).sin() + 0.3 * (2.0 * w * t + 1.0).sin(), 4.0);
        let beats = beat_times(&tr, spacing_s(Some(0.8)));
        assert!(beats.len() >= 2, "{beats:?}");
        for pair in beats.windows(2) {
            assert!((pair[1] - pair[0] - 0.8).abs() < 0.011, "{beats:?}");
        }
        for &t in &beats {
            let (before, after) = (
                tr.iter().find(|s| (s.0 - (t - 0.01)).abs() < 1e-9),
                tr.iter().find(|s| (s.0 - (t + 0.01)).abs() < 1e-9),
            );
            let v = tr.iter().find(|s| s.0 == t).map(|s| s.1);
            assert!(v > before.map(|s| s.1) && v >= after.map(|s| s.1), "{t}");
        }
    }

    #[test]
    fn unconfirmed_edges_flat_and_short_traces_give_no_beat() {
        assert!(beat_times(&trace(|_| 0.2, 3.0), 0.3).is_empty());
        assert!(beat_times(&[(0.0, 1.0), (0.01, 2.0)], 0.3).is_empty());
        // A rising ramp peaks at its newest sample: not a beat until it has come down.
        assert!(beat_times(&trace(|t| t, 3.0), 0.3).is_empty());
        // A flat-topped peak is one beat, at its first sample.
        let plateau = trace(|t| (1.0 - (t - 1.5).abs()).min(0.8), 3.0);
        let beats = beat_times(&plateau, 0.3);
        assert_eq!(beats.len(), 1, "{beats:?}");
        assert!((beats[0] - 1.3).abs() < 0.011, "{beats:?}");
    }

    #[test]
    fn the_spacing_follows_the_reported_period_but_never_below_a_racing_heart() {
        assert_eq!(spacing_s(None), MIN_SPACING_S);
        assert!((spacing_s(Some(1.0)) - 0.6).abs() < 1e-12);
        assert_eq!(spacing_s(Some(0.2)), MIN_SPACING_S);
        assert_eq!(spacing_s(Some(f64::NAN)), MIN_SPACING_S);
    }
}
