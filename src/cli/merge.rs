//! `daystep merge`: the shards of `annual --shard k/n` assembled into one run's files.

use super::args::MergeArgs;
use super::config;
use super::messages::note;
use crate::error::Result;

/// Runs `daystep merge` into `--out`.
///
/// # Errors
/// Shards that do not belong together or cannot be read ([`crate::Error::Input`]),
/// unwritable output.
pub fn run(a: MergeArgs) -> Result<()> {
    let params = config::metric_params(&a.metrics)?;
    super::check_outputs(&a.out, None)?;
    crate::sequence::annual::merge(&a.parts, &a.out, a.step, &params)?;
    note!(
        "daystep merge: {} shards → {}",
        a.parts.len(),
        a.out.display()
    );
    Ok(())
}
