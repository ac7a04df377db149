//! The simulated bench: it implements control's ports with physics, so the daemon and the
//! trackers run unchanged without hardware.

pub mod fem;
