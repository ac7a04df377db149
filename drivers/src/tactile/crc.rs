//! CRC-16/IBM-3740 (often called CRC-16/CCITT-FALSE), the checksum of the tactile protocol.
//!
//! Width 16, polynomial 0x1021, initial value 0xFFFF, no reflection, no final XOR; the
//! catalogue check value over the ASCII bytes `123456789` is 0x29B1. Table driven, the table
//! built at compile time.

const POLY: u16 = 0x1021;
const INIT: u16 = 0xFFFF;

const TABLE: [u16; 256] = build_table();

const fn build_table() -> [u16; 256] {
    let mut table = [0u16; 256];
    let mut i = 0;
    while i < 256 {
        let mut crc = (i as u16) << 8;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ POLY
            } else {
                crc << 1
            };
            bit += 1;
        }
        table[i] = crc;
        i += 1;
    }
    table
}

/// The CRC of `bytes`.
pub fn crc16(bytes: &[u8]) -> u16 {
    bytes.iter().fold(INIT, |crc, &b| {
        (crc << 8) ^ TABLE[usize::from((crc >> 8) as u8 ^ b)]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit-at-a-time reference, straight from the definition.
    fn crc16_bitwise(bytes: &[u8]) -> u16 {
        let mut crc = INIT;
        for &b in bytes {
            crc ^= u16::from(b) << 8;
            for _ in 0..8 {
                crc = if crc & 0x8000 != 0 {
                    (crc << 1) ^ POLY
                } else {
                    crc << 1
                };
            }
        }
        crc
    }

    #[test]
    fn catalogue_vectors() {
        // Check value from the CRC catalogue (CRC-16/IBM-3740).
        assert_eq!(crc16(b"123456789"), 0x29B1);
        // The empty message leaves the initial value.
        assert_eq!(crc16(b""), 0xFFFF);
        // Single bytes, computed by the definition above and by common tools.
        assert_eq!(crc16(b"A"), 0xB915);
        assert_eq!(crc16(&[0x00]), 0xE1F0);
    }

    proptest::proptest! {
        #[test]
        fn table_matches_definition(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..64)) {
            proptest::prop_assert_eq!(crc16(&bytes), crc16_bitwise(&bytes));
        }

        #[test]
        fn any_single_bit_flip_is_detected(
            bytes in proptest::collection::vec(proptest::num::u8::ANY, 1..64),
            bit in 0usize..512,
        ) {
            let bit = bit % (bytes.len() * 8);
            let mut flipped = bytes.clone();
            flipped[bit / 8] ^= 1 << (bit % 8);
            proptest::prop_assert_ne!(crc16(&bytes), crc16(&flipped));
        }
    }
}
