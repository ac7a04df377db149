//! Print the magnitude response of the seed's band-pass (0.5-2.0 Hz at 100 Hz) for a range
//! of FIR orders: why a literal 4th order does not work, and what the shipped order passes.
//!
//! Run: `cargo run --release -p pulsetrack-control --example bandpass_response`

extern crate pulsetrack_control as control;

use control::signal::{BandPass, BandPassSpec};

const ORDERS: &[usize] = &[4, 16, 32, 64, 96, 128, 192, 256, 384];
const FREQUENCIES_HZ: &[f64] = &[
    0.0, 0.1, 0.25, 0.5, 1.0, 1.25, 1.67, 2.0, 3.0, 5.0, 10.0, 25.0,
];

fn main() {
    print!("| order |");
    for f in FREQUENCIES_HZ {
        print!(" {f} Hz |");
    }
    println!();
    print!("|---|");
    for _ in FREQUENCIES_HZ {
        print!("---|");
    }
    println!();
    for &order in ORDERS {
        let filter = match BandPass::design(BandPassSpec {
            order,
            low_hz: 0.5,
            high_hz: 2.0,
            sample_rate_hz: 100.0,
        }) {
            Ok(f) => f,
            Err(e) => {
                println!("| {order} | {e} |");
                continue;
            }
        };
        print!("| {order} |");
        for &f in FREQUENCIES_HZ {
            print!(" {:.3} |", filter.gain_at(f));
        }
        println!();
    }
}
