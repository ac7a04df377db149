//! Every constant of `beatslide`, with its default and why (docs/tracker-beatslide.md has
//! the measurements behind them).

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BeatSlideParams {
    /// Pulse periods searched, s (the band of heart rates and the seed's ~1 Hz solenoid;
    /// as `seed2002`).
    pub min_period_s: f64,
    pub max_period_s: f64,
    /// A pulse is declared at rest when the search statistic (the largest eigenvalue of the
    /// elements' whitened harmonic scatter, normalized by its noise-only law) exceeds this.
    /// Chosen on noise-only windows (docs/tracker-beatslide.md).
    pub detection_threshold: f64,
    /// Longest stretch over which a heart is taken to keep its phase, s: searches at rest
    /// over longer windows pool sub-windows of about this length through their common
    /// spatial pattern.
    pub coherent_s: f64,
    /// First window of a mark, s; extended by `mark_extend_s` while nothing is found, up to
    /// `mark_max_window_s` (a weak pulse is felt by waiting longer).
    pub mark_window_s: f64,
    pub mark_extend_s: f64,
    pub mark_max_window_s: f64,
    /// Window of a search at rest after the pulse was lost while sliding, s.
    pub search_window_s: f64,
    /// A fix while sliding is accepted when the kernel amplitude exceeds this many of its
    /// standard errors.
    pub fix_snr: f64,
    /// Beats per fix are chosen so that a fix reaches about this amplitude SNR.
    pub target_snr: f64,
    /// Most beats averaged into one fix.
    pub max_beats_per_fix: usize,
    /// Top sliding speed, m/s: the speed setting.
    pub max_speed_m_s: f64,
    /// Most artery travelled between two fixes, m.
    pub max_travel_per_fix_m: f64,
    /// Slow down so that the path model's predicted lateral SD two fixes ahead stays within
    /// this, m (the array reaches ±9 mm; the model's confidence sets the step).
    pub prediction_sd_m: f64,
    /// Never move further than this along the path beyond the last fix, m: with no pulse
    /// the sensor stops within it instead of wandering.
    pub max_blind_m: f64,
    /// Failed windows in a row while sliding before stopping to search at rest.
    pub sliding_misses: usize,
    /// Returns to the last fix without progress before the artery is declared lost.
    pub max_returns: usize,
    /// A fix whose lateral innovation exceeds both this many predicted SDs and
    /// `gate_min_m` is not on this artery (a lump, a neighbour): rejected.
    pub gate_sigma: f64,
    pub gate_min_m: f64,
    /// Prior SD of the path's curvature before any data, 1/m.
    pub curvature_prior_per_m: f64,
    /// How fast the curvature may change along the path: SD of its change over one metre,
    /// 1/m per √m (a random walk).
    pub curvature_walk: f64,
    /// The same for a second, turning mode of the path model, mixed with the calm one
    /// above by their likelihood (an interacting multiple model, `path_filter`); 0 (the
    /// default), or anything not above `curvature_walk`, keeps one mode. Opt-in: on the
    /// scene families a turning mode takes 10-15 % off the beats on winding courses and
    /// adds as much under breathing and beside lumps (docs/tracker-beatslide.md, "Two
    /// curvature walks").
    pub turning_walk: f64,
    /// With a turning mode: the probability that the path turns from calm to turning
    /// between two fixes, and back, each in (0, 0.5].
    pub turn_onset: f64,
    pub turn_end: f64,
    /// Prior of how far the sensor trails the robot's belief while sliding, m, and its SD:
    /// the rod and incision compliance times the sliding friction (on the seed's bench about
    /// 11 mm/N × 0.4 N). Estimated on line from then on.
    pub lag_prior_m: f64,
    pub lag_prior_sd_m: f64,
    /// How fast that lag may change along the path, m per √m (the compliance depends on
    /// the insertion depth). Slow and tight: a lag left free takes up the artery's own
    /// motion across the course (breathing), reaching 10 mm against a true 2-5 mm
    /// (docs/tracker-beatslide.md, "Tissue motion").
    pub lag_walk: f64,
    /// Added in quadrature to each fix's standard error, m: what the fit cannot see
    /// (the sensor's compliance, the artery moving on the array within a window).
    pub fix_floor_m: f64,
    /// How far the sensor sits outward of the robot's belief per metre of its distance from
    /// the point of the surface below the pivot (the tissue frame's origin): the contact
    /// force less the added mass's weight, acting across a tilted rod, bends it and pushes
    /// the incision aside (rod and incision compliance × net load ÷ the pivot's height above
    /// the surface). Dimensionless; 0 for a rigid rod. A calibration of the rig, like
    /// `lag_prior_m`: unlike the lag it cannot be learned on line, since it scales the whole
    /// path about the pivot and a scaled path is as smooth as the true one.
    pub tilt_deflection: f64,
    /// Speed of the moves back to the last fix, m/s.
    pub return_speed_m_s: f64,
    /// After a loss, listen for the pulse in windows while going back to the last fix: a
    /// clear fix on the way (timed on the whole array) re-seeds the path model from the
    /// last fix to it and the slide goes on from there, without the search at the last fix
    /// and the probe. Such a fix steers and is never reported. A regular heart's clear
    /// pulse (one beat per fix) then goes back at once, without the search where it
    /// stopped (`machine/lost.rs`). `false`: the searches at rest alone, as before
    /// 2026-11-28 (docs/tracker-beatslide.md, "Listening on the way back").
    pub listen_returning: bool,
    /// The first mark is made from both sides: a stroke this far along +z and back, a mark,
    /// the same along -z, a second mark, and their midpoint is the seed point, so that
    /// where the rod rests off the belief cancels (`machine/seating.rs`), m; 0 (the
    /// default) marks once where the surgeon left it. 8 mm halves the points more than
    /// 2 mm off on the scene families, but costs the shipped arcs some of their figures
    /// (docs/tracker-beatslide.md, "The first placement").
    pub seat_stroke_m: f64,
    /// Where the arm's load says where the sensor is (`TrackerInput::loaded_sensor`): at
    /// rest (marks, searches) a point is reported where that reading puts it (it is within
    /// 0.1-0.3 mm there); while sliding, where it scatters by 0.3-0.6 mm RMS, a point whose
    /// place by that reading and by the tracker's own (belief, tilt and lag models) differ
    /// by more than this across the path is not reported (it still steers), m: about three
    /// times that scatter. 0 ignores the reading.
    pub load_gate_m: f64,
    /// A mark that found no pulse in `mark_max_window_s` listens on at rest for one too
    /// weak to see in a window (`signal::weak_pulse`: its likelihood ratio over the
    /// artery's place and the heart's timing, growing until it decides), up to this long
    /// in all, s; at most 600 (the shipped threshold table's limit), 0 turns it off.
    /// An artery found so is tracked by `weak_step_m` steps, listening at each
    /// (`machine/weak.rs`).
    pub weak_limit_s: f64,
    /// The listen's false-alarm rate over that limit: 0.01 or 0.05 (the shipped table's).
    pub weak_false_alarm: f64,
    /// The distance between the listens that track a weak artery, m: each is made at rest,
    /// after a move this far along the path model from the last.
    pub weak_step_m: f64,
}

