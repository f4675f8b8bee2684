//! A part's bounce rows as its file stores them (`docs/reference/coefficient-format.md`, "Shard
//! parts"): an encoding word, each row's length, then the entries, 8 bytes each where every
//! weight is grey (half of what a grey scene's parts wrote, read and checked before).

use rayon::prelude::*;

use crate::bake::bounce_rows::{HitCache, RowBuilder};
use crate::bake::interreflection::{self, Rows};
use crate::formats::header::Header;
use crate::formats::part_id::PartId;

/// First word of a part's bounce rows: the rows' encoding, which also tells a part of an older
/// prt-bake (whose rows begin with the first row's length, never this large) from a current
/// one. RGB: 16-byte entries (slot, 3 × f32).
pub(crate) const ROWS_RGB: u32 = 0xFFFF_FF10;
/// Grey: 8-byte entries (slot, one f32 for R, G and B), written where every entry's three
/// weights are the same bits (a grey scene's: half the bytes to write and read).
pub(crate) const ROWS_GREY: u32 = 0xFFFF_FF08;

/// Bounce rows as a part stores them: the encoding word and the row lengths, then the
/// entries in pieces (in order).
pub struct EncodedRows {
    pub lengths: Vec<u8>,
    pub entries: Vec<Vec<u8>>,
    /// Entries in all.
    pub count: u64,
}

impl EncodedRows {
    /// Bytes in the file.
    pub fn byte_len(&self) -> usize {
        self.lengths.len() + self.entries.iter().map(Vec::len).sum::<usize>()
    }

    /// Bytes of the same rows as [`Rows`] in memory ([`Rows::bytes`]): what
    /// `--hit-cache-mb` bounds.
    pub fn rows_bytes(&self) -> u64 {
        let receivers = (self.lengths.len() / 4).saturating_sub(1) as u64;
        self.count * interreflection::BYTES_PER_ENTRY + 4 * receivers
    }
}

/// The encoding word ([`ROWS_RGB`] or [`ROWS_GREY`]), each row's length (u32), then every
/// entry's vertex (u32) and weight (3 × f32, or one).
pub(crate) fn row_bytes(rows: &Rows) -> EncodedRows {
    let grey = rows.weights.iter().all(is_grey);
    let mut lengths = Vec::with_capacity(4 * rows.starts.len());
    lengths.extend(if grey { ROWS_GREY } else { ROWS_RGB }.to_le_bytes());
    for pair in rows.starts.windows(2) {
        lengths.extend(((pair[1] - pair[0]) as u32).to_le_bytes());
    }
    let size = entry_bytes(grey);
    let mut entries = vec![0u8; size * rows.vertices.len()];
    let chunks = entries.par_chunks_mut(size << 14);
    chunks.enumerate().for_each(|(c, out)| {
        let first = c << 14;
        for (k, entry) in out.chunks_exact_mut(size).enumerate() {
            put_entry(entry, rows.vertices[first + k], &rows.weights[first + k]);
        }
    });
    EncodedRows {
        lengths,
        entries: vec![entries],
        count: rows.vertices.len() as u64,
    }
}

/// The rows of a direct pass's jobs folded and encoded job by job, in parallel, without
/// [`Rows`] in between: a shard's rows at 2048² were 1.5 GB of fresh memory as `Rows`, then
/// 0.8 GB again as bytes.
pub(crate) fn encode_jobs(cache: HitCache) -> EncodedRows {
    // Each thread encodes into one scratch buffer that serves job after job, and each job's
    // entries leave it as one exact allocation: grown in place, they reallocated under the
    // allocator's lock, which both threads of a 2-core shard waited on (2.5 % of its time).
    let jobs: Vec<(Vec<u8>, Vec<u8>, bool)> = (0..cache.job_count())
        .into_par_iter()
        .map_init(
            || (RowBuilder::default(), Vec::new()),
            |(builder, scratch), job| {
                let receivers = cache.receiver_count(job);
                let mut lengths = Vec::with_capacity(4 * receivers);
                let mut grey = true;
                scratch.clear();
                for k in 0..receivers {
                    let (vertices, weights) = cache.row(job, k, builder);
                    lengths.extend((vertices.len() as u32).to_le_bytes());
                    if grey && !weights.iter().all(is_grey) {
                        (*scratch, grey) = (to_rgb(scratch), false);
                    }
                    let size = entry_bytes(grey);
                    let at = scratch.len();
                    scratch.resize(at + size * vertices.len(), 0);
                    let out = scratch[at..].chunks_exact_mut(size);
                    for ((&vertex, weight), entry) in vertices.iter().zip(weights).zip(out) {
                        put_entry(entry, vertex, weight);
                    }
                }
                (lengths, scratch.to_vec(), grey)
            },
        )
        .collect();
    let grey = jobs.iter().all(|(_, _, g)| *g);
    let mut lengths = Vec::with_capacity(4 + jobs.iter().map(|j| j.0.len()).sum::<usize>());
    lengths.extend(if grey { ROWS_GREY } else { ROWS_RGB }.to_le_bytes());
    let mut count = 0;
    let mut pieces = Vec::with_capacity(jobs.len());
    for (job_lengths, entries, job_grey) in jobs {
        lengths.extend(job_lengths);
        count += (entries.len() / entry_bytes(job_grey)) as u64;
        pieces.push(if job_grey && !grey {
            to_rgb(&entries)
        } else {
            entries
        });
    }
    EncodedRows {
        lengths,
        entries: pieces,
        count,
    }
}

