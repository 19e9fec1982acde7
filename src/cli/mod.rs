//! L9 the command line, split the way ripgrep splits its own:
//!
//! - [`args`]: the raw clap structures — flags, defaults and help text, nothing more;
//! - [`ranges`]: the range of every number a flag takes, and the value parsers holding them;
//! - [`config`]: raw arguments turned into library values (quality preset, sky, cache,
//!   metric thresholds, dates, shard, knobs), every refusal an [`crate::Error::Input`] naming the
//!   flag and the value;
//! - one short module per command ([`instant`], [`df`], [`convergence`], [`annual`],
//!   [`render`], [`merge`], [`view`], [`cache`]) that calls the library and reports on the terminal; the work
//!   itself (choosing a weather record, checking sites, writing outputs) is in the
//!   library, so a Rust caller gets it too;
//! - `messages`: terminal output that never panics on a closed pipe;
//! - this module: [`run`], [`main`] and the exit codes.
//!
//! Exit codes: 0 success (also when the reader of standard output goes away early, as in
//! `daystep cache stats | head -0`), 1 bad input (including a missing or unreadable file
//! the user named), 2 internal error, 130 interrupted by Ctrl-C.

pub mod annual;
pub mod args;
pub mod cache;
pub mod config;
pub mod convergence;
pub mod df;
pub mod instant;
pub mod merge;
pub mod ranges;
pub mod render;
pub mod view;
pub(crate) mod messages;
mod progress;

pub use args::{Cli, Command};

use crate::error::Result;
use clap::Parser;

/// Runs a parsed command line.
///
/// # Errors
/// Any library error, to be mapped to an exit code.
pub fn run(cli: Cli) -> Result<()> {
    // Read (and checked) before any work, for every command.
    let limits = config::Limits::from_args(cli.max_memory.as_deref(), cli.cache_size.as_deref())?;
    match cli.command {
        Command::Instant(a) => instant::run(a, &limits),
        Command::Df(a) => df::run(a, &limits),
        Command::Convergence(a) => convergence::run(a),
        Command::Annual(a) => annual::run(a, &limits),
        Command::Render(a) => render::run(*a, &limits),
        Command::Merge(a) => merge::run(a),
        Command::View(a) => view::run(a),
        Command::Cache { action } => cache::run(action),
    }
}

/// Checks the output folder `--out` and the optional `--gltf` file before any work, so a
/// path that cannot be written ends the run at once with exit 1 naming the flag.
fn check_outputs(out: &std::path::Path, gltf: Option<&std::path::Path>) -> Result<()> {
    crate::files::check_output_dir("--out", out)?;
    if let Some(g) = gltf {
        crate::files::check_output_file("--gltf", g)?;
    }
    Ok(())
}

/// The exit code of a finished [`run`] (see the module doc); a broken pipe on standard
/// output is success, and nothing is printed for it.
fn exit_code(result: Result<()>) -> i32 {
    match result {
        Ok(()) => 0,
        Err(e) if messages::is_broken_pipe(&e) => 0,
        Err(e) => {
            messages::note!("error: {e}");
            e.exit_code()
        }
    }
}

/// Parses the process arguments, runs, and returns the exit code.
pub fn main() -> i32 {
    crate::allocator::keep_freed_memory();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 1 } else { 0 };
            let _ = e.print();
            return code;
        }
    };
    if let Some(n) = cli.threads {
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()
        {
            messages::note!("error: cannot set up {n} threads: {e}");
            return 2;
        }
    }
    exit_code(run(cli))
}
