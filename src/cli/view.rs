//! `daystep view`: the `.glb` solution viewer served on 127.0.0.1 until Ctrl-C.

use super::args::ViewArgs;
use super::messages::{note, say};
use crate::error::Result;
use crate::export::viewer::ViewerServer;

/// Runs `daystep view`: binds, prints the URL on standard output (so a script can read
/// it), and serves until the process is stopped.
///
/// # Errors
/// A missing or unreadable file, a port that cannot be bound ([`crate::Error::Input`] or
/// [`crate::Error::Io`]).
pub fn run(a: ViewArgs) -> Result<()> {
    let server = ViewerServer::bind(&a.glb, a.port)?;
    say!("{}", server.url())?;
    note!("daystep view: serving {} (Ctrl-C stops)", a.glb.display());
    server.run()
}
