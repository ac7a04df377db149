//! End-to-end tests live in `tests/tests/`; this library holds what they share with the
//! benchmarks in `tests/examples/`.

pub mod foxglove_ws;
