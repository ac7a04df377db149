//! Where the daemon keeps its socket and recordings when a configured path starts with
//! `{runtime}` or `{state}`: the systemd unit's own directories under systemd, the system
//! ones for root, and per-user ones otherwise, so that an unprivileged run never shares a
//! fixed folder under `/tmp` that any user could have made first.
//!
//! | placeholder | systemd | root | other users |
//! | --- | --- | --- | --- |
//! | `{runtime}` | `$RUNTIME_DIRECTORY` | `/run/pulsetrack` | `$XDG_RUNTIME_DIR/pulsetrack`, else `/tmp/pulsetrack-<uid>` |
//! | `{state}` | `$STATE_DIRECTORY` | `/var/lib/pulsetrack` | `$XDG_STATE_HOME/pulsetrack`, else `~/.local/state/pulsetrack`, else `/tmp/pulsetrack-<uid>/state` |
//!
//! Whatever the path, the daemon then insists that the directory is its own
//! ([`crate::private_fs`]).

use std::path::{Path, PathBuf};

/// The environment the resolution reads (a struct so tests need not touch the process's).
#[derive(Debug, Clone, Default)]
pub struct Env {
    pub uid: u32,
    pub runtime_directory: Option<String>,
    pub state_directory: Option<String>,
    pub xdg_runtime_dir: Option<String>,
    pub xdg_state_home: Option<String>,
    pub home: Option<String>,
}

impl Env {
    pub fn current() -> Self {
        let var = |k: &str| std::env::var(k).ok().filter(|v| !v.is_empty());
        Self {
            uid: nix::unistd::geteuid().as_raw(),
            runtime_directory: var("RUNTIME_DIRECTORY"),
            state_directory: var("STATE_DIRECTORY"),
            xdg_runtime_dir: var("XDG_RUNTIME_DIR"),
            xdg_state_home: var("XDG_STATE_HOME"),
            home: var("HOME"),
        }
    }

    pub fn runtime_dir(&self) -> PathBuf {
        if let Some(d) = first_absolute(self.runtime_directory.as_deref()) {
            return d;
        }
        if self.uid == 0 {
            return PathBuf::from("/run/pulsetrack");
        }
        if let Some(d) = first_absolute(self.xdg_runtime_dir.as_deref()) {
            return d.join("pulsetrack");
        }
        PathBuf::from(format!("/tmp/pulsetrack-{}", self.uid))
    }

    pub fn state_dir(&self) -> PathBuf {
        if let Some(d) = first_absolute(self.state_directory.as_deref()) {
            return d;
        }
        if self.uid == 0 {
            return PathBuf::from("/var/lib/pulsetrack");
        }
        if let Some(d) = first_absolute(self.xdg_state_home.as_deref()) {
            return d.join("pulsetrack");
        }
        if let Some(h) = first_absolute(self.home.as_deref()) {
            return h.join(".local/state/pulsetrack");
        }
        PathBuf::from(format!("/tmp/pulsetrack-{}/state", self.uid))
    }

    /// `{runtime}/x` and `{state}/x` resolved; any other path unchanged.
    pub fn expand(&self, raw: &str) -> PathBuf {
        if let Some(rest) = raw.strip_prefix("{runtime}") {
            return join_rest(self.runtime_dir(), rest);
        }
        if let Some(rest) = raw.strip_prefix("{state}") {
            return join_rest(self.state_dir(), rest);
        }
        PathBuf::from(raw)
    }
}

/// systemd passes a colon-separated list when a unit names several directories.
fn first_absolute(v: Option<&str>) -> Option<PathBuf> {
    let first = v?.split(':').next()?;
    let p = Path::new(first);
    p.is_absolute().then(|| p.to_path_buf())
}

fn join_rest(base: PathBuf, rest: &str) -> PathBuf {
    let rest = rest.trim_start_matches('/');
    if rest.is_empty() {
        base
    } else {
        base.join(rest)
    }
}

/// Resolve with the process's own environment.
pub fn expand(raw: &str) -> PathBuf {
    Env::current().expand(raw)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_kind_of_run_gets_its_own_directories() {
        let user = Env {
            uid: 1000,
            xdg_runtime_dir: Some("/run/user/1000".into()),
            home: Some("/home/ana".into()),
            ..Env::default()
        };
        assert_eq!(
            user.expand("{runtime}/console.sock"),
            PathBuf::from("/run/user/1000/pulsetrack/console.sock")
        );
        assert_eq!(
            user.expand("{state}/trials"),
            PathBuf::from("/home/ana/.local/state/pulsetrack/trials")
        );
        let bare = Env {
            uid: 1000,
            ..Env::default()
        };
        assert_eq!(
            bare.expand("{runtime}/console.sock"),
            PathBuf::from("/tmp/pulsetrack-1000/console.sock")
        );
        let root = Env::default();
        assert_eq!(
            root.expand("{runtime}/console.sock"),
            PathBuf::from("/run/pulsetrack/console.sock")
        );
        assert_eq!(root.expand("{state}"), PathBuf::from("/var/lib/pulsetrack"));
        let unit = Env {
            uid: 998,
            runtime_directory: Some("/run/pulsetrack:/run/other".into()),
            state_directory: Some("/var/lib/pulsetrack".into()),
            ..Env::default()
        };
        assert_eq!(
            unit.expand("{runtime}/console.sock"),
            PathBuf::from("/run/pulsetrack/console.sock")
        );
        // A relative XDG value is ignored, as the XDG spec says.
        let odd = Env {
            uid: 7,
            xdg_runtime_dir: Some("relative".into()),
            ..Env::default()
        };
        assert_eq!(odd.runtime_dir(), PathBuf::from("/tmp/pulsetrack-7"));
        assert_eq!(
            root.expand("/srv/x/console.sock"),
            PathBuf::from("/srv/x/console.sock")
        );
    }
}
