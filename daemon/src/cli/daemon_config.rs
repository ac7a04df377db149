//! Which daemon a console verb talks to when no `--config` names one: the daemon the shipped
//! systemd unit starts (daemon/systemd/pulsetrackd.service: `--config /etc/pulsetrack/lab.ron`,
//! `RuntimeDirectory=pulsetrack`) when that config is installed, else the daemon started by
//! hand without `--config` (the embedded simulated bench, sockets under this user's runtime
//! directory). A test reads the unit file so that these constants follow it.

use std::path::Path;

use crate::pulsetrackd::LoadedConfig;
use crate::runtime_paths::Env;

/// The config the shipped unit passes to `pulsetrackd --config`.
pub const UNIT_CONFIG: &str = "/etc/pulsetrack/lab.ron";
/// `/run/` + the unit's `RuntimeDirectory` (systemd's `$RUNTIME_DIRECTORY` for the daemon).
pub const UNIT_RUNTIME_DIR: &str = "/run/pulsetrack";
/// `/var/lib/` + the unit's `StateDirectory`.
pub const UNIT_STATE_DIR: &str = "/var/lib/pulsetrack";

/// The daemon config to read the socket and the daemon's user from: `explicit` if given,
/// else `unit_config` if that file exists (paths resolved as the unit's daemon resolves
/// them, not as this user would), else the embedded default.
pub fn load(explicit: Option<&Path>, unit_config: &Path) -> Result<LoadedConfig, String> {
    if explicit.is_none() && unit_config.exists() {
        return load_as_unit(unit_config);
    }
    LoadedConfig::load(explicit).map_err(|e| e.to_string())
}

/// `path` with `{runtime}` and `{state}` expanded as under the shipped unit.
pub fn load_as_unit(path: &Path) -> Result<LoadedConfig, String> {
    let mut l = LoadedConfig::load_unexpanded(Some(path)).map_err(|e| e.to_string())?;
    let unit = Env {
        uid: u32::MAX,
        runtime_directory: Some(UNIT_RUNTIME_DIR.into()),
        state_directory: Some(UNIT_STATE_DIR.into()),
        ..Env::default()
    };
    let c = &mut l.config;
    c.console.socket_path = unit.expand(&c.console.socket_path).display().to_string();
    c.recording.dir = unit.expand(&c.recording.dir).display().to_string();
    Ok(l)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn repo(path: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
    }

    /// The value of `Key=` in the unit's text (the last one, as systemd reads it).
    fn unit_value<'a>(unit: &'a str, key: &str) -> &'a str {
        unit.lines()
            .filter_map(|l| l.trim().strip_prefix(key)?.strip_prefix('='))
            .next_back()
            .unwrap_or_else(|| panic!("the unit has no {key}="))
    }

    #[test]
    fn the_default_socket_is_the_one_the_shipped_unit_gives_the_daemon() {
        let unit = std::fs::read_to_string(repo("daemon/systemd/pulsetrackd.service"))
            .expect("the unit file is in the repository");
        // The config the unit starts the daemon with, and the repository file installed there.
        let exec = unit_value(&unit, "ExecStart");
        let config = exec
            .split_whitespace()
            .skip_while(|w| *w != "--config")
            .nth(1)
            .unwrap_or_else(|| panic!("ExecStart has no --config: {exec}"));
        assert_eq!(config, UNIT_CONFIG);
        assert!(
            unit.contains(&format!("config/lab.ron {UNIT_CONFIG}")),
            "the unit's install notes put config/lab.ron at {UNIT_CONFIG}"
        );
        let runtime = format!("/run/{}", unit_value(&unit, "RuntimeDirectory"));
        assert_eq!(runtime, UNIT_RUNTIME_DIR);
        let state = format!("/var/lib/{}", unit_value(&unit, "StateDirectory"));
        assert_eq!(state, UNIT_STATE_DIR);
        // What the daemon under the unit binds: systemd sets $RUNTIME_DIRECTORY and the
        // daemon runs as a system user.
        let shipped = repo("config/lab.ron");
        let raw = LoadedConfig::load_unexpanded(Some(&shipped)).expect("lab.ron loads");
        let daemon_env = Env {
            uid: 998,
            runtime_directory: Some(runtime.clone()),
            state_directory: Some(state),
            ..Env::default()
        };
        let bound = daemon_env.expand(&raw.config.console.socket_path);
        assert!(bound.starts_with(&runtime), "{}", bound.display());
        // What the command line picks with that file installed and no --config.
        let picked = load(None, &shipped).expect("loads");
        assert_eq!(PathBuf::from(picked.config.console.socket_path), bound);
        assert!(picked.config.console.daemon_user.is_some());
    }

    #[test]
    fn a_placeholder_resolves_as_under_the_unit_for_every_user() {
        let dir = tempfile::tempdir().expect("tmp");
        let text = std::fs::read_to_string(repo("config/lab.ron")).expect("lab.ron");
        let moved = text.replace(
            "\"/run/pulsetrack/console.sock\"",
            "\"{runtime}/console.sock\"",
        );
        assert_ne!(moved, text, "lab.ron names its socket");
        let file = dir.path().join("lab.ron");
        std::fs::write(&file, moved).expect("write");
        let l = load(None, &file).expect("loads");
        assert_eq!(
            l.config.console.socket_path,
            format!("{UNIT_RUNTIME_DIR}/console.sock")
        );
    }

    #[test]
    fn without_the_unit_config_or_with_an_explicit_one_the_unit_is_not_used() {
        let dir = tempfile::tempdir().expect("tmp");
        let absent = dir.path().join("absent.ron");
        let embedded = load(None, &absent).expect("embedded");
        assert!(embedded.origin.contains("embedded"), "{}", embedded.origin);
        let shipped = repo("config/lab.ron");
        let sim = repo("config/sim.ron");
        let explicit = load(Some(&sim), &shipped).expect("explicit");
        assert!(explicit.origin.contains("sim.ron"), "{}", explicit.origin);
        // A broken installed config is reported, not silently passed over.
        let broken = dir.path().join("broken.ron");
        std::fs::write(&broken, "(console: (").expect("write");
        let e = load(None, &broken).expect_err("broken");
        assert!(e.contains("broken.ron"), "{e}");
    }
}
