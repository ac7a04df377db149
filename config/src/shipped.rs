//! Files that ship with pulsetrack, embedded so that binaries run with none on disk.

/// The default configuration: the simulated bench, no hardware needed.
pub const SIM_CONFIG: (&str, &str) = ("sim.ron", include_str!("../sim.ron"));

/// The configuration of the real rig.
pub const LAB_CONFIG: (&str, &str) = ("lab.ron", include_str!("../lab.ron"));

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Config, load_str};

    #[test]
    fn shipped_configs_load() {
        for (name, text) in [SIM_CONFIG, LAB_CONFIG] {
            let c: Config = load_str(name, text).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(c.version, 1);
        }
    }
}