fn is_grey([r, g, b]: &[f32; 3]) -> bool {
    r.to_bits() == g.to_bits() && g.to_bits() == b.to_bits()
}

/// Writes an entry into `out` (8 bytes: grey, the first weight only; 16: RGB).
fn put_entry(out: &mut [u8], vertex: u32, weight: &[f32; 3]) {
    out[..4].copy_from_slice(&vertex.to_le_bytes());
    for (o, w) in out[4..].chunks_exact_mut(4).zip(weight) {
        o.copy_from_slice(&w.to_le_bytes());
    }
}

/// Grey entries as RGB ones.
fn to_rgb(grey: &[u8]) -> Vec<u8> {
    let mut rgb = Vec::with_capacity(2 * grey.len());
    for entry in grey.chunks_exact(8) {
        rgb.extend(&entry[..4]);
        for _ in 0..3 {
            rgb.extend(&entry[4..]);
        }
    }
    rgb
}

/// Bytes per entry of grey or RGB rows.
pub(crate) fn entry_bytes(grey: bool) -> usize {
    match grey {
        true => interreflection::GREY_BYTES_PER_ENTRY as usize,
        false => interreflection::BYTES_PER_ENTRY as usize,
    }
}

/// Where each of `id.vertices` rows starts, from the encoding word and the u32 lengths that
/// begin `bytes`, checked against the entries `bytes` holds after them; and whether the
/// entries are grey.
pub(crate) fn row_starts(bytes: &[u8], id: &PartId) -> Result<(Vec<u64>, bool), String> {
    let count = id.vertices as usize;
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    let grey = match bytes.len().checked_sub(4).map(|_| u32_at(0)) {
        Some(ROWS_GREY) => true,
        Some(ROWS_RGB) => false,
        _ => {
            return Err(format!(
                "{id}: bounce rows without their encoding word (a part of an older prt-bake, \
                 before grey rows): bake the shards again"
            ));
        }
    };
    if bytes.len() < 4 + 4 * count {
        return Err(format!(
            "{id}: the payload is {} bytes, too few for {count} bounce-row lengths",
            bytes.len()
        ));
    }
    let mut starts = Vec::with_capacity(count + 1);
    starts.push(0u64);
    for k in 0..count {
        starts.push(starts[k] + u64::from(u32_at(4 + 4 * k)));
    }
    let entries = starts[count];
    let expected = 4 + count as u64 * 4 + entries * entry_bytes(grey) as u64;
    if bytes.len() as u64 != expected {
        return Err(format!(
            "{id}: the bounce rows announce {entries} entries ({expected} bytes), the payload holds {} bytes for them",
            bytes.len()
        ));
    }
    Ok((starts, grey))
}

/// Bounce rows of `id.vertices` vertices as [`row_bytes`] wrote them, each entry checked.
pub(crate) fn parse_rows(bytes: &[u8], id: &PartId, header: &Header) -> Result<Rows, String> {
    let count = id.vertices as usize;
    let (starts, grey) = row_starts(bytes, id)?;
    let entries = starts[count] as usize;
    let size = entry_bytes(grey);
    let mut rows = Rows {
        starts,
        vertices: Vec::with_capacity(entries),
        weights: Vec::with_capacity(entries),
    };
    let body = &bytes[4 + 4 * count..];
    for (e, b) in body.chunks_exact(size).enumerate() {
        let word = |o: usize| b[o..o + 4].try_into().expect("4 bytes");
        let vertex = u32::from_le_bytes(word(0));
        let weight = match grey {
            true => [f32::from_le_bytes(word(4)); 3],
            false => [4, 8, 12].map(|o| f32::from_le_bytes(word(o))),
        };
        if u64::from(vertex) >= header.vertex_count || !weight.iter().all(|w| w.is_finite()) {
            return Err(format!(
                "{id}: bounce-row entry {e} (vertex {vertex}, weight {weight:?}) is invalid"
            ));
        }
        rows.vertices.push(vertex);
        rows.weights.push(weight);
    }
    Ok(rows)
}
