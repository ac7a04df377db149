//! The Phantom joint amplifiers' CAN messages (docs/protocols/phantom-can.md).
//!
//! CANopen-style identifiers: function code plus node id. Multi-byte fields little-endian.
//!
//! | id          | from | message        | bytes                                               |
//! |-------------|------|----------------|-----------------------------------------------------|
//! | 0x000       | host | control        | command u8, node u8 (0 = every amplifier)           |
//! | 0x080 + n   | amp  | emergency      | code u16, error register u8, state u8, detail [4]   |
//! | 0x180 + n   | amp  | feedback       | counts i32, amp time µs u16, status u8, seq u8      |
//! | 0x200 + n   | host | torque command | motor torque i16 (10 µN·m), seq u8, reserved u8 (0) |
//! | 0x700 + n   | both | heartbeat      | state u8, error register u8                         |

use super::frame::DataFrame;

pub const CONTROL_ID: u16 = 0x000;
pub const EMERGENCY_BASE: u16 = 0x080;
pub const FEEDBACK_BASE: u16 = 0x180;
pub const TORQUE_BASE: u16 = 0x200;
pub const HEARTBEAT_BASE: u16 = 0x700;

/// Motor torque of one command count, N·m (i16 spans ±0.32767 N·m).
pub const NM_PER_TORQUE_COUNT: f64 = 1.0e-5;

/// Feedback status bits.
pub mod status {
    pub const ENABLED: u8 = 0x01;
    pub const FAULT: u8 = 0x02;
    /// The e-stop input is open.
    pub const ESTOP: u8 = 0x04;
    pub const OVER_TEMPERATURE: u8 = 0x08;
    /// The last command exceeded the amplifier's own limit and was clipped.
    pub const TORQUE_LIMITED: u8 = 0x10;
    pub const DEFINED: u8 = 0x1F;
}

/// An amplifier's (or the host's) operating state, as sent in heartbeats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NodeState {
    Boot = 0,
    Disabled = 1,
    Enabled = 2,
    Fault = 3,
}

impl NodeState {
    fn from_byte(b: u8) -> Option<Self> {
        Some(match b {
            0 => Self::Boot,
            1 => Self::Disabled,
            2 => Self::Enabled,
            3 => Self::Fault,
            _ => return None,
        })
    }
}

/// Host commands on the control id.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ControlCommand {
    Enable = 0x01,
    Disable = 0x02,
    /// Clear latched amplifier faults (they stay disabled).
    ClearFault = 0x81,
}

impl ControlCommand {
    fn from_byte(b: u8) -> Option<Self> {
        Some(match b {
            0x01 => Self::Enable,
            0x02 => Self::Disable,
            0x81 => Self::ClearFault,
            _ => return None,
        })
    }
}

/// Everything on the bus this system speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Message {
    Control {
        command: ControlCommand,
        /// 0 addresses every amplifier.
        node: u8,
    },
    Emergency {
        node: u8,
        code: u16,
        error_register: u8,
        state: NodeState,
        detail: [u8; 4],
    },
    Feedback {
        node: u8,
        counts: i32,
        amp_time_us: u16,
        status: u8,
        seq: u8,
    },
    Torque {
        node: u8,
        /// Motor torque in units of [`NM_PER_TORQUE_COUNT`].
        torque: i16,
        seq: u8,
    },
    Heartbeat {
        node: u8,
        state: NodeState,
        error_register: u8,
    },
}

/// A frame on one of the protocol's identifiers that does not hold a valid message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    #[error("id {id:#05x}: {len} data bytes, expected {expected}")]
    BadLength {
        id: u16,
        len: usize,
        expected: usize,
    },
    #[error("id {id:#05x}: node id 0 is not a node")]
    NodeZero { id: u16 },
    #[error("id {id:#05x}: {field} {value:#04x} is not defined")]
    BadValue {
        id: u16,
        field: &'static str,
        value: u8,
    },
}

fn node_id(node: u8) -> u16 {
    u16::from(node & 0x7F)
}

