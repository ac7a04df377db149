//! The tactile array's messages and their byte layout (docs/protocols/tactile-serial.md).
//!
//! A message on the wire is `COBS(type, body, crc16_le(type, body))` followed by one 0x00.
//! Multi-byte fields are little-endian. This module converts between messages and the
//! unstuffed bytes; [`super::decoder`] does the framing.

use super::cobs;
use super::crc::crc16;

/// Protocol version this build speaks (carried in [`DeviceInfo::protocol_version`]).
pub const PROTOCOL_VERSION: u8 = 1;

/// Force of one raw count, N (1 count = 0.1 mN; i16 spans about ±3.28 N).
pub const NEWTONS_PER_COUNT: f64 = 1.0e-4;

/// The raw value a device sends for an element it cannot measure (saturated, open, faulty).
pub const ELEMENT_FAULT: i16 = i16::MIN;

/// Most channels one force message may carry.
pub const MAX_CHANNELS: usize = 32;

/// Longest unstuffed message: a force message with [`MAX_CHANNELS`] channels.
pub const MAX_MESSAGE_LEN: usize = 1 + FORCES_HEADER_LEN + 2 * MAX_CHANNELS + 2;

/// Longest stuffed message, without its delimiter.
pub const MAX_ENCODED_LEN: usize = MAX_MESSAGE_LEN + MAX_MESSAGE_LEN / 254 + 1;

const FORCES_HEADER_LEN: usize = 4 + 4 + 1;
const DEVICE_INFO_BODY_LEN: usize = 1 + 3 + 1 + 2 + 4;
const CONFIGURE_BODY_LEN: usize = 2 + 1;

/// Message type bytes.
pub mod kind {
    pub const FORCES: u8 = 0x01;
    pub const DEVICE_INFO: u8 = 0x02;
    pub const CONFIGURE: u8 = 0x10;
}

/// One sample of every channel, device to host.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Forces {
    /// Increments by one per sample and wraps; gaps reveal lost frames.
    pub seq: u32,
    /// Device clock at the sample, µs, wrapping.
    pub device_time_us: u32,
    channels: [i16; MAX_CHANNELS],
    count: u8,
}

impl Forces {
    /// A force message; `None` if there are more than [`MAX_CHANNELS`] channels.
    pub fn new(seq: u32, device_time_us: u32, counts: &[i16]) -> Option<Self> {
        let mut channels = [0i16; MAX_CHANNELS];
        channels.get_mut(..counts.len())?.copy_from_slice(counts);
        Some(Self {
            seq,
            device_time_us,
            channels,
            count: u8::try_from(counts.len()).ok()?,
        })
    }

    /// Raw channel values, element 0 first.
    pub fn counts(&self) -> &[i16] {
        &self.channels[..usize::from(self.count)]
    }
}

/// What the device is and how it is streaming: sent at power-up and in answer to every
/// [`Configure`], device to host.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DeviceInfo {
    pub protocol_version: u8,
    pub firmware: [u8; 3],
    pub channels: u8,
    /// Streaming rate now in effect, Hz; 0 when not streaming.
    pub rate_hz: u16,
    pub serial_number: u32,
}

/// Host to device: start or stop streaming at a rate. The device answers with a
/// [`DeviceInfo`] that states the rate it applied.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Configure {
    pub rate_hz: u16,
    pub streaming: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Message {
    Forces(Forces),
    DeviceInfo(DeviceInfo),
    Configure(Configure),
}

/// Why an unstuffed message was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum WireError {
    #[error("bad framing: {0}")]
    Cobs(#[from] cobs::CobsError),
    #[error("frame longer than {max} bytes")]
    Oversize { max: usize },
    #[error("frame too short ({len} bytes) to hold a type and a CRC")]
    TooShort { len: usize },
    #[error("CRC mismatch: frame says {carried:#06x}, bytes give {computed:#06x}")]
    BadCrc { carried: u16, computed: u16 },
    #[error("unknown message type {0:#04x}")]
    UnknownType(u8),
    #[error("message type {kind:#04x} with a {len}-byte body, expected {expected}")]
    BadLength {
        kind: u8,
        len: usize,
        expected: usize,
    },
    #[error("force message claims {0} channels, more than the protocol's 32")]
    TooManyChannels(u8),
    #[error("configure message with streaming flag {0}, expected 0 or 1")]
    BadFlag(u8),
}

