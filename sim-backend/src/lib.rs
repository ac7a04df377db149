//! The simulated bench: it implements control's ports with physics, so the daemon and the
//! trackers run unchanged without hardware.
//!
//! - [`scene`]: what exists (artery, pulse, tissue, sensor, which mechanical effects), read
//!   from RON;
//! - [`physics`]: the surface pressure kernel and tactile model, tissue contact and friction,
//!   the rod through a compliant pivot, the Phantom's joint dynamics and encoders;
//! - [`rig`]: the simulated bench behind control's ports, for the daemon;
//! - [`runner`]: the lockstep runner behind `pulsetrack sim` and the benchmarks;
//! - [`family`]: scene families, distributions of scenes a trial draws one scene from.
//!
//! The 2-D tissue FEM of the seed papers, and the FEM pressure kernel a scene may use instead
//! of the analytic one, are the crate `pulsetrack-fem` (`sim-backend/fem/`).

pub mod bench;
pub mod detection_bound;
pub mod error;
pub mod family;
pub mod physics;
pub mod random;
pub mod rig;
pub mod runner;

pub mod scene;
pub mod search_scene;
pub mod trial;
pub mod trial_event;

pub use error::SimError;
