//! The beat period from the beat-to-beat intervals: the autocorrelation of the pulse's
//! spatially combined signal, pooled over the windows of one heart.
//!
//! Why not only the harmonic search ([`super::pulse_search`]): that statistic fits the
//! harmonics of one phase over a whole sub-window, so it needs the heart to keep its phase.
//! An irregular heart (beat interval SD 10-20 % of the period) loses it within a few beats,
//! the fundamental's power is smeared, and a period of two or three beats, whose 2nd or 3rd
//! harmonic catches the heart's fundamental and whose other harmonics catch the smear,
//! scores as well as the true one (measured: a 1.6 Hz pulse with 19 % jitter in a 4 s
//! window gave twice the period in 7 of 30 windows). The autocorrelation compares each beat
//! with the next one only: its peak at one interval is lowered by one interval's jitter,
//! at two intervals by √2 times as much, so the true period is normally the highest peak;
//! over a handful of beats chance can lift a later one, so the period taken is the
//! shortest peak at least [`SHORTEST_FRACTION`] of the highest. The series is band-passed
//! first (the harmonics decorrelate fastest and a strong dicrotic wave would otherwise put
//! a peak near half the period). A window holds few beats, so successive windows of the
//! same heart are pooled ([`BeatIntervals`]).
//!
//! Hand-written: a few dozen lines over buffers allocated once, nothing allocated per
//! search; no crate offers a pooled autocorrelation on borrowed slices.

/// The period is the shortest peak at least this fraction of the highest: with varying
/// intervals the peak at one beat is the higher (the correlation at `k` beats falls with
/// `k` times the interval variance), but over a handful of beats chance can lift a later
/// one (measured on 4 s windows at 1.6-1.8 Hz with a 20 % interval SD).
pub const SHORTEST_FRACTION: f64 = 0.5;
/// A peak lower than this correlation is not taken as a beat interval (noise alone gives
/// about `1/√n` for `n` samples: 0.1 in 4 s at 25 Hz).
pub const MIN_CORRELATION: f64 = 0.2;
/// Relative tolerance of an agreement between two periods.
pub const TOLERANCE: f64 = 0.12;

/// The beats' lag products pooled over the windows seen, with their own buffers.
///
/// One window at rest holds a handful of beats: with a 20 % interval SD its
/// autocorrelation alone can favour two beats over one (measured: 2 to 5 of 40 four-second
/// windows). Successive windows of the same heart are pooled, older ones weighed down by
/// `retain` per window, so the decision rests on every beat felt lately.
#[derive(Debug, Clone)]
pub struct BeatIntervals {
    band: Vec<f64>,
    cross: Vec<f64>,
    energy_lead: Vec<f64>,
    energy_lag: Vec<f64>,
    values: Vec<f64>,
    dt_s: f64,
}

impl BeatIntervals {
    /// Buffers for windows of up to `max_samples` samples and lags of up to `max_lags`.
    pub fn new(max_samples: usize, max_lags: usize) -> Self {
        let lags = max_lags.max(4);
        Self {
            band: vec![0.0; max_samples.max(4)],
            cross: vec![0.0; lags],
            energy_lead: vec![0.0; lags],
            energy_lag: vec![0.0; lags],
            values: vec![0.0; lags],
            dt_s: f64::NAN,
        }
    }

    /// Drop every window pooled so far (a different heart, or a new trial).
    pub fn forget(&mut self) {
        for v in [&mut self.cross, &mut self.energy_lead, &mut self.energy_lag] {
            v.fill(0.0);
        }
        self.dt_s = f64::NAN;
    }

