//! An interreflected bake's bounces distributed bounce by bounce, as dependent job arrays:
//!
//! 1. the shards bake their direct pass and bounce rows into parts (`bake --shard K/N`);
//! 2. `merge --direct` joins the parts' direct transfer into **bounce file 0** (T₀ of every
//!    receiver, with the aux arrays);
//! 3. for k = 1..B: each shard gathers bounce k for its own receivers from its part's rows and
//!    the merged bounce file k − 1 (`prt-bake gather`), and `merge --lower` joins the shards'
//!    gathers into bounce file k, adding bounce k to the running total; the last one writes
//!    the bake's file.
//!
//! Each step is the whole bake's own step (`interreflection::sum_bounces`): a gather reads
//! the previous bounce through [`BounceTargets::slot_values`] (for texels: placed in the
//! lightmap and dilated, not stitched) with [`interreflection::bounce_pass`], and the total is
//! T₀ broadcast to every channel plus each bounce in order, so the last merge writes the
//! whole bake's file byte for byte. No step casts rays but the shards' first.
//!
//! A bounce file (`PRTBNC`): magic, k (u32), shard index and count (u32; count 0: merged,
//! every receiver), 4 reserved bytes, the first receiver and the receiver count (u64), the
//! length (u64) of a *stub* — a part file of no receivers that carries the bake's header and,
//! in a merged file, its lightmap ([`Part`]; a shard's gather leaves the lightmap out, it is
//! tens of megabytes) — the lightmap's fingerprint (u64, 0 for a vertex bake) and the stub;
//! then bounce k at each receiver (n² floats at k = 0, channels × n² after); a merged file
//! with k ≥ 1 also the total T₀ + … + T_k (channels × n²; at k = 0 the total is T₀ broadcast,
//! not stored); a file of the last bounce (k = B: the shards' last gathers) also the aux arrays
//! and, for a denoised bake, the parts' denoiser guides (12 words a receiver,
//! [`crate::distribute::part_guides`]), which each last gather copies from its own part, so
//! that no earlier bounce file carries them: the last merge denoises the total with them, as
//! the whole bake denoises its transfer after the bounces; last an xxh3 of everything before
//! it. Version 1 files (aux and guides in every merged file) are refused: run the stages again.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::CoefficientFile;
use crate::bake::denoise::Guides;
use crate::bake::interreflection::{self, PackedRows, RowSource, Rows};
use crate::bake::transfer::{Estimator, Mode};
use crate::distribute::big_reads::Mapped;
use crate::distribute::merge::{join, refuse};
use crate::distribute::part_guides::{GUIDE_WORDS, guide_bytes, parse_guides};
use crate::distribute::shard::{Part, PartId, ShardId, header_difference, options_of, shard_range};
use crate::formats::encoded::Encoded;
use crate::math::sh;
use crate::support::error::{Error, Result};
use crate::support::progress::Progress;

const MAGIC: &[u8; 8] = b"PRTBNC\0\x02";
/// The first version's magic, refused with a message.
const MAGIC_1: &[u8; 8] = b"PRTBNC\0\x01";
/// Magic, k, shard index, shard count, reserved, first, count, stub length, fingerprint.
const HEAD: usize = 56;

/// What a reading of a bounce file decodes; the rest is checked by the checksum only.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Keep {
    All,
    /// `merge --lower`'s reading of bounce file k − 1: its values only at k − 1 = 0, where
    /// they are the total so far; a gather of bounce k has read them.
    Merge,
    /// A gather's: neither values (read from the file's bytes), total (150 MB at 2048²) nor
    /// guides, and the stub's lightmap mask only.
    Gather,
    /// `merge --lower`'s reading of a gather: all but its values (read from the file's bytes).
    Gathered,
}

