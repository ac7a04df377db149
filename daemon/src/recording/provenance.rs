//! What a trial recording says about where it came from, as MCAP metadata records: the
//! fully resolved configuration (every gain, limit and tracker parameter, not just a path),
//! the simulated scene, the build, and the host. A trial file is then enough on its own to
//! know what ran, and to replay it offline with the same tracker settings.

use std::collections::BTreeMap;

use crate::pulsetrackd::LoadedConfig;

/// A named MCAP metadata record.
pub type MetadataRecord = (String, BTreeMap<String, String>);

/// The build: crate version and the git commit it was built from (build.rs).
pub fn build_record() -> MetadataRecord {
    let mut m = BTreeMap::new();
    m.insert("version".to_string(), env!("CARGO_PKG_VERSION").to_string());
    m.insert("commit".to_string(), env!("PULSETRACK_COMMIT").to_string());
    m.insert(
        "profile".to_string(),
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        }
        .to_string(),
    );
    ("build".to_string(), m)
}

/// The host: name, OS and architecture.
pub fn host_record() -> MetadataRecord {
    let mut m = BTreeMap::new();
    let hostname = nix::unistd::gethostname()
        .ok()
        .and_then(|h| h.into_string().ok())
        .unwrap_or_else(|| "unknown".into());
    m.insert("hostname".to_string(), hostname);
    m.insert("os".to_string(), std::env::consts::OS.to_string());
    m.insert("arch".to_string(), std::env::consts::ARCH.to_string());
    ("host".to_string(), m)
}

/// The configuration as the daemon resolved and validated it, as JSON, and where it came
/// from.
pub fn config_record(loaded: &LoadedConfig) -> MetadataRecord {
    let mut m = BTreeMap::new();
    m.insert("origin".to_string(), loaded.origin.clone());
    let json = serde_json::to_string(&loaded.config)
        .unwrap_or_else(|e| format!("{{\"error\": \"not serializable: {e}\"}}"));
    m.insert("json".to_string(), json);
    ("config".to_string(), m)
}

/// The simulated scene (sim backend only; `None` on the rig or if it cannot be read again).
pub fn scene_record(loaded: &LoadedConfig) -> Option<MetadataRecord> {
    let config::schema::Backend::Sim(s) = &loaded.config.backend else {
        return None;
    };
    let scene = match sim::scene::load(&s.scene, loaded.dir.as_deref()) {
        Ok(scene) => scene,
        Err(e) => {
            tracing::warn!("the scene will not be in trial metadata: {e}");
            return None;
        }
    };
    let mut m = BTreeMap::new();
    m.insert("name".to_string(), scene.name.clone());
    m.insert("source".to_string(), s.scene.clone());
    m.insert("seed".to_string(), s.seed.to_string());
    m.insert("time_scale".to_string(), s.time_scale.to_string());
    m.insert(
        "json".to_string(),
        serde_json::to_string(&scene).unwrap_or_default(),
    );
    Some(("scene".to_string(), m))
}

/// Every record that is the same for all trials of this daemon run.
pub fn static_records(loaded: &LoadedConfig) -> Vec<MetadataRecord> {
    let mut v = vec![config_record(loaded)];
    v.extend(scene_record(loaded));
    v.push(build_record());
    v.push(host_record());
    v
}
