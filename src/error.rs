//! The crate's error type: input errors name the file, line and offending value;
//! the binary maps variants to exit codes (1 input, 2 internal).

use std::path::{Path, PathBuf};

/// Every failure a daystep library call can report.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad user input: a file that cannot be parsed, a value out of range.
    /// `line` is 1-based where the input is line-oriented; `value` is the offending text.
    #[error("{}{}: {message}{}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default(), value.as_ref().map(|v| format!(" (value: {v:?})")).unwrap_or_default())]
    Input {
        /// The file the bad input came from (or a pseudo-path such as `<command line>`).
        path: PathBuf,
        /// 1-based line number, where known.
        line: Option<usize>,
        /// The offending value as written, where known.
        value: Option<String>,
        /// What is wrong, in words a user can act on.
        message: String,
    },
    /// An operating-system I/O failure on a named path.
    #[error("{}: {source}", path.display())]
    Io {
        /// The path being read or written.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A numerical failure that is not the user's fault (non-finite intermediate, etc.).
    #[error("numerical error: {0}")]
    Numerical(String),
    /// A broken invariant: a bug in daystep.
    #[error("internal error: {0}")]
    Internal(String),
    /// The user stopped a long run (Ctrl-C); what was finished is kept.
    #[error("interrupted: finished work is kept; run the same command again to continue")]
    Interrupted,
}

/// Result alias used across the crate.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// An input error with file, optional line, optional value and a message.
    pub fn input(
        path: impl AsRef<Path>,
        line: Option<usize>,
        value: Option<&str>,
        message: impl Into<String>,
    ) -> Self {
        Error::Input {
            path: path.as_ref().to_path_buf(),
            line,
            value: value.map(str::to_owned),
            message: message.into(),
        }
    }

    /// An input error about a command-line argument.
    pub fn arg(name: &str, value: impl ToString, message: impl Into<String>) -> Self {
        Error::Input {
            path: PathBuf::from(format!("<argument {name}>")),
            line: None,
            value: Some(value.to_string()),
            message: message.into(),
        }
    }

    /// An I/O error on `path`.
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.as_ref().to_path_buf(),
            source,
        }
    }

    /// Process exit code for this error: 1 for bad input (including a missing or unreadable
    /// file), 2 otherwise.
    pub fn exit_code(&self) -> i32 {
        use std::io::ErrorKind::{
            IsADirectory, NotADirectory, NotFound, PermissionDenied, ReadOnlyFilesystem,
        };
        match self {
            Error::Input { .. } => 1,
            Error::Interrupted => 130,
            // A file the user named that is missing, unreadable, or a folder where a file
            // belongs (or the reverse) is bad input too.
            Error::Io { source, .. }
                if matches!(
                    source.kind(),
                    NotFound | PermissionDenied | IsADirectory | NotADirectory | ReadOnlyFilesystem
                ) =>
            {
                1
            }
            _ => 2,
        }
    }
}

/// Test helper: the display text, path, line and value of an [`Error::Input`]; panics on
/// any other variant.
#[cfg(test)]
pub(crate) fn input_parts(e: Error) -> (String, PathBuf, Option<usize>, Option<String>) {
    let shown = e.to_string();
    match e {
        Error::Input {
            path, line, value, ..
        } => (shown, path, line, value),
        other => panic!("expected an input error, got {other:?}"),
    }
}
