//! Terminal output that never panics. `print!` and `eprint!` panic when the stream is
//! gone (`daystep cache stats | head -0`: EPIPE); here a closed standard error is ignored,
//! since messages there are commentary on work that goes on, and a closed standard output
//! becomes an [`crate::Error::Io`] of kind `BrokenPipe`, which stops the command and which
//! [`super::main`] turns into a quiet success, as ripgrep does.

use crate::error::{Error, Result};
use std::io::Write;

/// Writes one line to standard error, ignoring any failure to write it.
macro_rules! note {
    ($($arg:tt)*) => {
        $crate::cli::messages::stderr_line(format_args!($($arg)*))
    };
}
pub(crate) use note;

/// Writes one line to standard output.
///
/// # Errors
/// [`Error::Io`] on `<stdout>` when it cannot be written (`BrokenPipe` when its reader has
/// gone).
macro_rules! say {
    ($($arg:tt)*) => {
        $crate::cli::messages::stdout_line(format_args!($($arg)*))
    };
}
pub(crate) use say;

/// The pseudo-path naming standard output in errors.
const STDOUT: &str = "<stdout>";

/// The body of [`note!`]: one line to standard error, failures ignored.
pub(crate) fn stderr_line(line: std::fmt::Arguments) {
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

/// The body of [`say!`]: one line to standard output, flushed so that a closed pipe shows
/// up here and not at exit.
pub(crate) fn stdout_line(line: std::fmt::Arguments) -> Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(out, "{line}")
        .and_then(|()| out.flush())
        .map_err(|e| Error::io(STDOUT, e))
}

/// Prints every warning as `warning: …`.
pub(crate) fn warnings(list: &[String]) {
    for w in list {
        note!("warning: {w}");
    }
}

/// Whether `e` means the reader of our output has gone (`daystep … | head`): nothing is
/// wrong, there is just nobody left to tell.
pub(crate) fn is_broken_pipe(e: &Error) -> bool {
    matches!(e, Error::Io { source, .. } if source.kind() == std::io::ErrorKind::BrokenPipe)
}
