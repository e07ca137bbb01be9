//! One-line error reporting, and the two other ways `beamctl` speaks
//! outside its outputs: notes on stderr ([`note`]) and stdout written so
//! that a closed pipe is not an error ([`write_stdout`]).
//!
//! Every failure ends up as a single line on stderr, `error: <message>`,
//! where the message starts with the flag (or file) it is about, and a
//! non-zero exit code: 2 for bad usage (flags, values, input files), 1 for a
//! failure while running (simulation, writing outputs).

use std::fmt;
use std::io::Write;
use std::process::ExitCode;

/// Exit code for bad command-line usage (clap uses the same).
pub const EXIT_USAGE: u8 = 2;
/// Exit code for a failure while running.
pub const EXIT_FAILURE: u8 = 1;
/// [`CliError::code`] of a run stopped by its caller's interrupt (the
/// Python package's Ctrl-C; 128 + SIGINT, as shells report it).
pub const EXIT_INTERRUPTED: u8 = 130;

/// An error to report to the user.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CliError {
    /// The message, without the `error: ` prefix.
    pub message: String,
    /// Process exit code.
    pub code: u8,
}

impl CliError {
    /// A bad value or combination of flags: `--flag: message`.
    pub fn usage(flag: &str, message: impl fmt::Display) -> Self {
        Self {
            message: format!("{flag}: {message}"),
            code: EXIT_USAGE,
        }
    }

    /// A failure while running (simulation, I/O).
    pub fn failure(message: impl fmt::Display) -> Self {
        Self {
            message: message.to_string(),
            code: EXIT_FAILURE,
        }
    }

    /// `what` was stopped by its caller's interrupt: `what: interrupted`,
    /// exit code [`EXIT_INTERRUPTED`].
    pub fn interrupted(what: &str) -> Self {
        Self {
            message: format!("{what}: interrupted"),
            code: EXIT_INTERRUPTED,
        }
    }

    /// Print `error: <message>` on stderr and return the exit code.
    pub fn report(&self) -> ExitCode {
        let line = one_line(&self.message);
        // Nothing useful can be done if stderr itself is gone.
        let _ = writeln!(std::io::stderr().lock(), "error: {line}");
        ExitCode::from(self.code)
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

/// Collapse whitespace runs (including newlines) into single spaces.
pub fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Handle a clap parse error: help and version go to stdout as usual;
/// anything else is reduced to one line (clap's first lines, without the
/// usage block) on stderr.
pub fn clap_exit(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    match e.kind() {
        ErrorKind::DisplayHelp
        | ErrorKind::DisplayVersion
        | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            let _ = e.print();
            ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(EXIT_USAGE))
        }
        _ => {
            let text = e.to_string();
            let message = clap_message(&text);
            CliError {
                message,
                code: EXIT_USAGE,
            }
            .report()
        }
    }
}

/// The part of a rendered clap error before its usage block, on one line,
/// without the leading `error:`.
fn clap_message(rendered: &str) -> String {
    let body: Vec<&str> = rendered
        .lines()
        .take_while(|l| !l.trim_start().starts_with("Usage:"))
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with("For more information"))
        .collect();
    let joined = one_line(&body.join(" "));
    let joined = joined.strip_prefix("error:").unwrap_or(&joined).trim();
    let out = if joined.is_empty() {
        "invalid command line (see --help)".to_string()
    } else {
        joined.to_string()
    };
    format!("{out} (see --help)")
}

/// Print a notice on stderr.
pub fn note(msg: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{msg}");
}

/// Write to stdout; a closed pipe (`| head`) is not an error.
pub fn write_stdout(text: &str) -> Result<(), CliError> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(CliError::failure(format!("writing to stdout: {e}"))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clap_message_is_one_line_without_usage() {
        let r = "error: invalid value 'x' for '--estimator <LAW>'\n  [possible values: adaptive, gradient]\n\nUsage: beamctl simulate [OPTIONS]\n\nFor more information, try '--help'.\n";
        let r2 = "error: invalid value '4' for '--modes <N>': 4 is not in 1..=3\n\nFor more information, try '--help'.\n";
        assert_eq!(
            clap_message(r2),
            "invalid value '4' for '--modes <N>': 4 is not in 1..=3 (see --help)"
        );
        assert_eq!(
            clap_message(r),
            "invalid value 'x' for '--estimator <LAW>' [possible values: adaptive, gradient] (see --help)"
        );
    }

    #[test]
    fn usage_names_the_flag() {
        let e = CliError::usage("--zeta", "damping ratios must be > 0 (got -0.1)");
        assert_eq!(
            e.to_string(),
            "--zeta: damping ratios must be > 0 (got -0.1)"
        );
        assert_eq!(e.code, EXIT_USAGE);
    }
}