impl Message {
    /// The unstuffed bytes: type, body and CRC.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(MAX_MESSAGE_LEN);
        match self {
            Message::Forces(f) => {
                out.push(kind::FORCES);
                out.extend_from_slice(&f.seq.to_le_bytes());
                out.extend_from_slice(&f.device_time_us.to_le_bytes());
                out.push(f.count);
                for c in f.counts() {
                    out.extend_from_slice(&c.to_le_bytes());
                }
            }
            Message::DeviceInfo(d) => {
                out.push(kind::DEVICE_INFO);
                out.push(d.protocol_version);
                out.extend_from_slice(&d.firmware);
                out.push(d.channels);
                out.extend_from_slice(&d.rate_hz.to_le_bytes());
                out.extend_from_slice(&d.serial_number.to_le_bytes());
            }
            Message::Configure(c) => {
                out.push(kind::CONFIGURE);
                out.extend_from_slice(&c.rate_hz.to_le_bytes());
                out.push(u8::from(c.streaming));
            }
        }
        let crc = crc16(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        out
    }

    /// The bytes as sent on the wire: stuffed, with the 0x00 delimiter. A leading delimiter
    /// too, so that a receiver holding garbage from before ends it there.
    pub fn to_wire(&self) -> Vec<u8> {
        let raw = self.to_bytes();
        let mut out = Vec::with_capacity(raw.len() + 3);
        out.push(0);
        cobs::encode_into(&raw, &mut out);
        out.push(0);
        out
    }