/// Bounce k of a range of a bake's receivers (a shard's gather) or of all of them (merged).
#[derive(Clone, Debug, PartialEq)]
pub struct BounceFile {
    pub k: u32,
    /// The gathering shard; `None` for a merged file.
    pub shard: Option<ShardId>,
    pub first: u64,
    pub count: u64,
    /// The bake's header and (merged files) lightmap: a part of no receivers.
    pub stub: Part,
    /// Texel bakes: the lightmap's fingerprint (atlas and baked texels).
    pub fingerprint: Option<u64>,
    /// Bounce k per receiver: n² floats at k = 0 (grey), channels × n² after.
    pub values: Vec<f32>,
    /// Merged files with k ≥ 1: T₀ + … + T_k per receiver (channels × n²; empty at k = 0,
    /// where it is `values` broadcast: [`BounceFile::total_so_far`]).
    pub total: Vec<f32>,
    /// Files of the last bounce (k = B): the aux arrays of their receivers.
    pub ao: Option<Vec<f32>>,
    pub bent_normal: Option<Vec<Vec3>>,
    /// Files of the last bounce of a denoised bake: their receivers' noise and the denoiser's
    /// guides, for the last merge to denoise with ([`crate::distribute::part_guides`]).
    pub guides: Option<Guides>,
}

impl BounceFile {
    fn widths(stub: &Part, k: u32) -> (usize, usize) {
        let n = sh::coeff_count(stub.header.order as usize);
        let total = stub.header.channels as usize * n;
        (if k == 0 { n } else { total }, total)
    }

    /// Whether a file of bounce k carries the aux arrays and guides: only the last bounce's.
    fn carries_aux(stub: &Part, k: u32) -> bool {
        k == stub.header.bounces
    }

    /// T₀ + … + T_k per receiver, taken out of the file: at k = 0, T₀ broadcast to every
    /// channel, as the bake starts its total (T₀ itself where there is one channel).
    fn take_total_so_far(&mut self) -> Vec<f32> {
        let channels = self.stub.header.channels as usize;
        match (self.k, channels) {
            (0, 1) => return std::mem::take(&mut self.values),
            (0, _) => {}
            _ => return std::mem::take(&mut self.total),
        }
        let n = sh::coeff_count(self.stub.header.order as usize);
        let mut total = Vec::with_capacity(self.values.len() * channels);
        for t0 in self.values.chunks_exact(n) {
            for _ in 0..channels {
                total.extend_from_slice(t0);
            }
        }
        total
    }

    pub fn to_bytes(&self) -> Vec<u8> {
        self.encode().into_vec()
    }

