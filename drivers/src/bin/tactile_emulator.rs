//! `tactile-emulator`: see [`pulsetrack_drivers::programs::tactile_emulator`].

fn main() -> std::process::ExitCode {
    pulsetrack_drivers::programs::tactile_emulator::main()
}
