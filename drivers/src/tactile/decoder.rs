//! Splits a byte stream into messages at 0x00 delimiters and decodes each one.
//!
//! Bounded memory: a run of bytes longer than any valid frame is discarded up to the next
//! delimiter and reported once as oversize. Any byte sequence at all is accepted; garbage
//! costs at most the frame it lands in.

use super::cobs;
use super::wire::{MAX_ENCODED_LEN, MAX_MESSAGE_LEN, Message, WireError};

/// Streaming decoder; feed it whatever the port returns.
#[derive(Debug, Clone)]
pub struct FrameDecoder {
    buf: [u8; MAX_ENCODED_LEN],
    len: usize,
    overflowed: bool,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    pub fn new() -> Self {
        Self {
            buf: [0; MAX_ENCODED_LEN],
            len: 0,
            overflowed: false,
        }
    }

    /// Forget a partial frame (after a reconnect).
    pub fn reset(&mut self) {
        self.len = 0;
        self.overflowed = false;
    }

    /// Consume `bytes`, calling `on` with each complete frame's outcome, in order.
    pub fn push(&mut self, bytes: &[u8], mut on: impl FnMut(Result<Message, WireError>)) {
        for &b in bytes {
            if b != 0 {
                if self.len < self.buf.len() {
                    self.buf[self.len] = b;
                    self.len += 1;
                } else {
                    self.overflowed = true;
                }
                continue;
            }
            // A delimiter: an empty frame (two delimiters in a row) is idle line, not an error.
            if self.overflowed {
                on(Err(WireError::Oversize {
                    max: MAX_ENCODED_LEN,
                }));
            } else if self.len > 0 {
                on(decode_frame(&self.buf[..self.len]));
            }
            self.reset();
        }
    }
}

/// Decode one stuffed frame (no delimiter).
pub fn decode_frame(stuffed: &[u8]) -> Result<Message, WireError> {
    let mut raw = [0u8; MAX_MESSAGE_LEN];
    let n = cobs::decode(stuffed, &mut raw).map_err(|e| match e {
        cobs::CobsError::TooLong { .. } => WireError::Oversize {
            max: MAX_MESSAGE_LEN,
        },
        other => WireError::Cobs(other),
    })?;
    Message::from_bytes(&raw[..n])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tactile::wire::{Configure, Forces};
    use proptest::prelude::*;

    fn collect(d: &mut FrameDecoder, bytes: &[u8]) -> Vec<Result<Message, WireError>> {
        let mut out = Vec::new();
        d.push(bytes, |r| out.push(r));
        out
    }

    fn forces(seq: u32) -> Message {
        Message::Forces(Forces::new(seq, seq * 10_000, &[seq as i16; 10]).expect("fits"))
    }

    #[test]
    fn resynchronizes_after_garbage() {
        let mut d = FrameDecoder::new();
        let mut stream = vec![0x13, 0x37, 0xFF, 0x42]; // mid-frame start: garbage
        stream.extend(forces(1).to_wire());
        stream.extend([0x55; 7]); // garbage between frames
        stream.push(0);
        stream.extend(forces(2).to_wire());
        let out = collect(&mut d, &stream);
        let good: Vec<_> = out.iter().filter_map(|r| r.as_ref().ok()).collect();
        assert_eq!(good, vec![&forces(1), &forces(2)]);
        assert_eq!(out.iter().filter(|r| r.is_err()).count(), 2);
    }

    #[test]
    fn byte_at_a_time_equals_all_at_once() {
        let mut stream = Vec::new();
        for s in 0..5 {
            stream.extend(forces(s).to_wire());
        }
        stream.extend(
            Message::Configure(Configure {
                rate_hz: 100,
                streaming: true,
            })
            .to_wire(),
        );
        let mut a = FrameDecoder::new();
        let whole = collect(&mut a, &stream);
        let mut b = FrameDecoder::new();
        let mut pieces = Vec::new();
        for byte in &stream {
            pieces.extend(collect(&mut b, std::slice::from_ref(byte)));
        }
        assert_eq!(whole, pieces);
        assert_eq!(whole.len(), 6);
        assert!(whole.iter().all(|r| r.is_ok()));
    }

    #[test]
    fn truncated_frame_then_good_frame() {
        let mut d = FrameDecoder::new();
        let wire = forces(9).to_wire();
        // Cut the frame short (the device reset mid-frame), then a full frame follows.
        let mut stream = wire[..wire.len() / 2].to_vec();
        stream.extend(forces(10).to_wire());
        let out = collect(&mut d, &stream);
        assert_eq!(out.len(), 2);
        assert!(out[0].is_err());
        assert_eq!(out[1], Ok(forces(10)));
    }

    #[test]
    fn endless_garbage_is_bounded_and_reported_once() {
        let mut d = FrameDecoder::new();
        let mut stream = vec![0xAB; 10_000];
        stream.push(0);
        stream.extend(forces(3).to_wire());
        let out = collect(&mut d, &stream);
        assert_eq!(
            out,
            vec![
                Err(WireError::Oversize {
                    max: MAX_ENCODED_LEN
                }),
                Ok(forces(3))
            ]
        );
    }

    proptest! {
        #[test]
        fn arbitrary_bytes_never_panic_and_good_frames_survive(
            garbage in proptest::collection::vec(any::<u8>(), 0..400),
            seq in any::<u32>(),
        ) {
            let mut d = FrameDecoder::new();
            let _ = collect(&mut d, &garbage);
            // Whatever came before, a delimiter-led frame decodes.
            let m = forces(seq % 1000);
            let out = collect(&mut d, &m.to_wire());
            prop_assert_eq!(out.last(), Some(&Ok(m)));
        }
    }
}