    /// Pool one window: `series` sampled every `dt_s` s, lags up to `max_period_s` (and
    /// half the window), band-passed (see [`band_pass`]) for periods `min_period_s` to
    /// `max_period_s`; earlier windows are weighed by `retain` (0 to 1). A window with a
    /// different sample spacing replaces the pool. Returns false (and pools nothing) for
    /// a constant, non-finite or too short window or bad arguments.
    pub fn add(
        &mut self,
        series: &[f64],
        dt_s: f64,
        min_period_s: f64,
        max_period_s: f64,
        retain: f64,
    ) -> bool {
        let n = series.len().min(self.band.len());
        let series = &series[..n];
        if !(dt_s.is_finite()
            && dt_s > 0.0
            && min_period_s.is_finite()
            && min_period_s > 0.0
            && max_period_s.is_finite()
            && max_period_s > min_period_s)
            || n < 8
        {
            return false;
        }
        let band = &mut self.band[..n];
        if !band_pass(series, dt_s, min_period_s, max_period_s, band) {
            return false;
        }
        if !(self.dt_s.is_finite() && (self.dt_s / dt_s - 1.0).abs() < 0.02) {
            for v in [&mut self.cross, &mut self.energy_lead, &mut self.energy_lag] {
                v.fill(0.0);
            }
            self.dt_s = dt_s;
        }
        let keep = if retain.is_finite() {
            retain.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let last_lag = ((max_period_s / dt_s).ceil() as usize)
            .min(n / 2)
            .min(self.cross.len() - 1);
        for lag in 0..self.cross.len() {
            let (mut c, mut ea, mut eb) = (0.0, 0.0, 0.0);
            if lag <= last_lag {
                let (a, b) = (&band[..n - lag], &band[lag..]);
                c = a.iter().zip(b).map(|(p, q)| p * q).sum();
                ea = a.iter().map(|p| p * p).sum();
                eb = b.iter().map(|q| q * q).sum();
            }
            self.cross[lag] = keep * self.cross[lag] + c;
            self.energy_lead[lag] = keep * self.energy_lead[lag] + ea;
            self.energy_lag[lag] = keep * self.energy_lag[lag] + eb;
        }
        true
    }

    /// The pooled autocorrelation for periods `min_period_s..=max_period_s`; `None` when
    /// nothing is pooled over at least three lags of that range.
    pub fn autocorrelation(
        &mut self,
        min_period_s: f64,
        max_period_s: f64,
    ) -> Option<Autocorrelation<'_>> {
        let dt = self.dt_s;
        if !(dt.is_finite() && min_period_s > 0.0 && max_period_s.is_finite()) {
            return None;
        }
        let first_lag = ((min_period_s / dt).floor() as usize).max(1);
        let last_lag = ((max_period_s / dt).ceil() as usize).min(self.cross.len() - 1);
        let mut count = 0;
        for lag in first_lag..=last_lag.max(first_lag) {
            let denom = (self.energy_lead[lag] * self.energy_lag[lag]).sqrt();
            if denom.is_nan() || denom <= 0.0 {
                break;
            }
            self.values[lag - first_lag] = self.cross[lag] / denom;
            count += 1;
        }
        (count >= 3).then(|| Autocorrelation {
            values: &self.values[..count],
            first_lag,
            dt_s: dt,
        })
    }
}

/// A band-pass as the difference of two centred moving means: over a quarter of the
/// shortest period (keeps the fundamental, drops most harmonics, which a varying interval
/// decorrelates first) and over the longest period (a creep or a contact change is not a
/// beat). False if the result is constant or not finite.
pub fn band_pass(
    series: &[f64],
    dt_s: f64,
    min_period_s: f64,
    max_period_s: f64,
    out: &mut [f64],
) -> bool {
    let short = (0.125 * min_period_s / dt_s).round() as usize;
    let long = ((0.5 * max_period_s / dt_s).round() as usize).max(1);
    let mut fast = RunningMean::default();
    let mut slow = RunningMean::default();
    for (i, d) in out.iter_mut().take(series.len()).enumerate() {
        *d = fast.centred(series, i, short) - slow.centred(series, i, long);
    }
    let scale = series.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let y = &out[..series.len().min(out.len())];
    y.iter().all(|v| v.is_finite()) && y.iter().any(|v| v.abs() > 1e-12 * (1.0 + scale))
}

