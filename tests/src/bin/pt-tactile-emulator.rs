//! The real `tactile-emulator` program under a test name, for the hardware end-to-end tests.

fn main() -> std::process::ExitCode {
    drivers::programs::tactile_emulator::main()
}
