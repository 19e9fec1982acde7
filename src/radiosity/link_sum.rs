//! The sum of an operator build's links over its directions ([`super::bundles`]): each
//! direction's list sorted and merged, then summed into one sorted list with one entry per
//! key, in fixed point. Past [`SPILL_ENTRIES`] entries the sum is written out as a sorted
//! run to an unnamed file in the system's temporary folder and begun again; the runs are
//! merged as the sum is read.
//!
//! Why: held whole, the sum (16 bytes a link) and the lists pending beside it were the
//! largest holding of a cold run where sensors are few: about 110 of the 220 MB peak of
//! the corridor building's operator build (4.6 M links a part). On disk, the runs sit in
//! the page cache instead (on a `tmpfs` `TMPDIR`, still in memory, but not in the
//! process's). Fixed-point sums are exact, so neither the grouping, the order nor the
//! spilling changes a bit of the operator. Where no file can be made, the sum is held.

use crate::files::{read_at, write_at};
use rayon::prelude::*;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::fs::File;

/// Entries of the sum held past which it is written out as a run (16 MiB of grey
/// links). Scenes whose operator parts have fewer links never spill.
const SPILL_ENTRIES: usize = 1 << 20;

/// Entries a run is written and read back by.
const CHUNK: usize = 1 << 14;

/// Links (receiver row << 32 | source row, fixed-point τ), grey ones with one value: in
/// a scene without coloured glazing every link is grey, and half the bytes of the
/// lists, which are the operator build's largest holding.
#[derive(Default)]
pub(super) struct Links {
    grey: Vec<(u64, u64)>,
    colour: Vec<(u64, [u64; 3])>,
}

impl Links {
    /// Adds the link `key` with fixed-point factors `q` (R, G, B).
    pub fn push(&mut self, key: u64, q: [u64; 3]) {
        if q[0] == q[1] && q[1] == q[2] {
            self.grey.push((key, q[0]));
        } else {
            self.colour.push((key, q));
        }
    }

    /// Entries, grey and coloured.
    pub fn len(&self) -> usize {
        self.grey.len() + self.colour.len()
    }

    /// Moves `other`'s entries in.
    pub fn extend(&mut self, other: Links) {
        self.grey.extend(other.grey);
        self.colour.extend(other.colour);
    }

    /// Keeps the entries whose key `keep` accepts.
    pub fn retain(&mut self, keep: impl Fn(u64) -> bool) {
        self.grey.retain(|e| keep(e.0));
        self.colour.retain(|e| keep(e.0));
    }

    /// Each list sorted by key, equal keys' values summed.
    pub fn merged(self) -> Links {
        Links {
            grey: merge_pairs(self.grey),
            colour: merge_pairs(self.colour),
        }
    }
}

/// A link's fixed-point value: one sum (grey) or three (R, G, B), stored as that many
/// u64 words after the key.
trait Value: Copy + Send + Sync + 'static {
    const WORDS: usize;
    fn add(&mut self, other: Self);
    fn put(self, out: &mut Vec<u64>);
    fn get(words: &[u64]) -> Self;
}

impl Value for u64 {
    const WORDS: usize = 1;
    fn add(&mut self, other: u64) {
        *self += other;
    }
    fn put(self, out: &mut Vec<u64>) {
        out.push(self);
    }
    fn get(words: &[u64]) -> u64 {
        words[0]
    }
}

impl Value for [u64; 3] {
    const WORDS: usize = 3;
    fn add(&mut self, other: [u64; 3]) {
        for (x, y) in self.iter_mut().zip(other) {
            *x += y;
        }
    }
    fn put(self, out: &mut Vec<u64>) {
        out.extend(self);
    }
    fn get(words: &[u64]) -> [u64; 3] {
        [words[0], words[1], words[2]]
    }
}

/// The runs written out: the file, its length (bytes), and per kind each run's (first
/// byte, entries).
struct Spill {
    file: File,
    end: u64,
    grey: Vec<(u64, usize)>,
    colour: Vec<(u64, usize)>,
}

impl Spill {
    /// Appends `entries` as a run; its (first byte, entries).
    fn write<V: Value>(&mut self, entries: &[(u64, V)]) -> std::io::Result<(u64, usize)> {
        let start = self.end;
        let mut words = Vec::with_capacity(CHUNK * (1 + V::WORDS));
        for chunk in entries.chunks(CHUNK) {
            words.clear();
            for &(k, v) in chunk {
                words.push(k);
                v.put(&mut words);
            }
            let bytes: &[u8] = bytemuck::cast_slice(&words);
            write_at(&self.file, bytes, self.end)?;
            self.end += bytes.len() as u64;
        }
        Ok((start, entries.len()))
    }