/// The normalized autocorrelation over a range of lags.
#[derive(Debug)]
pub struct Autocorrelation<'a> {
    /// At lag `first_lag + i` samples.
    values: &'a [f64],
    first_lag: usize,
    dt_s: f64,
}

impl Autocorrelation<'_> {
    /// The correlation at each lag, the first at [`Autocorrelation::first_period_s`], one
    /// sample apart.
    pub fn values(&self) -> &[f64] {
        self.values
    }

    pub fn first_period_s(&self) -> f64 {
        self.period_of(0.0)
    }

    fn period_of(&self, i: f64) -> f64 {
        (self.first_lag as f64 + i) * self.dt_s
    }

    /// The highest local maximum (an interior one: a peak at the range's end may continue
    /// beyond it) within `period_s · (1 ± tolerance)`: its correlation and its period,
    /// refined by a parabola.
    pub fn peak_near(&self, period_s: f64, tolerance: f64) -> Option<(f64, f64)> {
        let lo = period_s * (1.0 - tolerance);
        let hi = period_s * (1.0 + tolerance);
        self.peak_in(lo, hi)
    }

    /// The highest interior local maximum with its period in `lo_s..=hi_s`.
    pub fn peak_in(&self, lo_s: f64, hi_s: f64) -> Option<(f64, f64)> {
        let v = self.values;
        let mut best: Option<(f64, f64)> = None;
        for i in 1..v.len().saturating_sub(1) {
            let p = self.period_of(i as f64);
            if p < lo_s || p > hi_s || v[i] < v[i - 1] || v[i] < v[i + 1] {
                continue;
            }
            if best.is_none_or(|(r, _)| v[i] > r) {
                let denom = v[i - 1] - 2.0 * v[i] + v[i + 1];
                let shift = if denom < 0.0 {
                    (0.5 * (v[i - 1] - v[i + 1]) / denom).clamp(-0.5, 0.5)
                } else {
                    0.0
                };
                best = Some((v[i], self.period_of(i as f64 + shift)));
            }
        }
        best
    }

    /// The beat period: the shortest peak at least [`SHORTEST_FRACTION`] of the highest
    /// (a peak at several beats is never higher than at one but for chance; a dicrotic
    /// wave gives no peak at half the period once the harmonics are filtered out).
    /// `None` when no peak reaches [`MIN_CORRELATION`].
    pub fn beat_period(&self) -> Option<BeatPeriod> {
        let (r_best, _) = self.peak_in(0.0, f64::INFINITY)?;
        if r_best < MIN_CORRELATION {
            return None;
        }
        let floor = (SHORTEST_FRACTION * r_best).max(MIN_CORRELATION);
        let v = self.values;
        (1..v.len().saturating_sub(1))
            .find(|&i| v[i] >= floor && v[i] >= v[i - 1] && v[i] >= v[i + 1])
            .map(|i| {
                let denom = v[i - 1] - 2.0 * v[i] + v[i + 1];
                let shift = if denom < 0.0 {
                    (0.5 * (v[i - 1] - v[i + 1]) / denom).clamp(-0.5, 0.5)
                } else {
                    0.0
                };
                BeatPeriod {
                    period_s: self.period_of(i as f64 + shift),
                    correlation: v[i],
                }
            })
    }
}

/// A beat period with the correlation of consecutive beats at that interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeatPeriod {
    pub period_s: f64,
    pub correlation: f64,
}

/// Do two periods agree within [`TOLERANCE`]?
pub fn agree(a_s: f64, b_s: f64) -> bool {
    (a_s / b_s - 1.0).abs() <= TOLERANCE
}

/// A centred moving mean over a series, advanced one index at a time.
#[derive(Debug, Default)]
struct RunningMean {
    sum: f64,
    lo: usize,
    hi: usize,
}