    /// Parse unstuffed bytes (type, body, CRC).
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, WireError> {
        if bytes.len() > MAX_MESSAGE_LEN {
            return Err(WireError::Oversize {
                max: MAX_MESSAGE_LEN,
            });
        }
        let Some((crc_bytes, covered)) = bytes
            .len()
            .checked_sub(2)
            .filter(|&n| n >= 1)
            .map(|n| (&bytes[n..], &bytes[..n]))
        else {
            return Err(WireError::TooShort { len: bytes.len() });
        };
        let carried = u16::from_le_bytes([crc_bytes[0], crc_bytes[1]]);
        let computed = crc16(covered);
        if carried != computed {
            return Err(WireError::BadCrc { carried, computed });
        }
        let (kind_byte, body) = (covered[0], &covered[1..]);
        let expect_len = |expected: usize| {
            if body.len() == expected {
                Ok(())
            } else {
                Err(WireError::BadLength {
                    kind: kind_byte,
                    len: body.len(),
                    expected,
                })
            }
        };
        match kind_byte {
            kind::FORCES => {
                let Some(header) = body.get(..FORCES_HEADER_LEN) else {
                    return Err(WireError::BadLength {
                        kind: kind_byte,
                        len: body.len(),
                        expected: FORCES_HEADER_LEN,
                    });
                };
                let count = header[8];
                if usize::from(count) > MAX_CHANNELS {
                    return Err(WireError::TooManyChannels(count));
                }
                expect_len(FORCES_HEADER_LEN + 2 * usize::from(count))?;
                let mut channels = [0i16; MAX_CHANNELS];
                for (slot, pair) in channels
                    .iter_mut()
                    .zip(body[FORCES_HEADER_LEN..].chunks_exact(2))
                {
                    *slot = i16::from_le_bytes([pair[0], pair[1]]);
                }
                Ok(Message::Forces(Forces {
                    seq: u32::from_le_bytes([header[0], header[1], header[2], header[3]]),
                    device_time_us: u32::from_le_bytes([
                        header[4], header[5], header[6], header[7],
                    ]),
                    channels,
                    count,
                }))
            }
            kind::DEVICE_INFO => {
                expect_len(DEVICE_INFO_BODY_LEN)?;
                Ok(Message::DeviceInfo(DeviceInfo {
                    protocol_version: body[0],
                    firmware: [body[1], body[2], body[3]],
                    channels: body[4],
                    rate_hz: u16::from_le_bytes([body[5], body[6]]),
                    serial_number: u32::from_le_bytes([body[7], body[8], body[9], body[10]]),
                }))
            }
            kind::CONFIGURE => {
                expect_len(CONFIGURE_BODY_LEN)?;
                let streaming = match body[2] {
                    0 => false,
                    1 => true,
                    other => return Err(WireError::BadFlag(other)),
                };
                Ok(Message::Configure(Configure {
                    rate_hz: u16::from_le_bytes([body[0], body[1]]),
                    streaming,
                }))
            }
            other => Err(WireError::UnknownType(other)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn force_message_layout_is_as_documented() {
        let f = Forces::new(0x0403_0201, 0x0807_0605, &[1, -1]).expect("2 channels fit");
        let bytes = Message::Forces(f).to_bytes();
        assert_eq!(
            &bytes[..14],
            &[0x01, 1, 2, 3, 4, 5, 6, 7, 8, 2, 0x01, 0x00, 0xFF, 0xFF]
        );
        let crc = crc16(&bytes[..14]);
        assert_eq!(&bytes[14..], &crc.to_le_bytes());
        assert_eq!(Message::from_bytes(&bytes), Ok(Message::Forces(f)));
    }

    #[test]
    fn each_kind_of_damage_is_named() {
        let f = Forces::new(7, 70, &[5; 10]).expect("10 channels fit");
        let good = Message::Forces(f).to_bytes();

        let mut flipped = good.clone();
        flipped[5] ^= 0x10;
        assert!(matches!(
            Message::from_bytes(&flipped),
            Err(WireError::BadCrc { .. })
        ));

        // Truncated by one channel, CRC recomputed: the length no longer matches the count.
        let mut short = good[..good.len() - 4].to_vec();
        let crc = crc16(&short);
        short.extend_from_slice(&crc.to_le_bytes());
        assert_eq!(
            Message::from_bytes(&short),
            Err(WireError::BadLength {
                kind: kind::FORCES,
                len: 9 + 18,
                expected: 9 + 20
            })
        );

        assert_eq!(
            Message::from_bytes(&[0x01]),
            Err(WireError::TooShort { len: 1 })
        );
        let mut unknown = vec![0x7E, 1, 2];
        let crc = crc16(&unknown);
        unknown.extend_from_slice(&crc.to_le_bytes());
        assert_eq!(
            Message::from_bytes(&unknown),
            Err(WireError::UnknownType(0x7E))
        );
        let mut many = vec![kind::FORCES, 0, 0, 0, 0, 0, 0, 0, 0, 33];
        let crc = crc16(&many);
        many.extend_from_slice(&crc.to_le_bytes());
        assert_eq!(
            Message::from_bytes(&many),
            Err(WireError::TooManyChannels(33))
        );
    }

    fn any_message() -> impl Strategy<Value = Message> {
        prop_oneof![
            (
                any::<u32>(),
                any::<u32>(),
                proptest::collection::vec(any::<i16>(), 0..=MAX_CHANNELS)
            )
                .prop_map(|(s, t, c)| Message::Forces(
                    Forces::new(s, t, &c).expect("at most MAX_CHANNELS")
                )),
            (
                any::<u8>(),
                any::<[u8; 3]>(),
                any::<u8>(),
                any::<u16>(),
                any::<u32>()
            )
                .prop_map(
                    |(protocol_version, firmware, channels, rate_hz, serial_number)| {
                        Message::DeviceInfo(DeviceInfo {
                            protocol_version,
                            firmware,
                            channels,
                            rate_hz,
                            serial_number,
                        })
                    }
                ),
            (any::<u16>(), any::<bool>()).prop_map(|(rate_hz, streaming)| Message::Configure(
                Configure { rate_hz, streaming }
            )),
        ]
    }

    proptest! {
        #[test]
        fn round_trip(m in any_message()) {
            let bytes = m.to_bytes();
            prop_assert!(bytes.len() <= MAX_MESSAGE_LEN);
            prop_assert_eq!(Message::from_bytes(&bytes), Ok(m));
            let wire = m.to_wire();
            prop_assert!(wire.len() <= MAX_ENCODED_LEN + 2);
        }

        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..120)) {
            let _ = Message::from_bytes(&bytes);
        }
    }
}
