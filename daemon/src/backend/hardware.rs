//! The real rig behind the daemon's ports (`backend: Hardware(...)`): the Phantom's joints
//! over CAN and the tactile array over serial (drivers/), stamped with CLOCK_MONOTONIC
//! seconds since the daemon started, the clock the loop runs on.

use std::sync::Arc;

use control::ports::{Manipulator, TactileArray};
use control::types::{JointState, JointTorques, TactileFrame};

use crate::backend::{ArmPort, Backend, BackendInfo, OpenError, PortError, TactilePort};

struct ArmOnBus<M> {
    arm: M,
    clock: Arc<dyn drivers::clock::Clock>,
}

fn port_err(e: impl std::fmt::Display) -> PortError {
    PortError(e.to_string())
}

impl<M: Manipulator + Send> ArmPort for ArmOnBus<M> {
    fn enable(&mut self) -> Result<(), PortError> {
        self.arm.enable().map_err(port_err)
    }
    fn disable(&mut self) -> Result<(), PortError> {
        self.arm.disable().map_err(port_err)
    }
    fn read_joints(&mut self) -> Result<JointState, PortError> {
        self.arm.read_joints().map_err(port_err)
    }
    fn write_torques(&mut self, torques: &JointTorques) -> Result<(), PortError> {
        self.arm.write_torques(torques).map_err(port_err)
    }
    fn recover(&mut self) -> Result<(), PortError> {
        self.arm.recover().map_err(port_err)
    }
    fn now_s(&self) -> f64 {
        self.clock.now_s()
    }
}

struct ArrayOnSerial<T>(T);

impl<T: TactileArray + Send> TactilePort for ArrayOnSerial<T> {
    fn poll_frame(&mut self) -> Result<Option<TactileFrame>, PortError> {
        self.0.poll_frame().map_err(port_err)
    }
}

pub fn open(
    config: &config::Config,
    hw: &config::schema::HardwareBackend,
    runtime: &tokio::runtime::Handle,
) -> Result<Backend, OpenError> {
    let clock: Arc<dyn drivers::clock::Clock> = Arc::new(drivers::clock::MonotonicClock::new());
    let (arm, tactile) = drivers::hardware::open(
        hw,
        config.sensor.sample_rate_hz,
        runtime,
        Arc::clone(&clock),
    )
    .map_err(|e| OpenError::Backend(e.to_string()))?;
    Ok(Backend {
        arm: Box::new(ArmOnBus { arm, clock }),
        tactile: Box::new(ArrayOnSerial(tactile)),
        info: BackendInfo {
            kind: "hardware",
            time_scale: 1.0,
            wall_clock_bound: true,
            scene: None,
        },
        judge: None,
        array_bench: None,
    })
}
