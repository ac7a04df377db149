//! Running as a service: logging, systemd notifications and the watchdog.

pub mod log_forward;
pub mod logging;
pub mod systemd;
