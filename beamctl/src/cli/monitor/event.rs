//! What the monitor's event loop waits for ([`Event`]: the link, keys,
//! stdin lines) and what a key asks it to do ([`KeyAction`]); shared by
//! the loop ([`crate::cli::monitor`]) and the terminal view (`tui.rs`).

use crate::link::grammar::CommandArgs;
use crate::link::Incoming;

/// Everything the event loop waits for.
#[derive(Debug)]
pub enum Event {
    /// From the link's reader thread.
    Link(Incoming),
    /// A key in the terminal view.
    Key(ratatui::crossterm::event::KeyEvent),
    /// A line from stdin (`--stdin-commands`).
    Line(String),
}

impl From<Incoming> for Event {
    fn from(i: Incoming) -> Self {
        Self::Link(i)
    }
}

/// What a key asks for.
pub enum KeyAction {
    /// Nothing.
    None,
    /// End the monitor.
    Quit,
    /// Send this command to the device.
    Send(CommandArgs),
}
