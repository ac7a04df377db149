//! The console: a Unix socket speaking newline-delimited JSON (docs/console-protocol.md).

pub mod client;
pub mod hub;
pub mod protocol;
pub mod server;