    /// The run at `(start, len)`, read back in chunks.
    fn read<V: Value>(&self, (start, len): (u64, usize)) -> RunReader<'_, V> {
        RunReader {
            file: &self.file,
            at: start,
            left: len,
            buf: Vec::new(),
            words: Vec::new(),
            pos: 0,
        }
    }
}

/// A run read back a chunk at a time.
struct RunReader<'a, V> {
    file: &'a File,
    at: u64,
    left: usize,
    buf: Vec<(u64, V)>,
    words: Vec<u64>,
    pos: usize,
}

impl<V: Value> Iterator for RunReader<'_, V> {
    type Item = (u64, V);
    fn next(&mut self) -> Option<(u64, V)> {
        if self.pos == self.buf.len() {
            if self.left == 0 {
                return None;
            }
            let n = self.left.min(CHUNK);
            self.words.resize(n * (1 + V::WORDS), 0);
            // A scratch file this process wrote and still holds open: a failed read is a
            // failing disk, with no operator to fall back on.
            read_at(
                self.file,
                bytemuck::cast_slice_mut(&mut self.words),
                self.at,
            )
            .unwrap_or_else(|e| {
                panic!(
                    "reading back the operator build's scratch file in {}: {e}",
                    std::env::temp_dir().display()
                )
            });
            self.buf.clear();
            self.buf.extend(
                self.words
                    .chunks_exact(1 + V::WORDS)
                    .map(|w| (w[0], V::get(&w[1..]))),
            );
            self.at += (n * 8 * (1 + V::WORDS)) as u64;
            self.left -= n;
            self.pos = 0;
        }
        self.pos += 1;
        Some(self.buf[self.pos - 1])
    }
}

/// Links summed over many directions in bounded memory: one sorted list with one entry
/// per key, and the directions' lists pending beside it, sorted and merged into it (in
/// place, from its end) once they reach a quarter of it; the list written out as a run
/// once it passes `spill_at` entries. Held at most: `spill_at` entries and half as much
/// again, or, where no file can be made, the links' sum and half as much again.
pub(super) struct Accumulator {
    merged: Links,
    pending: Links,
    spill: Option<Spill>,
    spill_at: usize,
}

impl Default for Accumulator {
    fn default() -> Self {
        Accumulator::spilling_at(SPILL_ENTRIES)
    }
}

impl Accumulator {
    /// Entries pending below which no merge is made, whatever the sum's size.
    const MIN_PENDING: usize = 1 << 20;

    /// An empty sum that writes itself out past `spill_at` entries.
    fn spilling_at(spill_at: usize) -> Accumulator {
        Accumulator {
            merged: Links::default(),
            pending: Links::default(),
            spill: None,
            spill_at,
        }
    }

    /// Adds a direction's links.
    pub fn add(&mut self, links: Links) {
        self.pending.extend(links);
        if self.pending.len() > (self.merged.len() / 4).max(Self::MIN_PENDING) {
            self.flush();
        }
    }

    fn flush(&mut self) {
        let p = std::mem::take(&mut self.pending).merged();
        let m = &mut self.merged;
        m.grey = merge_sorted(std::mem::take(&mut m.grey), p.grey);
        m.colour = merge_sorted(std::mem::take(&mut m.colour), p.colour);
        if m.len() > self.spill_at {
            self.write_out();
        }
    }

    /// Writes the held sum out as a run (grey and coloured), or, where that fails, keeps
    /// holding it from now on.
    fn write_out(&mut self) {
        if self.spill.is_none() {
            self.spill = tempfile::tempfile().ok().map(|file| Spill {
                file,
                end: 0,
                grey: Vec::new(),
                colour: Vec::new(),
            });
        }
        let Some(s) = self.spill.as_mut() else {
            self.spill_at = usize::MAX;
            return;
        };
        let m = &self.merged;
        match (s.write(&m.grey), s.write(&m.colour)) {
            (Ok(g), Ok(c)) => {
                s.grey.push(g);
                s.colour.push(c);
                self.merged = Links::default();
            }
            // A half-written run is never listed, so never read.
            _ => self.spill_at = usize::MAX,
        }
    }

    /// The sum.
    pub fn finish(mut self) -> LinkSum {
        self.flush();
        LinkSum {
            held: self.merged,
            spill: self.spill,
        }
    }
}

/// The links of all directions summed: the part held and the runs written out.
pub(super) struct LinkSum {
    held: Links,
    spill: Option<Spill>,
}

