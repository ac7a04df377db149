//! A pulse found at rest and placed on the array: the search over the period
//! ([`PulseSearch`]) and the kernel fit ([`fit_kernel`]), with the pulse's sign the one the
//! kernel fits. Shared by `beatslide`'s marks and the autonomous search's looks, so that both
//! feel and place a pulse the same way.
//!
//! In time a square wave and its inverse differ only by half a period; the kernel with its
//! small negative lobes fits one far better than the other, so both signs are fitted and the
//! better kept.

use super::kernel_fit::{KernelFit, KernelFitError, fit_kernel};
use super::pulse_search::{PulseFound, PulseSearch, PulseSearchSettings, SearchMiss};
use crate::sensor::ArrayGeometry;
use crate::types::TactileFrame;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlaceMiss {
    #[error(transparent)]
    Search(#[from] SearchMiss),
    #[error(transparent)]
    Kernel(#[from] KernelFitError),
}

/// A pulse placed on the array.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlacedPulse {
    pub found: PulseFound,
    pub fit: KernelFit,
    /// How much worse (in chi-square) the pulse's inverse fits the kernel: small when the
    /// pulse is too weak to know its sign, and so its place (infinite when the inverse
    /// cannot be fitted at all).
    pub sign_margin_chi2: f64,
}

/// The strongest pulse in `settings`' range among `frames` and its kernel fit. At the
/// array's edge the position is only a bound: it is kept with an SE of two pitches.
pub fn placed_pulse<'a>(
    search: &mut PulseSearch,
    frames: impl Iterator<Item = &'a TactileFrame> + Clone,
    sigma: f64,
    settings: &PulseSearchSettings,
    geometry: &ArrayGeometry,
) -> Result<PlacedPulse, PlaceMiss> {
    let found = search.search(frames, sigma, settings)?;
    let se = found.amplitudes.se_per_sigma * sigma;
    let flipped = found.flipped();
    let (found, mut fit, margin) = match (
        fit_kernel(&found.amplitudes.amplitude_n, se, geometry),
        fit_kernel(&flipped.amplitudes.amplitude_n, se, geometry),
    ) {
        (Ok(a), Ok(b)) if b.chi2 < a.chi2 => (flipped, b, a.chi2 - b.chi2),
        (Ok(a), Ok(b)) => (found, a, b.chi2 - a.chi2),
        (Ok(a), Err(_)) => (found, a, f64::INFINITY),
        (Err(_), Ok(b)) => (flipped, b, f64::INFINITY),
        (Err(e), Err(_)) => return Err(e.into()),
    };
    if fit.at_edge || !fit.offset_se_m.is_finite() {
        fit.offset_se_m = 2.0 * geometry.pitch_m;
    }
    Ok(PlacedPulse {
        found,
        fit,
        sign_margin_chi2: margin,
    })
}