    /// The file's bytes in pieces, the arrays borrowed ([`Encoded`]): a merged bounce file is
    /// 55 MB at 2048², which building whole copied into fresh memory before writing.
    pub fn encode(&self) -> Encoded<'_> {
        self.encode_with(None, None)
    }

    /// [`BounceFile::encode`] with the values as the gathers' files hold them (`values`, a
    /// merge's, [`Merged`]) and the guides' words `raw` as a part's file holds them (a last
    /// gather's, [`Gathered`]) where given, instead of [`BounceFile::values`] and
    /// [`BounceFile::guides`].
    fn encode_with<'a>(
        &'a self,
        values: Option<&[&'a [u8]]>,
        raw: Option<&'a [u8]>,
    ) -> Encoded<'a> {
        // The stub's pieces follow the head as they are: its lightmap's arrays borrowed.
        let stub = self.stub.encode();
        let mut head = Vec::with_capacity(HEAD);
        head.extend(MAGIC);
        head.extend(self.k.to_le_bytes());
        let shard = self.shard.unwrap_or(ShardId { index: 0, count: 0 });
        head.extend(shard.index.to_le_bytes());
        head.extend(shard.count.to_le_bytes());
        head.extend(0u32.to_le_bytes());
        head.extend(self.first.to_le_bytes());
        head.extend(self.count.to_le_bytes());
        head.extend((stub.len() as u64).to_le_bytes());
        head.extend(self.fingerprint.unwrap_or(0).to_le_bytes());
        let mut e = Encoded::default();
        e.push(head);
        e.append(stub);
        match values {
            Some(pieces) => pieces.iter().for_each(|p| e.put(p, |b: u8| [b])),
            None => e.put(&self.values, f32::to_le_bytes),
        }
        e.put(&self.total, f32::to_le_bytes);
        e.put(self.ao.as_deref().unwrap_or_default(), f32::to_le_bytes);
        let bent = self.bent_normal.as_deref().unwrap_or_default();
        e.put(bent, |n: Vec3| {
            let mut b = [0u8; 12];
            for (o, f) in b.chunks_exact_mut(4).zip(n.to_array()) {
                o.copy_from_slice(&f.to_le_bytes());
            }
            b
        });
        match raw {
            Some(words) => e.put(words, |b: u8| [b]),
            None => e.push(self.guides.as_ref().map_or(Vec::new(), guide_bytes)),
        }
        let mut hasher = xxhash_rust::xxh3::Xxh3::new();
        for part in e.parts() {
            hasher.update(part);
        }
        e.push(hasher.digest().to_le_bytes().to_vec());
        e
    }

    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<BounceFile, String> {
        Ok(BounceFile::from_bytes_with(bytes, Keep::All)?.0)
    }

    /// [`BounceFile::from_bytes`] keeping what `keep` says (the rest is checked by the
    /// checksum only and left empty), and where the values lie in `bytes`.
    fn from_bytes_with(
        bytes: &[u8],
        keep: Keep,
    ) -> std::result::Result<(BounceFile, usize), String> {
        if bytes.len() >= 8 && &bytes[..8] == MAGIC_1 {
            return Err(
                "a bounce file of an older prt-bake (version 1): run the bake's stages \
                        again from the shards' parts (merge --direct, gather, merge --lower)"
                    .into(),
            );
        }
        if bytes.len() < HEAD + 8 || &bytes[..8] != MAGIC {
            return Err("not a bounce file (prt-bake merge --direct, gather)".into());
        }
        let (body, sum) = bytes.split_at(bytes.len() - 8);
        if xxhash_rust::xxh3::xxh3_64(body).to_le_bytes() != sum {
            return Err("checksum mismatch: the file is truncated or corrupted".into());
        }
        let u32_at = |o: usize| u32::from_le_bytes(body[o..o + 4].try_into().expect("4"));
        let u64_at = |o: usize| u64::from_le_bytes(body[o..o + 8].try_into().expect("8"));
        let (k, index, shards) = (u32_at(8), u32_at(12), u32_at(16));
        let (first, count, stub_len) = (u64_at(24), u64_at(32), u64_at(40));
        let fingerprint = Some(u64_at(48)).filter(|&f| f != 0);
        let stub_end = (HEAD as u64)
            .checked_add(stub_len)
            .filter(|&e| e <= body.len() as u64)
            .ok_or("the stub runs past the end")? as usize;
        let stub = match keep {
            Keep::Gather => Part::stub_mask_from_bytes(&body[HEAD..stub_end])?,
            _ => Part::from_bytes(&body[HEAD..stub_end])?,
        };
        let receivers = stub.receiver_count() as u64;
        if first.checked_add(count).is_none_or(|end| end > receivers) {
            return Err(format!(
                "receivers {first}..+{count} beyond the bake's {receivers}"
            ));
        }
        let merged = shards == 0;
        let stub_fingerprint = stub.lightmap.as_ref().map(|l| l.fingerprint);
        if merged && stub_fingerprint != fingerprint {
            return Err("the stub's lightmap is not the file's".into());
        }
        if merged && (index != 0 || first != 0 || count != receivers) {
            return Err("a merged bounce file that does not hold every receiver".into());
        }
        if !merged && index >= shards {
            return Err(format!("shard {index} of {shards}"));
        }
        let (width, total_width) = BounceFile::widths(&stub, k);
        let aux = stub.header.aux;
        let last = BounceFile::carries_aux(&stub, k);
        let with_total = merged && k > 0;
        let guided = last && stub.header.denoised;
        let per_receiver = width
            + total_width * usize::from(with_total)
            + if last {
                usize::from(aux.ao) + 3 * usize::from(aux.bent_normal)
            } else {
                0
            }
            + GUIDE_WORDS * usize::from(guided);
        let floats = &body[stub_end..];
        let expected = (count as usize)
            .checked_mul(per_receiver * 4)
            .ok_or("sizes overflow")?;
        if floats.len() != expected {
            return Err(format!(
                "{} bytes of arrays, {expected} expected for {count} receivers",
                floats.len()
            ));
        }
        let mut words = floats
            .chunks_exact(4)
            .map(|w| f32::from_le_bytes(w.try_into().expect("4")));
        let count_us = count as usize;
        // Floats read (`keep`) or skipped.
        let mut take = |n: usize, keep: bool| -> Vec<f32> {
            let words = words.by_ref().take(n);
            match keep {
                true => words.collect(),
                false => {
                    words.for_each(drop);
                    Vec::new()
                }
            }
        };
        // A merge reads bounce k − 1 only where it is the total so far (k − 1 = 0).
        let keep_values = match keep {
            Keep::All => true,
            Keep::Merge => k == 0,
            Keep::Gather | Keep::Gathered => false,
        };
        let values = take(count_us * width, keep_values);
        let total = match with_total {
            true => take(count_us * total_width, keep != Keep::Gather),
            false => Vec::new(),
        };
        let ao = (last && aux.ao).then(|| take(count_us, true));
        let bent_normal = (last && aux.bent_normal).then(|| {
            take(3 * count_us, true)
                .chunks_exact(3)
                .map(Vec3::from_slice)
                .collect()
        });
        // A gather reads no guides: only the last merge denoises.
        let guide_len = count_us * GUIDE_WORDS * 4;
        let guides = match guided && keep != Keep::Gather {
            true => Some(parse_guides(&floats[floats.len() - guide_len..], count_us)?),
            false => None,
        };
        let file = BounceFile {
            k,
            shard: (!merged).then_some(ShardId {
                index,
                count: shards,
            }),
            first,
            count,
            stub,
            fingerprint,
            values,
            total,
            ao,
            bent_normal,
            guides,
        };
        Ok((file, stub_end))
    }

    pub fn read(path: &Path) -> Result<BounceFile> {
        Ok(BounceFile::read_with(path, Keep::All)?.0)
    }

    /// [`BounceFile::read`] keeping what `keep` says; also the file's bytes and where its
    /// values lie in them.
    fn read_with(path: &Path, keep: Keep) -> Result<(BounceFile, Mapped, usize)> {
        let bytes = crate::distribute::big_reads::map(path)?;
        let (file, at) = BounceFile::from_bytes_with(&bytes, keep)
            .map_err(|message| Error::coefficient_file(path, message))?;
        Ok((file, bytes, at))
    }

    /// Writes the file atomically, in pieces.
    pub fn write(&self, path: &Path) -> Result<()> {
        let output = crate::support::output::Output::new(path, &[])?;
        output.write_parts(&self.encode().parts())
    }

    /// Whether every bounce of the bake is in: the total is the bake's transfer.
    pub fn is_last(&self) -> bool {
        self.k == self.stub.header.bounces
    }

    /// The bake's file from the last merged bounce file ([`BounceFile::is_last`]); a texel
    /// bake's lightmap stitched only with `stitch`.
    pub fn into_file(mut self, stitch: bool) -> CoefficientFile {
        let receivers = self.stub.receiver_count();
        let total = self.take_total_so_far();
        let part = Part {
            id: PartId {
                shard: ShardId { index: 0, count: 1 },
                first_vertex: 0,
                vertices: receivers as u32,
            },
            ao: self.ao,
            bent_normal: self.bent_normal,
            guides: self.guides,
            ..self.stub
        };
        part.into_file_with(total, stitch)
    }
}