impl LinkSum {
    /// Every key once, in order, with its grey and coloured sums added (exact: fixed
    /// point), the runs merged as they are read.
    pub fn sorted(&self) -> impl Iterator<Item = (u64, [u64; 3])> + '_ {
        let (grey_runs, colour_runs) = match &self.spill {
            Some(s) => (&s.grey[..], &s.colour[..]),
            None => (&[][..], &[][..]),
        };
        let grey = merge_sources(self.sources(&self.held.grey, grey_runs));
        let colour = merge_sources(self.sources(&self.held.colour, colour_runs));
        grey_and_colour(grey, colour)
    }

    /// The runs `runs` read back, and the entries `held`.
    fn sources<'a, V: Value>(
        &'a self,
        held: &'a [(u64, V)],
        runs: &[(u64, usize)],
    ) -> Vec<Source<'a, V>> {
        let spill = self.spill.as_ref();
        runs.iter()
            .filter_map(|&r| spill.map(|s| Source::Run(s.read(r))))
            .chain([Source::Held(held.iter())])
            .collect()
    }

    /// At least the keys in the sum, without a pass over it: the entries held and written
    /// out, grey and coloured, whose keys the merge may join.
    pub fn most_len(&self) -> usize {
        let runs = self.spill.as_ref().map_or(0, |s| {
            s.grey.iter().chain(&s.colour).map(|r| r.1).sum::<usize>()
        });
        self.held.len() + runs
    }

    /// Runs written out.
    #[cfg(test)]
    fn runs(&self) -> usize {
        self.spill.as_ref().map_or(0, |s| s.grey.len())
    }
}

/// One sorted source of a merge: a run read back, or the entries held.
enum Source<'a, V: Value> {
    Run(RunReader<'a, V>),
    Held(std::slice::Iter<'a, (u64, V)>),
}

impl<V: Value> Iterator for Source<'_, V> {
    type Item = (u64, V);
    fn next(&mut self) -> Option<(u64, V)> {
        match self {
            Source::Run(r) => r.next(),
            Source::Held(h) => h.next().copied(),
        }
    }
}

