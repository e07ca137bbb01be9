//! The host end of the serial link (`docs/PROTOCOL.md`): what
//! `beamctl monitor` and `beamctl send` are built on, and what tests and
//! tools use to talk to a device.
//!
//! * [`transport`]: open a serial port, a TCP socket or a capture file, and
//!   read it on a thread;
//! * [`host`]: the host's view of the link: the stream decoder and its
//!   counters, the device's last `Status`, frame rates, commands awaiting
//!   their acknowledgement;
//! * [`record`]: `--record`: every frame to a CSV file, the raw samples to a
//!   second CSV in the form `beamctl replay` reads (`docs/RECORDING.md`);
//! * [`grammar`]: commands as text, both ways: the grammar of `beamctl
//!   send` and the monitor's command line (parsed into a [`beam_protocol::Command`]) and
//!   a command written back in it;
//! * [`text`]: names and one-line descriptions of flags, waveforms and
//!   answers, shared by every output;
//! * [`fake`]: a fake device that speaks the protocol (estimates, raw
//!   samples, status, acknowledgements) over any byte stream, for tests and
//!   for trying the tools without a rig.
//!
//! Everything protocol-related (framing, messages, validation) is the
//! core's [`beam_protocol`]; nothing here re-implements it.

pub mod fake;
pub mod grammar;
pub mod host;
pub mod record;
pub mod text;
pub mod transport;

pub use host::{Host, Pending};
pub use record::{raw_path_for, RecordStats, Recorder};
pub use transport::{Connection, Endpoint, Incoming, StreamEnd};