/// A part of no receivers that carries `part`'s header and lightmap (taken out of `part`).
fn stub_of(part: &mut Part) -> Part {
    let aux = part.header.aux;
    Part {
        header: part.header.clone(),
        id: PartId {
            shard: ShardId { index: 0, count: 1 },
            first_vertex: 0,
            vertices: 0,
        },
        coefficients: Vec::new(),
        ao: aux.ao.then(Vec::new),
        bent_normal: aux.bent_normal.then(Vec::new),
        rows: Some(Rows {
            starts: vec![0],
            vertices: Vec::new(),
            weights: Vec::new(),
        }),
        lightmap: part.lightmap.take(),
        guides: part.header.denoised.then(Default::default),
    }
}

/// The fingerprint of a part's lightmap.
fn fingerprint(part: &Part) -> Option<u64> {
    part.lightmap.as_ref().map(|l| l.fingerprint)
}

/// Refuses a file at `path` (its header and lightmap fingerprint) unless it is of the bake of
/// `lower` (at `lower_path`).
fn check_same_bake(
    lower: &BounceFile,
    other: (&crate::formats::header::Header, Option<u64>),
    path: &Path,
    lower_path: &Path,
) -> Result<()> {
    let difference = header_difference(&lower.stub.header, other.0).or_else(|| {
        (lower.fingerprint != other.1)
            .then(|| "another lightmap atlas or set of baked texels".to_string())
    });
    match difference {
        Some(d) => Err(refuse(format!(
            "{}: of another bake than {}: {d}",
            path.display(),
            lower_path.display()
        ))),
        None => Ok(()),
    }
}

