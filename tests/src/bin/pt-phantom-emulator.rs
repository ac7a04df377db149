//! The real `phantom-emulator` program under a test name, for the hardware end-to-end tests.

fn main() -> std::process::ExitCode {
    drivers::programs::phantom_emulator::main()
}
