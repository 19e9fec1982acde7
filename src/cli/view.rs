//! `daystep view`: the `.glb` solution viewer served on 127.0.0.1 until Ctrl-C.

use super::args::ViewArgs;
use super::messages::{note, say};
use crate::error::Result;
use crate::export::viewer::ViewerServer;

/// Runs `daystep view`: checks the file is a glTF 2.0 binary, binds, prints the URL on
/// standard output (so a script can read it), and serves until the process is stopped.
/// Only requests for the printed origin (or `localhost` / `[::1]` with the same port) are
/// answered; the threat model is `docs/viewer-server.md`.
///
/// # Errors
/// A missing or unreadable file, one that is not a glTF 2.0 binary (`daystep view
/// scene.toml`), a port that cannot be bound ([`crate::Error::Input`] or
/// [`crate::Error::Io`]; exit 1).
pub fn run(a: ViewArgs) -> Result<()> {
    let server = ViewerServer::bind(&a.glb, a.port)?;
    say!("{}", server.url())?;
    note!("daystep view: serving {} (Ctrl-C stops)", a.glb.display());
    server.run()
}