/// `merge --direct`: bounce file 0 from every part of an interreflected bake (their direct
/// transfer, joined; the total so far is T₀ broadcast, not stored). The aux arrays and guides
/// stay in the parts: the last bounce's gathers carry them on.
pub fn direct(paths: &[PathBuf]) -> Result<Merged> {
    let (header, _, mut whole) = join(paths, false)?;
    if header.mode != Mode::Interreflected {
        return Err(Error::InvalidOption(
            "merge --direct is for interreflected bakes (the others have no bounces)".into(),
        ));
    }
    // Without bounces bounce file 0 is the last one: it carries the aux arrays and guides.
    let last = header.bounces == 0;
    if last {
        whole = join(paths, true)?.2;
    }
    let fingerprint = fingerprint(&whole);
    let count = whole.receiver_count() as u64;
    let stub = stub_of(&mut whole);
    let file = BounceFile {
        k: 0,
        shard: None,
        first: 0,
        count,
        fingerprint,
        values: whole.coefficients,
        total: Vec::new(),
        ao: whole.ao.filter(|_| last),
        bent_normal: whole.bent_normal.filter(|_| last),
        guides: whole.guides.filter(|_| last),
        stub,
    };
    Ok(Merged {
        file,
        values: Vec::new(),
    })
}

/// A shard's gather ([`gather`]): its bounce file, which the last bounce's gather writes with
/// the part's guides as the part's file holds them (12 words a receiver, copied once rather
/// than decoded and encoded again: 25 MB a shard at 1024²).
pub struct Gathered {
    pub file: BounceFile,
    /// The part's rows, which hold its file's bytes.
    rows: PackedRows,
    /// Where the guides lie in them (the last bounce of a denoised bake).
    guides: Option<std::ops::Range<usize>>,
}

impl Gathered {
    /// The gather's file in pieces ([`BounceFile::encode`]).
    pub fn encode(&self) -> Encoded<'_> {
        let raw = self.guides.clone().map(|r| &self.rows.file_bytes()[r]);
        self.file.encode_with(None, raw)
    }
}