impl Message {
    /// The frame carrying this message. Node ids are taken modulo 128.
    pub fn encode(&self) -> DataFrame {
        let (id, bytes): (u16, heapless_bytes::Bytes) = match *self {
            Message::Control { command, node } => (CONTROL_ID, [command as u8, node].into()),
            Message::Emergency {
                node,
                code,
                error_register,
                state,
                detail,
            } => {
                let c = code.to_le_bytes();
                (
                    EMERGENCY_BASE + node_id(node),
                    [
                        c[0],
                        c[1],
                        error_register,
                        state as u8,
                        detail[0],
                        detail[1],
                        detail[2],
                        detail[3],
                    ]
                    .into(),
                )
            }
            Message::Feedback {
                node,
                counts,
                amp_time_us,
                status,
                seq,
            } => {
                let c = counts.to_le_bytes();
                let t = amp_time_us.to_le_bytes();
                (
                    FEEDBACK_BASE + node_id(node),
                    [c[0], c[1], c[2], c[3], t[0], t[1], status, seq].into(),
                )
            }
            Message::Torque { node, torque, seq } => {
                let t = torque.to_le_bytes();
                (TORQUE_BASE + node_id(node), [t[0], t[1], seq, 0].into())
            }
            Message::Heartbeat {
                node,
                state,
                error_register,
            } => (
                HEARTBEAT_BASE + node_id(node),
                [state as u8, error_register].into(),
            ),
        };
        DataFrame::new(id, bytes.as_slice())
            .expect("protocol ids are at most 0x77F and payloads at most 8 bytes")
    }

    /// The message in a frame: `Ok(None)` for an identifier outside the protocol.
    pub fn decode(frame: &DataFrame) -> Result<Option<Self>, DecodeError> {
        let id = frame.id();
        let d = frame.data();
        let want = |expected: usize| {
            if d.len() == expected {
                Ok(())
            } else {
                Err(DecodeError::BadLength {
                    id,
                    len: d.len(),
                    expected,
                })
            }
        };
        let node = (id & 0x7F) as u8;
        let function = id & !0x7F;
        if id != CONTROL_ID && node == 0 && matches!(function, 0x080 | 0x180 | 0x200 | 0x700) {
            return Err(DecodeError::NodeZero { id });
        }
        let bad = |field, value| DecodeError::BadValue { id, field, value };
        let msg = match function {
            CONTROL_ID if id == CONTROL_ID => {
                want(2)?;
                Message::Control {
                    command: ControlCommand::from_byte(d[0]).ok_or(bad("command", d[0]))?,
                    node: d[1],
                }
            }
            EMERGENCY_BASE => {
                want(8)?;
                Message::Emergency {
                    node,
                    code: u16::from_le_bytes([d[0], d[1]]),
                    error_register: d[2],
                    state: NodeState::from_byte(d[3]).ok_or(bad("state", d[3]))?,
                    detail: [d[4], d[5], d[6], d[7]],
                }
            }
            FEEDBACK_BASE => {
                want(8)?;
                if d[6] & !status::DEFINED != 0 {
                    return Err(bad("status", d[6]));
                }
                Message::Feedback {
                    node,
                    counts: i32::from_le_bytes([d[0], d[1], d[2], d[3]]),
                    amp_time_us: u16::from_le_bytes([d[4], d[5]]),
                    status: d[6],
                    seq: d[7],
                }
            }
            TORQUE_BASE => {
                want(4)?;
                if d[3] != 0 {
                    return Err(bad("reserved", d[3]));
                }
                Message::Torque {
                    node,
                    torque: i16::from_le_bytes([d[0], d[1]]),
                    seq: d[2],
                }
            }
            HEARTBEAT_BASE => {
                want(2)?;
                Message::Heartbeat {
                    node,
                    state: NodeState::from_byte(d[0]).ok_or(bad("state", d[0]))?,
                    error_register: d[1],
                }
            }
            _ => return Ok(None),
        };
        Ok(Some(msg))
    }
}

/// A fixed-capacity byte list for building payloads without allocating.
mod heapless_bytes {
    pub struct Bytes {
        buf: [u8; 8],
        len: usize,
    }

    impl Bytes {
        pub fn as_slice(&self) -> &[u8] {
            &self.buf[..self.len]
        }
    }

