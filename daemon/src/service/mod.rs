//! Running as a service: logging, systemd notifications and the watchdog.

pub mod logging;
pub mod systemd;
