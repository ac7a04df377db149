//! The live view: the running trial on Foxglove's WebSocket protocol (docs/foxglove.md).
//!
//! The supervisor builds each message with the recording's own builders and hands it to a
//! publisher thread through a bounded queue that drops and counts rather than block
//! ([`tap`]). The publisher ([`publisher`]) adds the band-passed frames and the pulse
//! ([`bandpass`], with beat marks from [`beats`]) and logs everything to the `foxglove` SDK's server ([`server`]), which keeps
//! a lossy backlog per client, so a client that stops reading costs only its own messages.
//! Nothing here runs on the 1 kHz loop: its data reaches the supervisor through the loop's
//! existing sample queue, which also drops and counts. [`replay`] serves a recorded trial the
//! same way.

pub mod bandpass;
pub mod beats;
pub mod layout;
pub mod messages;
pub mod publisher;
pub mod replay;
pub mod server;
pub mod tap;
pub mod topics;
