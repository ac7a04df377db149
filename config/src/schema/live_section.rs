//! The live view: `pulsetrackd` serving the Foxglove WebSocket protocol (docs/foxglove.md).
//!
//! The protocol has no authentication, so the server binds a loopback address unless the
//! file says `allow_remote: true` in so many words.

use std::net::IpAddr;

use serde::{Deserialize, Serialize};

use crate::validate::{Validate, Validator};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LiveSection {
    /// Serve the live view.
    pub enabled: bool,
    /// IP address to listen on (`127.0.0.1` or `::1`; anything else needs `allow_remote`).
    pub address: String,
    /// TCP port; 0 takes any free port (the log and `status` name the one taken).
    pub port: u16,
    /// Serve on a non-loopback address: anyone who can reach it sees the trial, unauthenticated.
    pub allow_remote: bool,
    /// Messages waiting between the supervisor and the publisher; more are dropped and counted.
    pub queue_messages: usize,
}

/// Foxglove's own default port, so that *Open connection* needs no edit.
pub const DEFAULT_LIVE_PORT: u16 = 8765;

impl Default for LiveSection {
    fn default() -> Self {
        Self {
            enabled: false,
            address: "127.0.0.1".to_string(),
            port: DEFAULT_LIVE_PORT,
            allow_remote: false,
            queue_messages: 4096,
        }
    }
}

impl LiveSection {
    /// The address to bind, if it parses.
    pub fn ip(&self) -> Option<IpAddr> {
        self.address.parse().ok()
    }
}

impl Validate for LiveSection {
    fn validate(&self, v: &mut Validator) {
        match self.ip() {
            None => v.problem(
                "address",
                format!(
                    "{:?} is not an IP address (for example \"127.0.0.1\" or \"::1\")",
                    self.address
                ),
            ),
            Some(ip) => v.check(
                ip.is_loopback() || self.allow_remote,
                "address",
                format!(
                    "{ip} is not a loopback address: the live view has no authentication, so \
                     anyone who reaches it sees the trial; set live.allow_remote: true to serve \
                     it there anyway"
                ),
            ),
        }
        v.check(
            (16..=1 << 20).contains(&self.queue_messages),
            "queue_messages",
            format!("must be 16 to 1048576, got {}", self.queue_messages),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::load_str;
    use crate::schema::Config;

    fn load(live: &str) -> Result<Config, String> {
        let text = format!(
            "Config(version: 1, backend: Sim((scene: \"seed-arc-145.ron\")), live: {live})"
        );
        load_str::<Config>("t.ron", &text).map_err(|e| e.to_string())
    }

    #[test]
    fn absent_section_is_off_on_loopback_at_the_default_port() {
        let c = load_str::<Config>(
            "t.ron",
            "Config(version: 1, backend: Sim((scene: \"seed-arc-145.ron\")))",
        )
        .expect("loads");
        assert_eq!(c.live, LiveSection::default());
        assert!(!c.live.enabled);
        assert_eq!(c.live.address, "127.0.0.1");
        assert_eq!(c.live.port, DEFAULT_LIVE_PORT);
    }

    #[test]
    fn loopback_addresses_are_accepted() {
        for a in ["127.0.0.1", "::1", "127.0.0.2"] {
            let c = load(&format!("(enabled: true, address: {a:?}, port: 0)"))
                .unwrap_or_else(|e| panic!("{a}: {e}"));
            assert_eq!(c.live.address, a);
        }
    }

    #[test]
    fn a_remote_address_is_refused_without_allow_remote_naming_the_field() {
        for a in ["0.0.0.0", "192.168.1.20", "::"] {
            let e = load(&format!("(enabled: true, address: {a:?})")).expect_err(a);
            assert!(e.contains("live.address"), "{e}");
            assert!(e.contains("allow_remote"), "{e}");
            // Off is no excuse: a file that would serve the network when switched on is refused.
            let e = load(&format!("(address: {a:?})")).expect_err(a);
            assert!(e.contains("live.address"), "{e}");
        }
        let c = load("(enabled: true, address: \"0.0.0.0\", allow_remote: true)").expect("loads");
        assert!(c.live.allow_remote);
    }

    #[test]
    fn bad_values_name_their_field() {
        let e = load("(address: \"localhost\")").expect_err("hostname");
        assert!(
            e.contains("live.address") && e.contains("not an IP address"),
            "{e}"
        );
        let e = load("(queue_messages: 1)").expect_err("tiny queue");
        assert!(e.contains("live.queue_messages"), "{e}");
        let e = load("(port: 70000)").expect_err("port");
        assert!(e.contains("port"), "{e}");
        let e = load("(enable: true)").expect_err("unknown field");
        assert!(e.contains("enable"), "{e}");
    }
}