/// `prt-bake gather`: bounce k + 1 at the receivers of the part at `part_path`, from its rows
/// and the merged bounce file k at `lower_path`.
pub fn gather(part_path: &Path, lower_path: &Path, progress: &dyn Progress) -> Result<Gathered> {
    let (lower, lower_bytes, values_at) = BounceFile::read_with(lower_path, Keep::Gather)?;
    // The last bounce's gather carries the part's aux arrays and guides to the last merge.
    let last = BounceFile::carries_aux(&lower.stub, lower.k + 1);
    let (part, rows) = Part::read_packed_rows(part_path, last)?;
    if lower.shard.is_some() {
        return Err(refuse(format!(
            "{}: one shard's gather, not a merged bounce file (merge the shards' gathers first)",
            lower_path.display()
        )));
    }
    check_same_bake(
        &lower,
        (&part.header, fingerprint(&part)),
        part_path,
        lower_path,
    )?;
    if lower.is_last() {
        return Err(refuse(format!(
            "{}: holds bounce {} of {}: every bounce is gathered",
            lower_path.display(),
            lower.k,
            lower.stub.header.bounces
        )));
    }
    let options = options_of(&part.header);
    let n = sh::coeff_count(options.order);
    let channels = part.header.channels as usize;
    let previous_channels = if lower.k == 0 { 1 } else { channels };
    let k = lower.k + 1;
    progress.begin(&format!("bounce {k}"), u64::from(part.id.vertices), 0);
    // The previous bounce, from the file's bytes; texel bakes: in the lightmap, dilated, as
    // the bake reads it.
    let values =
        &lower_bytes[values_at..values_at + lower.count as usize * previous_channels * n * 4];
    let previous = match &lower.stub.lightmap {
        Some(l) => l.placed_and_dilated(values, previous_channels * n),
        None => values
            .chunks_exact(4)
            .map(|w| f32::from_le_bytes(w.try_into().expect("4")))
            .collect(),
    };
    let mut values = vec![0.0f32; part.id.vertices as usize * channels * n];
    interreflection::bounce_pass(
        &RowSource::Packed(&rows),
        Estimator::norm_of(&options) as f32,
        n,
        &previous,
        previous_channels,
        channels,
        &mut values,
        progress,
    );
    progress.finish();
    let guides = match last {
        true => part.guide_words_at(),
        false => None,
    };
    let file = BounceFile {
        k,
        shard: Some(part.id.shard),
        first: part.id.first_vertex,
        count: u64::from(part.id.vertices),
        // The header only: the merge has the lightmap (in the lower bounce file).
        stub: Part {
            lightmap: None,
            ..lower.stub
        },
        fingerprint: lower.fingerprint,
        values,
        total: Vec::new(),
        ao: part.ao,
        bent_normal: part.bent_normal,
        guides: None,
    };
    Ok(Gathered { file, rows, guides })
}

/// A merge's bounce file ([`merge`], [`direct`]): a `merge --lower`'s values stay in the
/// gathers' files, written from there (two copies of them in fresh memory before: 38 MB
/// each at 1024²).
pub struct Merged {
    pub file: BounceFile,
    /// The gathers' bytes and where their values lie, in shard order; empty: the file's own
    /// [`BounceFile::values`].
    values: Vec<(Mapped, std::ops::Range<usize>)>,
}

impl Merged {
    /// The merged file in pieces ([`BounceFile::encode`]).
    pub fn encode(&self) -> Encoded<'_> {
        let pieces: Vec<&[u8]> = self.values.iter().map(|(b, r)| &b[r.clone()]).collect();
        match pieces.is_empty() {
            true => self.file.encode(),
            false => self.file.encode_with(Some(&pieces), None),
        }
    }
}