impl Default for BeatSlideParams {
    fn default() -> Self {
        Self {
            min_period_s: 0.45,
            max_period_s: 2.2,
            detection_threshold: 8.0,
            coherent_s: 12.0,
            mark_window_s: 4.0,
            mark_extend_s: 2.0,
            mark_max_window_s: 40.0,
            search_window_s: 4.0,
            fix_snr: 5.0,
            target_snr: 7.0,
            max_beats_per_fix: 12,
            max_speed_m_s: 0.016,
            max_travel_per_fix_m: 0.025,
            prediction_sd_m: 0.0045,
            max_blind_m: 0.03,
            sliding_misses: 2,
            max_returns: 2,
            gate_sigma: 4.0,
            gate_min_m: 0.002,
            curvature_prior_per_m: 1.0 / 0.06,
            curvature_walk: 45.0,
            turning_walk: 0.0,
            turn_onset: 0.05,
            turn_end: 0.3,
            lag_prior_m: 0.0045,
            lag_prior_sd_m: 0.001,
            lag_walk: 0.003,
            fix_floor_m: 0.001,
            // The seed's bench as simulated (docs/tracker-beatslide.md, "Tilt deflection").
            tilt_deflection: 0.027,
            return_speed_m_s: 0.01,
            listen_returning: true,
            seat_stroke_m: 0.0,
            load_gate_m: 0.0015,
            weak_limit_s: 300.0,
            weak_false_alarm: 0.01,
            weak_step_m: 0.005,
        }
    }
}