    impl<const N: usize> From<[u8; N]> for Bytes {
        fn from(a: [u8; N]) -> Self {
            let mut buf = [0u8; 8];
            let len = N.min(8);
            buf[..len].copy_from_slice(&a[..len]);
            Bytes { buf, len }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn feedback_layout_is_as_documented() {
        let m = Message::Feedback {
            node: 2,
            counts: -2,
            amp_time_us: 0x1234,
            status: status::ENABLED | status::TORQUE_LIMITED,
            seq: 7,
        };
        let f = m.encode();
        assert_eq!(f.id(), 0x182);
        assert_eq!(f.data(), &[0xFE, 0xFF, 0xFF, 0xFF, 0x34, 0x12, 0x11, 7]);
        assert_eq!(Message::decode(&f), Ok(Some(m)));
    }

    #[test]
    fn bad_frames_on_protocol_ids_are_named() {
        let short = DataFrame::new(0x181, &[1, 2, 3]).expect("frame");
        assert_eq!(
            Message::decode(&short),
            Err(DecodeError::BadLength {
                id: 0x181,
                len: 3,
                expected: 8
            })
        );
        let hb = DataFrame::new(0x703, &[9, 0]).expect("frame");
        assert_eq!(
            Message::decode(&hb),
            Err(DecodeError::BadValue {
                id: 0x703,
                field: "state",
                value: 9
            })
        );
        let status = DataFrame::new(0x181, &[0, 0, 0, 0, 0, 0, 0x80, 0]).expect("frame");
        assert!(matches!(
            Message::decode(&status),
            Err(DecodeError::BadValue {
                field: "status",
                ..
            })
        ));
        let zero = DataFrame::new(0x180, &[0; 8]).expect("frame");
        assert_eq!(
            Message::decode(&zero),
            Err(DecodeError::NodeZero { id: 0x180 })
        );
        let foreign = DataFrame::new(0x4A1, &[1]).expect("frame");
        assert_eq!(Message::decode(&foreign), Ok(None));
    }

    fn any_state() -> impl Strategy<Value = NodeState> {
        prop_oneof![
            Just(NodeState::Boot),
            Just(NodeState::Disabled),
            Just(NodeState::Enabled),
            Just(NodeState::Fault)
        ]
    }

    fn any_message() -> impl Strategy<Value = Message> {
        let node = 1u8..=127;
        prop_oneof![
            (
                prop_oneof![
                    Just(ControlCommand::Enable),
                    Just(ControlCommand::Disable),
                    Just(ControlCommand::ClearFault)
                ],
                any::<u8>()
            )
                .prop_map(|(command, node)| Message::Control { command, node }),
            (
                node.clone(),
                any::<u16>(),
                any::<u8>(),
                any_state(),
                any::<[u8; 4]>()
            )
                .prop_map(|(node, code, error_register, state, detail)| {
                    Message::Emergency {
                        node,
                        code,
                        error_register,
                        state,
                        detail,
                    }
                }),
            (
                node.clone(),
                any::<i32>(),
                any::<u16>(),
                0u8..=status::DEFINED,
                any::<u8>()
            )
                .prop_map(|(node, counts, amp_time_us, status, seq)| {
                    Message::Feedback {
                        node,
                        counts,
                        amp_time_us,
                        status,
                        seq,
                    }
                }),
            (node.clone(), any::<i16>(), any::<u8>())
                .prop_map(|(node, torque, seq)| Message::Torque { node, torque, seq }),
            (node, any_state(), any::<u8>()).prop_map(|(node, state, error_register)| {
                Message::Heartbeat {
                    node,
                    state,
                    error_register,
                }
            }),
        ]
    }

    proptest! {
        #[test]
        fn round_trip(m in any_message()) {
            prop_assert_eq!(Message::decode(&m.encode()), Ok(Some(m)));
        }

        #[test]
        fn arbitrary_frames_never_panic(id in 0u16..=0x7FF, data in proptest::collection::vec(any::<u8>(), 0..=8)) {
            let f = DataFrame::new(id, &data).expect("valid classic frame");
            if let Ok(Some(m)) = Message::decode(&f) {
                // Whatever decodes re-encodes to the same frame.
                prop_assert_eq!(m.encode(), f);
            }
        }
    }
}