impl RunningMean {
    /// The mean of `series[i - half ..= i + half]` (clipped at the ends); `i` must not
    /// decrease between calls.
    fn centred(&mut self, series: &[f64], i: usize, half: usize) -> f64 {
        let want_lo = i.saturating_sub(half);
        let want_hi = (i + half + 1).min(series.len());
        while self.hi < want_hi {
            self.sum += series[self.hi];
            self.hi += 1;
        }
        while self.lo < want_lo {
            self.sum -= series[self.lo];
            self.lo += 1;
        }
        self.sum / (self.hi - self.lo).max(1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.04;

    /// A pulse train: `shape(phase)` per beat, beat intervals given.
    fn train(intervals: &[f64], shape: impl Fn(f64) -> f64) -> Vec<f64> {
        let total: f64 = intervals.iter().sum();
        let n = (total / DT) as usize;
        let mut out = Vec::with_capacity(n);
        let (mut k, mut onset) = (0usize, 0.0);
        for i in 0..n {
            let t = i as f64 * DT;
            while k + 1 < intervals.len() && t >= onset + intervals[k] {
                onset += intervals[k];
                k += 1;
            }
            out.push(shape((t - onset) / intervals[k]));
        }
        out
    }

    fn period(series: &[f64]) -> Option<BeatPeriod> {
        let mut pool = BeatIntervals::new(series.len(), 128);
        if !pool.add(series, DT, 0.45, 2.2, 0.0) {
            return None;
        }
        pool.autocorrelation(0.45, 2.2)?.beat_period()
    }

    fn systolic(phi: f64) -> f64 {
        (-((phi - 0.15) / 0.08).powi(2)).exp()
    }

    #[test]
    fn regular_train_gives_its_period_not_a_multiple() {
        let s = train(&[0.625; 16], systolic);
        let p = period(&s).expect("a period");
        assert!((p.period_s - 0.625).abs() < 0.02, "{p:?}");
    }

    #[test]
    fn dicrotic_wave_does_not_halve_the_period() {
        // The second harmonic 1.3 times the fundamental.
        let shape = |phi: f64| {
            let w = std::f64::consts::TAU * phi;
            w.cos() + 1.3 * (2.0 * w).cos()
        };
        let s = train(&[1.1; 10], shape);
        let p = period(&s).expect("a period");
        assert!((p.period_s - 1.1).abs() < 0.04, "{p:?}");
    }

    #[test]
    fn flat_or_short_series_give_nothing() {
        assert_eq!(period(&[0.3; 200]), None);
        assert_eq!(period(&[0.3, 0.1, 0.2]), None);
        // A bad sample spacing or range pools nothing.
        let s = train(&[0.625; 16], systolic);
        let mut pool = BeatIntervals::new(s.len(), 64);
        assert!(!pool.add(&s, 0.0, 0.45, 2.2, 0.5));
        assert!(!pool.add(&s, DT, 0.45, f64::NAN, 0.5));
        assert!(!pool.add(&[f64::NAN; 40], DT, 0.45, 2.2, 0.5));
        assert!(pool.autocorrelation(0.45, 2.2).is_none());
    }

    #[test]
    fn pooling_outvotes_one_ambiguous_window() {
        // Alternating short and long intervals look like a period of two beats in one
        // window; regular windows of the same heart before it settle on one beat.
        let mut pool = BeatIntervals::new(400, 128);
        let alternating = train(&[0.5, 0.75, 0.5, 0.75, 0.5, 0.75, 0.5], systolic);
        assert!(pool.add(&alternating, DT, 0.45, 2.2, 0.5));
        let alone = pool
            .autocorrelation(0.45, 2.2)
            .and_then(|a| a.beat_period());
        let regular = train(&[0.625; 7], systolic);
        pool.forget();
        for _ in 0..3 {
            assert!(pool.add(&regular, DT, 0.45, 2.2, 0.5));
        }
        assert!(pool.add(&alternating, DT, 0.45, 2.2, 0.5));
        let pooled = pool
            .autocorrelation(0.45, 2.2)
            .and_then(|a| a.beat_period())
            .expect("a period");
        assert!(
            (pooled.period_s - 0.625).abs() < 0.03,
            "{pooled:?} (alone {alone:?})"
        );
    }
}