/// `merge --lower`: bounce file k from every shard's gather of bounce k (`paths`, any order)
/// and the merged bounce file k − 1 (`lower_path`): bounce k joined, and added to the total.
pub fn merge(paths: &[PathBuf], lower_path: &Path) -> Result<Merged> {
    let mut lower = BounceFile::read_with(lower_path, Keep::Merge)?.0;
    if lower.shard.is_some() {
        return Err(refuse(format!(
            "{}: one shard's gather, not a merged bounce file",
            lower_path.display()
        )));
    }
    let k = lower.k + 1;
    let receivers = lower.count as usize;
    let mut by_index: BTreeMap<u32, (&Path, BounceFile, Mapped, usize)> = BTreeMap::new();
    let mut count = None;
    for path in paths {
        let (file, bytes, at) = BounceFile::read_with(path, Keep::Gathered)?;
        check_same_bake(
            &lower,
            (&file.stub.header, file.fingerprint),
            path,
            lower_path,
        )?;
        let Some(shard) = file.shard else {
            return Err(refuse(format!(
                "{}: a merged bounce file, not a shard's gather",
                path.display()
            )));
        };
        if file.k != k {
            return Err(refuse(format!(
                "{}: bounce {}, but {} holds bounce {} (so the gathers must be of bounce {k})",
                path.display(),
                file.k,
                lower_path.display(),
                lower.k
            )));
        }
        if *count.get_or_insert(shard.count) != shard.count {
            return Err(refuse(format!(
                "{}: {shard} of a bake split {} ways, the others {} ways",
                path.display(),
                shard.count,
                count.unwrap_or(0)
            )));
        }
        let range = shard_range(receivers, shard);
        if file.first != range.start as u64 || file.count != range.len() as u64 {
            return Err(refuse(format!(
                "{}: holds receivers {}..+{}, but {shard} is {}..{}",
                path.display(),
                file.first,
                file.count,
                range.start,
                range.end
            )));
        }
        if let Some((other, ..)) = by_index.get(&shard.index) {
            return Err(refuse(format!(
                "{} and {}: both are {shard}",
                other.display(),
                path.display()
            )));
        }
        by_index.insert(shard.index, (path.as_path(), file, bytes, at));
    }
    let count = count.ok_or_else(|| Error::InvalidOption("merge needs the gathers".into()))?;
    let missing: Vec<String> = (0..count)
        .filter(|i| !by_index.contains_key(i))
        .map(|i| i.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(refuse(format!(
            "bounce {k}: the gathers of shards {} of {count} are missing",
            missing.join(", ")
        )));
    }
    let mut total = lower.take_total_so_far();
    let width = BounceFile::widths(&lower.stub, k).0;
    let mut values = Vec::new();
    // The last bounce's gathers carry their receivers' aux arrays and guides, in shard order.
    let (mut ao, mut bent_normal, mut guides) = (None, None, None);
    let mut totals = &mut total[..];
    for (_, file, bytes, at) in by_index.into_values() {
        // The running total, as `sum_bounces` adds each bounce.
        let floats = file.count as usize * width;
        let range = at..at + floats * 4;
        let (these, rest) = std::mem::take(&mut totals).split_at_mut(floats);
        for (t, w) in these.iter_mut().zip(bytes[range.clone()].chunks_exact(4)) {
            *t += f32::from_le_bytes(w.try_into().expect("4 bytes"));
        }
        totals = rest;
        values.push((bytes, range));
        join_aux(&mut ao, file.ao);
        join_aux(&mut bent_normal, file.bent_normal);
        match (&mut guides, file.guides) {
            (None, more) => guides = more,
            (Some(g), Some(more)) => g.append(more),
            (Some(_), None) => {}
        }
    }
    let file = BounceFile {
        k,
        values: Vec::new(),
        total,
        ao,
        bent_normal,
        guides,
        ..lower
    };
    Ok(Merged { file, values })
}

/// Appends a gather's aux array to the ones before it.
fn join_aux<T>(joined: &mut Option<Vec<T>>, more: Option<Vec<T>>) {
    match (joined.as_mut(), more) {
        (None, more) => *joined = more,
        (Some(j), Some(more)) => j.extend(more),
        (Some(_), None) => {}
    }
}