/// Sources each sorted by key with one entry per key, as one such stream with equal keys'
/// values summed.
fn merge_sources<V: Value>(mut sources: Vec<Source<'_, V>>) -> impl Iterator<Item = (u64, V)> + '_ {
    let mut heads: Vec<Option<V>> = vec![None; sources.len()];
    let mut heap = BinaryHeap::new();
    for (i, s) in sources.iter_mut().enumerate() {
        if let Some((k, v)) = s.next() {
            heads[i] = Some(v);
            heap.push(Reverse((k, i)));
        }
    }
    std::iter::from_fn(move || {
        let Reverse((key, i)) = heap.pop()?;
        let mut sum = heads[i].take().expect("a head per source in the heap");
        let mut advance = |i: usize, heap: &mut BinaryHeap<_>, heads: &mut Vec<Option<V>>| {
            if let Some((k, v)) = sources[i].next() {
                heads[i] = Some(v);
                heap.push(Reverse((k, i)));
            }
        };
        advance(i, &mut heap, &mut heads);
        while let Some(&Reverse((k, j))) = heap.peek() {
            if k != key {
                break;
            }
            heap.pop();
            sum.add(heads[j].take().expect("a head per source in the heap"));
            advance(j, &mut heap, &mut heads);
        }
        Some((key, sum))
    })
}

/// A grey and a coloured stream, each sorted with one entry per key, as one stream of RGB
/// sums.
fn grey_and_colour(
    grey: impl Iterator<Item = (u64, u64)>,
    colour: impl Iterator<Item = (u64, [u64; 3])>,
) -> impl Iterator<Item = (u64, [u64; 3])> {
    let mut grey = grey.peekable();
    let mut colour = colour.peekable();
    std::iter::from_fn(move || match (grey.peek(), colour.peek()) {
        (Some(&(kg, g)), Some(&(kc, c))) => Some(if kg < kc {
            grey.next();
            (kg, [g; 3])
        } else if kc < kg {
            colour.next();
            (kc, c)
        } else {
            grey.next();
            colour.next();
            (kc, c.map(|x| x + g))
        }),
        (Some(&(kg, g)), None) => {
            grey.next();
            Some((kg, [g; 3]))
        }
        (None, Some(_)) => colour.next(),
        (None, None) => None,
    })
}

/// Two lists, each sorted by key with one entry per key, as one such list with equal
/// keys' values summed: written into `a` from its end, so nothing but `a` grows.
fn merge_sorted<V: Value>(mut a: Vec<(u64, V)>, b: Vec<(u64, V)>) -> Vec<(u64, V)> {
    let Some(&fill) = b.first() else {
        return a;
    };
    let (na, nb) = (a.len(), b.len());
    a.resize(na + nb, fill);
    let (mut i, mut j, mut w) = (na, nb, na + nb);
    // The write index never passes an unread entry of `a`: w − i is what of `b` is left
    // plus the keys merged, at least 0.
    while j > 0 {
        w -= 1;
        let y = b[j - 1];
        if i > 0 && a[i - 1].0 > y.0 {
            a[w] = a[i - 1];
            i -= 1;
        } else if i > 0 && a[i - 1].0 == y.0 {
            let mut x = a[i - 1];
            x.1.add(y.1);
            a[w] = x;
            i -= 1;
            j -= 1;
        } else {
            a[w] = y;
            j -= 1;
        }
    }
    // Keys merged left a gap of w − i between a's untouched head and the merged tail.
    if w > i {
        a.copy_within(w.., i);
        a.truncate(a.len() - (w - i));
    }
    a
}

/// `v` sorted by key with equal keys' values summed, in place.
fn merge_pairs<V: Value>(mut v: Vec<(u64, V)>) -> Vec<(u64, V)> {
    v.par_sort_unstable_by_key(|e| e.0);
    let mut w = 0;
    for i in 0..v.len() {
        if w > 0 && v[w - 1].0 == v[i].0 {
            let q = v[i].1;
            v[w - 1].1.add(q);
        } else {
            v[w] = v[i];
            w += 1;
        }
    }
    v.truncate(w);
    v.shrink_to_fit();
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rng::mix64;
    use std::collections::BTreeMap;

    /// Grey and coloured links, pushed in any order and merged in any grouping, read back
    /// as one sum per key in key order: the same as a plain map's sums.
    #[test]
    fn links_sum_per_key_whatever_their_colour_and_grouping() {
        let mut want: BTreeMap<u64, [u64; 3]> = BTreeMap::new();
        let mut parts = vec![Links::default(), Links::default(), Links::default()];
        for i in 0..3000u64 {
            let h = mix64(i);
            let key = ((h % 37) << 32) | ((h >> 20) % 41);
            let g = (h >> 40) % 1000;
            let q = if h % 5 == 0 {
                [g, g + 1, g + 7]
            } else {
                [g; 3]
            };
            let w = want.entry(key).or_default();
            for (a, b) in w.iter_mut().zip(q) {
                *a += b;
            }
            parts[(h % 3) as usize].push(key, q);
        }
        let mut all = Links::default();
        for p in parts {
            all.extend(p.merged());
            all = all.merged();
        }
        assert!(!all.grey.is_empty() && !all.colour.is_empty());
        let sum = LinkSum {
            held: all.merged(),
            spill: None,
        };
        let got: Vec<(u64, [u64; 3])> = sum.sorted().collect();
        let want: Vec<(u64, [u64; 3])> = want.into_iter().collect();
        assert_eq!(got, want);
    }

    /// The accumulator's sums equal a plain map's, whether its merges come after every
    /// list, every few, or only at the end, with keys before, between and after those
    /// already merged, and empty lists among them; and whether it holds its sum or writes
    /// it out as runs every few entries.
    #[test]
    fn the_accumulator_sums_per_key_whenever_it_merges_or_spills() {
        for (every, spill_at) in [
            (1, usize::MAX),
            (3, usize::MAX),
            (1000, usize::MAX),
            (1, 7),
            (3, 40),
        ] {
            let mut want: BTreeMap<u64, [u64; 3]> = BTreeMap::new();
            let mut acc = Accumulator::spilling_at(spill_at);
            for list in 0..200u64 {
                let mut links = Links::default();
                for i in 0..(list % 7) * 5 {
                    let h = mix64(list << 20 | i);
                    // Few keys, so lists repeat them; the range widens as lists go on.
                    let key = ((h % (3 + list / 10)) << 32) | ((h >> 24) % 13);
                    let g = (h >> 40) % 1000;
                    let q = if h % 4 == 0 { [g, g + 3, 1] } else { [g; 3] };
                    let w = want.entry(key).or_default();
                    for (a, b) in w.iter_mut().zip(q) {
                        *a += b;
                    }
                    links.push(key, q);
                }
                acc.add(links.merged());
                if list % every == 0 {
                    acc.flush();
                    let grey: Vec<u64> = acc.merged.grey.iter().map(|e| e.0).collect();
                    let colour: Vec<u64> = acc.merged.colour.iter().map(|e| e.0).collect();
                    for l in [grey, colour] {
                        assert!(
                            l.windows(2).all(|w| w[0] < w[1]),
                            "sorted, one entry per key"
                        );
                    }
                }
            }
            let sum = acc.finish();
            let got: Vec<(u64, [u64; 3])> = sum.sorted().collect();
            let want: Vec<(u64, [u64; 3])> = want.into_iter().collect();
            assert_eq!(
                got, want,
                "merging every {every} lists, spilling at {spill_at}"
            );
            assert!(sum.most_len() >= want.len());
            assert_eq!(
                sum.runs() > 10,
                spill_at < 100,
                "runs written: {}",
                sum.runs()
            );
        }
    }
}
