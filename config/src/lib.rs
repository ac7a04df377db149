//! Typed configuration for pulsetrack.
//!
//! Every file is RON with a version field; unknown fields are refused. [`load`] turns a file
//! into a typed value and runs its validation, and every error names the file, the line and
//! the field. [`shipped`] embeds the files that ship with the project so that the daemon and
//! the command-line tool run with no files on disk.

pub mod calibration_file;
pub mod load;
pub mod locate;
pub mod schema;
pub mod shipped;
pub mod validate;

pub use load::{ConfigError, Loaded, load_file, load_str};
pub use schema::Config;
pub use validate::{Validate, Validator};
