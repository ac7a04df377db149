//! Consistent Overhead Byte Stuffing: removes every 0x00 from a frame so that 0x00 can
//! delimit frames on the wire, and a receiver that starts mid-stream or meets garbage
//! resynchronizes at the next 0x00.

/// Why a COBS block could not be decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum CobsError {
    #[error("a zero byte inside an encoded frame at offset {offset}")]
    ZeroInFrame { offset: usize },
    #[error("a code byte at offset {offset} points past the end of the frame")]
    Truncated { offset: usize },
    #[error("the decoded frame does not fit in {capacity} bytes")]
    TooLong { capacity: usize },
}

/// Encode `src`, appending to `out` (no trailing delimiter). The output holds no zero byte
/// and is at most `src.len() + src.len() / 254 + 1` bytes long.
pub fn encode_into(src: &[u8], out: &mut Vec<u8>) {
    let mut code_at = out.len();
    out.push(0); // placeholder for the first code byte
    let mut code: u8 = 1;
    for &b in src {
        if b == 0 {
            out[code_at] = code;
            code_at = out.len();
            out.push(0);
            code = 1;
        } else {
            out.push(b);
            code += 1;
            if code == 0xFF {
                out[code_at] = code;
                code_at = out.len();
                out.push(0);
                code = 1;
            }
        }
    }
    out[code_at] = code;
}

/// Decode one COBS block (without its delimiter) into `dst`; returns the decoded length.
pub fn decode(src: &[u8], dst: &mut [u8]) -> Result<usize, CobsError> {
    let mut read = 0;
    let mut written = 0;
    while read < src.len() {
        let code = src[read];
        if code == 0 {
            return Err(CobsError::ZeroInFrame { offset: read });
        }
        let run = usize::from(code) - 1;
        let start = read + 1;
        let end = start + run;
        if end > src.len() {
            return Err(CobsError::Truncated { offset: read });
        }
        let block = &src[start..end];
        if let Some(z) = block.iter().position(|&b| b == 0) {
            return Err(CobsError::ZeroInFrame { offset: start + z });
        }
        let Some(slot) = dst.get_mut(written..written + run) else {
            return Err(CobsError::TooLong {
                capacity: dst.len(),
            });
        };
        slot.copy_from_slice(block);
        written += run;
        read = end;
        // A code below 0xFF stands for a zero after its run, except at the very end.
        if code != 0xFF && read < src.len() {
            let Some(z) = dst.get_mut(written) else {
                return Err(CobsError::TooLong {
                    capacity: dst.len(),
                });
            };
            *z = 0;
            written += 1;
        }
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn enc(src: &[u8]) -> Vec<u8> {
        let mut v = Vec::new();
        encode_into(src, &mut v);
        v
    }

    #[test]
    fn known_vectors() {
        // The examples of Cheshire & Baker's paper, as tabulated on the COBS references.
        assert_eq!(enc(&[]), [0x01]);
        assert_eq!(enc(&[0x00]), [0x01, 0x01]);
        assert_eq!(enc(&[0x00, 0x00]), [0x01, 0x01, 0x01]);
        assert_eq!(
            enc(&[0x11, 0x22, 0x00, 0x33]),
            [0x03, 0x11, 0x22, 0x02, 0x33]
        );
        assert_eq!(
            enc(&[0x11, 0x22, 0x33, 0x44]),
            [0x05, 0x11, 0x22, 0x33, 0x44]
        );
        assert_eq!(
            enc(&[0x11, 0x00, 0x00, 0x00]),
            [0x02, 0x11, 0x01, 0x01, 0x01]
        );
        let run: Vec<u8> = (1..=254).collect();
        let mut expected = vec![0xFF];
        expected.extend(1..=254u8);
        expected.push(0x01);
        assert_eq!(enc(&run), expected);
    }

    #[test]
    fn malformed_blocks_are_errors() {
        let mut dst = [0u8; 16];
        assert_eq!(
            decode(&[0x05, 0x11], &mut dst),
            Err(CobsError::Truncated { offset: 0 })
        );
        assert_eq!(
            decode(&[0x03, 0x11, 0x00], &mut dst),
            Err(CobsError::ZeroInFrame { offset: 2 })
        );
        let mut tiny = [0u8; 2];
        assert_eq!(
            decode(&[0x05, 1, 2, 3, 4], &mut tiny),
            Err(CobsError::TooLong { capacity: 2 })
        );
    }

    proptest! {
        #[test]
        fn round_trip(src in proptest::collection::vec(any::<u8>(), 0..600)) {
            let e = enc(&src);
            prop_assert!(!e.contains(&0));
            prop_assert!(e.len() <= src.len() + src.len() / 254 + 1);
            let mut dst = vec![0u8; src.len() + 1];
            let n = decode(&e, &mut dst);
            prop_assert_eq!(n, Ok(src.len()));
            prop_assert_eq!(&dst[..src.len()], &src[..]);
        }

        #[test]
        fn arbitrary_input_never_panics(src in proptest::collection::vec(any::<u8>(), 0..300), cap in 0usize..300) {
            let mut dst = vec![0u8; cap];
            let _ = decode(&src, &mut dst);
        }
    }
}
