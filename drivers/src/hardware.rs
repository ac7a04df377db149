//! Opening the real rig from the daemon's configuration: both ports in one call.

use std::sync::Arc;

use config::schema::{CanAdapter as CanAdapterConfig, HardwareBackend};

use crate::can::slcan::SlcanAdapter;
use crate::can::socketcan_adapter::SocketCanAdapter;
use crate::can::{CanAdapter, PhantomCan};
use crate::clock::Clock;
use crate::tactile::{SerialTactileArray, TactileError};

/// The arm on whichever CAN adapter the configuration names.
pub type HardwareArm = PhantomCan<Box<dyn CanAdapter>>;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HardwareError {
    #[error("joints: {0}")]
    Can(String),
    #[error("tactile: {0}")]
    Tactile(#[from] TactileError),
}

/// Open the CAN adapter named by the configuration.
pub fn open_can_adapter(adapter: &CanAdapterConfig) -> Result<Box<dyn CanAdapter>, String> {
    Ok(match adapter {
        CanAdapterConfig::SocketCan { interface } => Box::new(SocketCanAdapter::open(interface)?),
        CanAdapterConfig::Slcan {
            path,
            baud,
            bitrate_bps,
        } => Box::new(SlcanAdapter::open(path, *baud, *bitrate_bps)?),
    })
}

/// Open the arm (CAN) and start the tactile array's serial task on `runtime`.
///
/// The arm must be reachable now (its adapter opens or this fails with a message saying
/// what to do); the tactile array may appear later (its task keeps retrying).
pub fn open(
    hw: &HardwareBackend,
    sample_rate_hz: f64,
    runtime: &tokio::runtime::Handle,
    clock: Arc<dyn Clock>,
) -> Result<(HardwareArm, SerialTactileArray), HardwareError> {
    let adapter = open_can_adapter(&hw.joints.adapter).map_err(HardwareError::Can)?;
    let arm = PhantomCan::new(adapter, &hw.joints, clock.clone());
    let tactile = SerialTactileArray::spawn(runtime, &hw.tactile, sample_rate_hz, clock)?;
    Ok((arm, tactile))
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_emulated_lab_config_loads() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/lab-emulated.ron");
        let c = config::load_file::<config::Config>(&path).unwrap_or_else(|e| panic!("{e}"));
        let config::schema::Backend::Hardware(hw) = c.value.backend else {
            panic!("selects hardware")
        };
        assert_eq!(hw.tactile.path, "/tmp/pulsetrack-tactile");
        assert!(matches!(
            hw.joints.adapter,
            config::schema::CanAdapter::Slcan { ref path, .. } if path == "/tmp/pulsetrack-slcan"
        ));
    }
}
