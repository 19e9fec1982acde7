//! The source terms of a cold run's missing directions, kept on disk between the adjoint's
//! sensor blocks ([`super::Coefficients::prepare`]). The first block makes each
//! direction's terms (projection read or made, mesh weights, [`DirectionTerms`]) and
//! writes them to an unnamed scratch file; every later block reads them back in the same
//! order instead of making them again (every direction's record decoded, or projected
//! again without a cache, and its mesh weights summed): on a June day of the 10 000-triangle
//! building an extra block cost about 2.7 s before and 1.9 s with the spill. Reading them
//! is a sequential read of what the page cache usually still holds. The terms are read
//! bit for bit, so the coefficients do not depend on the spill; if the file cannot be
//! written or read, the blocks make the terms again from there on.

use crate::radiosity::DirectionTerms;
use std::fs::File;
use std::io::{BufReader, BufWriter, Seek, SeekFrom};

enum State {
    /// One block, or the file failed: every block makes its terms.
    Off,
    /// The first block writes.
    Writing(BufWriter<File>),
    /// Later blocks read from the start.
    Reading(BufReader<File>),
}

/// Terms written by the first sensor block and read by the later ones.
pub(super) struct TermsSpill {
    state: State,
    /// Bytes written.
    pub bytes: u64,
}

impl TermsSpill {
    /// A spill for `blocks` sensor blocks: off for one block (nothing to share), else an
    /// unnamed file in the system's temporary folder (`TMPDIR`).
    pub fn new(blocks: usize) -> TermsSpill {
        let state = match (blocks > 1).then(tempfile::tempfile) {
            Some(Ok(f)) => State::Writing(BufWriter::with_capacity(1 << 20, f)),
            _ => State::Off,
        };
        TermsSpill { state, bytes: 0 }
    }

    /// Called before each block after the first: the terms are read from the start.
    pub fn rewind(&mut self) {
        let state = std::mem::replace(&mut self.state, State::Off);
        self.state = match state {
            State::Writing(w) => w
                .into_inner()
                .ok()
                .and_then(|mut f| f.seek(SeekFrom::Start(0)).ok().map(|_| f))
                .map_or(State::Off, |f| {
                    State::Reading(BufReader::with_capacity(1 << 20, f))
                }),
            State::Reading(mut r) => r
                .seek(SeekFrom::Start(0))
                .map_or(State::Off, |_| State::Reading(r)),
            State::Off => State::Off,
        };
    }

    /// The next `n` directions' terms, when this block reads them; `None` when it makes
    /// them (the first block, or the file failed).
    pub fn read(&mut self, n: usize) -> Option<Vec<DirectionTerms>> {
        let State::Reading(r) = &mut self.state else {
            return None;
        };
        let got: std::io::Result<Vec<DirectionTerms>> =
            (0..n).map(|_| DirectionTerms::read_from(r)).collect();
        if got.is_err() {
            self.state = State::Off;
        }
        got.ok()
    }

    /// Keeps the terms the first block made; a no-op in the later blocks (they read).
    pub fn write(&mut self, terms: &[DirectionTerms]) {
        let State::Writing(w) = &mut self.state else {
            return;
        };
        let written: std::io::Result<()> = terms.iter().try_for_each(|t| t.write_to(w));
        match written {
            Ok(()) => self.bytes += terms.iter().map(DirectionTerms::encoded_bytes).sum::<u64>(),
            Err(_) => self.state = State::Off,
        }
    }
}
