//! The tactile serial stream: arbitrary bytes through the COBS/CRC frame decoder, then the
//! sequence, range and clock checks of every force message that decodes. Nothing may panic,
//! and a message that decodes must re-encode to the same bytes.
#![no_main]

use drivers::tactile::decoder::{FrameDecoder, decode_frame};
use drivers::tactile::stream_check::StreamCheck;
use drivers::tactile::wire::Message;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut decoder = FrameDecoder::new();
    let mut check = StreamCheck::new(3.0);
    let mut arrival_s = 0.0;
    // Split the input in two places so that frames straddle reads.
    let cut = data.first().map_or(0, |&b| usize::from(b)).min(data.len());
    for chunk in [&data[..cut], &data[cut..]] {
        decoder.push(chunk, |m| {
            if let Ok(m) = m {
                let again = Message::from_bytes(&m.to_bytes());
                assert_eq!(again, Ok(m));
                if let Message::Forces(f) = m {
                    arrival_s += 0.01;
                    let c = check.accept(&f, arrival_s);
                    if let Ok(frame) = c.frame {
                        assert!(frame.is_finite());
                        assert!(frame.t_s <= arrival_s);
                    }
                }
            }
        });
    }
    // The whole input as one stuffed frame, too.
    let _ = decode_frame(data);
});
