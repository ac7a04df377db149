//! The emulator programs' `main`s, in the library so other packages' tests can build the
//! same programs under their own names (a package cannot run another package's binaries).

pub mod phantom_emulator;
pub mod tactile_emulator;
