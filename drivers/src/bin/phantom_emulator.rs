//! `phantom-emulator`: see [`pulsetrack_drivers::programs::phantom_emulator`].

fn main() -> std::process::ExitCode {
    pulsetrack_drivers::programs::phantom_emulator::main()
}
