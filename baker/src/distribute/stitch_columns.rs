//! A texel bake's seams stitched in shards of columns (`prt-bake stitch`), so that the merge
//! does no heavy work: stitching is most of a large texel bake's time (docs/explanation/performance.md).
//!
//! The stitch solves one least-squares system per column of the lightmap (each coefficient,
//! and the accessibility), every column by its own solve, as if alone
//! ([`crate::bake::lightmap::stitch::stitch_fields`]); so a shard that stitches columns
//! j..j' of the merged, *unstitched* file (`merge --unstitched`) gets exactly the whole bake's
//! values of those columns, and the join puts them back: the whole bake's file, byte for byte.
//! The seam partners come from the prepared lightmap (`prt-bake prepare-lightmap`), checked
//! against the file's atlas and baked texels; or the shard reads the system factored once for
//! all shards (`prt-bake factor-seams`, [`crate::distribute::factor_file`]), checked against
//! the file by fingerprint, and only solves.
//!
//! The stitch moves only the texels its system solves for (the seams' unknowns, a fifth of
//! the heightfield's 2048² lightmap); every other texel keeps its unstitched value. So a
//! column file holds those texels only, and the join ([`crate::distribute::column_join`])
//! writes them over the unstitched file's bytes.
//!
//! A column file (`PRTCOL`, version 2): magic, the xxh3 of the unstitched file's bytes (u64),
//! shard index and count, first column and column count (u32), the number of stitched texels
//! m (u64), the lightmap's texel count (u64); the m stitched texels (u32, the factor's order),
//! then their columns' values, texel by texel; an xxh3 of everything before.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::CoefficientFile;
use crate::bake::lightmap::{self, Prepared, Stitching, Texels, stitch};
use crate::distribute::factor_file::FactorFile;
use crate::distribute::merge::refuse;
use crate::distribute::shard::{ShardId, shard_range};
use crate::support::error::{Error, Result};

const MAGIC: &[u8; 8] = b"PRTCOL\0\x02";
/// The magic of the dense column files before version 2, named in the refusal.
const OLD_MAGIC: &[u8; 8] = b"PRTCOL\0\x01";
const HEAD: usize = 48;

/// Some columns of a stitched lightmap.
#[derive(Clone, Debug, PartialEq)]
pub struct Columns {
    /// xxh3 of the unstitched file's bytes.
    pub key: u64,
    pub shard: ShardId,
    pub first: u32,
    pub count: u32,
    /// The lightmap's texel count (W·H).
    pub lightmap_texels: u64,
    /// The stitched texels (row-major indices), in the factor's order.
    pub texels: Vec<u32>,
    /// `count` floats per stitched texel.
    pub values: Vec<f32>,
}

impl Columns {
    pub fn to_bytes(&self) -> Vec<u8> {
        let floats = 4 * (self.texels.len() + self.values.len());
        let mut b = Vec::with_capacity(HEAD + floats + 8);
        b.extend(MAGIC);
        b.extend(self.key.to_le_bytes());
        for x in [self.shard.index, self.shard.count, self.first, self.count] {
            b.extend(x.to_le_bytes());
        }
        b.extend((self.texels.len() as u64).to_le_bytes());
        b.extend(self.lightmap_texels.to_le_bytes());
        for t in &self.texels {
            b.extend_from_slice(&t.to_le_bytes());
        }
        for v in &self.values {
            b.extend_from_slice(&v.to_le_bytes());
        }
        let sum = xxhash_rust::xxh3::xxh3_64(&b);
        b.extend(sum.to_le_bytes());
        b
    }

    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<Columns, String> {
        let (head, body) = ColumnsHead::parse(bytes)?;
        let u32s = |b: &[u8]| -> Vec<u32> {
            b.chunks_exact(4)
                .map(|w| u32::from_le_bytes(w.try_into().expect("4")))
                .collect()
        };
        Ok(Columns {
            key: head.key,
            shard: head.shard,
            first: head.first,
            count: head.count,
            lightmap_texels: head.lightmap_texels,
            texels: u32s(body.texels),
            values: u32s(body.values).into_iter().map(f32::from_bits).collect(),
        })
    }

    pub fn read(path: &Path) -> Result<Columns> {
        let bytes = std::fs::read(path).map_err(|err| Error::io(path, err))?;
        Columns::from_bytes(&bytes).map_err(|message| Error::coefficient_file(path, message))
    }
}

/// A column file's fields without its arrays: what the join checks before it copies them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColumnsHead {
    pub key: u64,
    pub shard: ShardId,
    pub first: u32,
    pub count: u32,
    /// How many texels the file holds (the stitched ones).
    pub stitched: u64,
    pub lightmap_texels: u64,
}

/// A column file's arrays, as little-endian bytes.
pub struct ColumnsBody<'a> {
    /// The stitched texels (u32 each), every one inside the lightmap.
    pub texels: &'a [u8],
    /// `count` floats per stitched texel.
    pub values: &'a [u8],
}

impl ColumnsHead {
    /// Checks a column file's `bytes` (magic, checksum, sizes, texel indices) and returns its
    /// fields and arrays.
    pub fn parse(bytes: &[u8]) -> std::result::Result<(ColumnsHead, ColumnsBody<'_>), String> {
        if bytes.len() >= 8 && &bytes[..8] == OLD_MAGIC {
            return Err(
                "a column file of an earlier prt-bake (every texel; now only the stitched ones): stitch the columns again".into(),
            );
        }
        if bytes.len() < HEAD + 8 || &bytes[..8] != MAGIC {
            return Err("not a column file (prt-bake stitch --columns)".into());
        }
        let (body, sum) = bytes.split_at(bytes.len() - 8);
        if xxhash_rust::xxh3::xxh3_64(body).to_le_bytes() != sum {
            return Err("checksum mismatch: the file is truncated or corrupted".into());
        }
        let u32_at = |o: usize| u32::from_le_bytes(body[o..o + 4].try_into().expect("4"));
        let u64_at = |o: usize| u64::from_le_bytes(body[o..o + 8].try_into().expect("8"));
        let (index, shards, first, count) = (u32_at(16), u32_at(20), u32_at(24), u32_at(28));
        let (stitched, lightmap_texels) = (u64_at(32), u64_at(40));
        let arrays = &body[HEAD..];
        if Some(arrays.len() as u64) != stitched.checked_mul(4 * (1 + u64::from(count))) {
            return Err(format!(
                "{} bytes of arrays for {stitched} texels × {count} columns",
                arrays.len()
            ));
        }
        if index >= shards {
            return Err(format!("shard {index} of {shards}"));
        }
        let (texels, values) = arrays.split_at(4 * stitched as usize);
        if let Some(t) = texels
            .chunks_exact(4)
            .map(|w| u32::from_le_bytes(w.try_into().expect("4")))
            .find(|&t| u64::from(t) >= lightmap_texels)
        {
            return Err(format!(
                "texel {t} outside the lightmap's {lightmap_texels}"
            ));
        }
        let shard = ShardId {
            index,
            count: shards,
        };
        let head = ColumnsHead {
            key: u64_at(8),
            shard,
            first,
            count,
            stitched,
            lightmap_texels,
        };
        Ok((head, ColumnsBody { texels, values }))
    }
}

/// The column files a join has taken: each checked against the file and the others.
#[derive(Default)]
pub struct ShardsSeen<'a> {
    by_index: BTreeMap<u32, &'a Path>,
    shards: Option<u32>,
}

impl<'a> ShardsSeen<'a> {
    /// Refuses the column file at `column_path` (`head`) unless its columns are of the
    /// unstitched file at `path` (key `key`, `total` columns, `texels` texels), of the split
    /// of the others, and new; returns its columns.
    pub fn check(
        &mut self,
        path: &Path,
        key: u64,
        column_path: &'a Path,
        head: &ColumnsHead,
        total: usize,
        texels: usize,
    ) -> Result<std::ops::Range<usize>> {
        let name = column_path.display();
        if head.key != key {
            return Err(refuse(format!(
                "{name}: columns of another file than {}",
                path.display()
            )));
        }
        if *self.shards.get_or_insert(head.shard.count) != head.shard.count {
            return Err(refuse(format!("{name}: {} of another split", head.shard)));
        }
        let range = shard_range(total, head.shard);
        if head.first as usize != range.start || head.count as usize != range.len() {
            return Err(refuse(format!("{name}: not the columns of {}", head.shard)));
        }
        if head.lightmap_texels != texels as u64 {
            return Err(refuse(format!(
                "{name}: not as many texels as {}",
                path.display()
            )));
        }
        if let Some(other) = self.by_index.insert(head.shard.index, column_path) {
            return Err(refuse(format!(
                "{} and {name}: both are {}",
                other.display(),
                head.shard
            )));
        }
        Ok(range)
    }

    /// Refuses a join that misses a shard's columns (or has none).
    pub fn finish(self) -> Result<()> {
        let shards = self
            .shards
            .ok_or_else(|| Error::InvalidOption("no column files".into()))?;
        let missing: Vec<String> = (0..shards)
            .filter(|i| !self.by_index.contains_key(i))
            .map(|i| i.to_string())
            .collect();
        if !missing.is_empty() {
            return Err(refuse(format!(
                "the columns of shards {} of {shards} are missing",
                missing.join(", ")
            )));
        }
        Ok(())
    }
}

/// The unstitched texel file at `path`: its bytes' key and the file.
pub fn read_unstitched(path: &Path) -> Result<(u64, CoefficientFile)> {
    let bytes = std::fs::read(path).map_err(|err| Error::io(path, err))?;
    let file = CoefficientFile::from_bytes(&bytes)
        .map_err(|message| Error::coefficient_file(path, message))?;
    if file.lightmap.is_none() {
        return Err(Error::coefficient_file(
            path,
            "not a lightmap (texel) bake: nothing to stitch",
        ));
    }
    Ok((xxhash_rust::xxh3::xxh3_64(&bytes), file))
}

/// The file's stitched columns: every coefficient, then the accessibility where it has one.
fn column_count(file: &CoefficientFile) -> usize {
    file.header.coefficients_per_vertex() + usize::from(file.ao.is_some())
}

/// Where a stitch shard's system comes from.
pub enum Seams<'a> {
    /// The prepared lightmap (`prt-bake prepare-lightmap`), for its seam partners: the shard
    /// finds the seam samples and factors their system.
    Prepared(&'a Prepared),
    /// The system factored already (`prt-bake factor-seams`), at the path given.
    Factored(&'a FactorFile, &'a Path),
}

/// Stitches `shard`'s columns of the unstitched `file` (key `key`, at `path`) along the seams
/// of a prepared lightmap or with their factor (`seams`), refused (exit 3) where either is not
/// of the file's atlas and texels.
pub fn stitch_shard(
    path: &Path,
    key: u64,
    file: &CoefficientFile,
    seams: Seams<'_>,
    shard: ShardId,
) -> Result<Columns> {
    let l = file.lightmap.as_ref().expect("read_unstitched checked");
    match seams {
        Seams::Prepared(prepared)
            if l.uv1 != prepared.atlas.uv1 || l.valid != prepared.texels.valid =>
        {
            return Err(refuse(format!(
                "{}: another atlas or other baked texels than the prepared lightmap's",
                path.display()
            )));
        }
        Seams::Factored(factor, factor_path) => factor.check(factor_path, path, l)?,
        Seams::Prepared(_) => {}
    }
    let width = file.header.coefficients_per_vertex();
    let columns = shard_range(column_count(file), shard);
    let count = columns.len();
    let factored_here;
    let factored = match seams {
        Seams::Prepared(prepared) => {
            let texels = Texels::mask(l.width, l.height, l.valid.clone());
            let stitching = Stitching {
                partners: &prepared.seams,
                uv1: &l.uv1,
            };
            let samples = lightmap::seam_samples(&texels, &l.dilated, &stitching);
            factored_here = stitch::factor(&samples);
            &factored_here
        }
        Seams::Factored(factor, _) => &factor.factored,
    };
    // The solve reads and writes only the texels of its system (a fifth of the heightfield's
    // lightmap), so only theirs are copied: the zeroed rest stays untouched pages.
    let texels = factored
        .factor()
        .map_or(Vec::new(), |f| f.texels().to_vec());
    let mut values = vec![0.0f32; l.valid.len() * count];
    for &t in &texels {
        let i = t as usize;
        for (v, c) in values[i * count..(i + 1) * count]
            .iter_mut()
            .zip(columns.clone())
        {
            *v = match (c < width, &file.ao) {
                (true, _) => file.coefficients[i * width + c],
                (false, Some(ao)) => ao[i],
                (false, None) => unreachable!("column_count counts the accessibility"),
            };
        }
    }
    stitch::stitch_factored(factored, &mut [(&mut values[..], count)]);
    // Only the texels the system solves for moved: the join keeps the others' bytes.
    let mut stitched = Vec::with_capacity(texels.len() * count);
    for &t in &texels {
        stitched.extend_from_slice(&values[t as usize * count..(t as usize + 1) * count]);
    }
    Ok(Columns {
        key,
        shard,
        first: columns.start as u32,
        count: count as u32,
        lightmap_texels: l.valid.len() as u64,
        texels,
        values: stitched,
    })
}

/// The unstitched texel `file` (at `path`, in memory) stitched with the seams' system
/// factored already (`prt-bake factor-seams`, at `factor_path`): one shard of every column
/// ([`stitch_shard`]) put back as [`join`] puts a column file's, so the last merge writes the
/// stitched file without an unstitched file or column files between. Refused (exit 3) where
/// the file is no texel bake or the factor is not of its lightmap.
pub fn stitch_with_factor(
    path: &Path,
    mut file: CoefficientFile,
    factor_path: &Path,
) -> Result<CoefficientFile> {
    if file.lightmap.is_none() {
        return Err(refuse(format!(
            "{}: a vertex bake: --factor stitches a lightmap's seams (texel bakes only)",
            path.display()
        )));
    }
    let factor = FactorFile::read(factor_path)?;
    let every = ShardId { index: 0, count: 1 };
    let seams = Seams::Factored(&factor, factor_path);
    let columns = stitch_shard(path, 0, &file, seams, every)?;
    put(
        &mut file,
        0,
        &columns.texels,
        &columns.values,
        columns.count as usize,
    );
    file.header.checksum = 0;
    Ok(file)
}

/// Writes the stitched `texels`' values (`n` columns each from column `first`) over `file`'s,
/// the accessibility clamped as the whole bake clamps it.
fn put(file: &mut CoefficientFile, first: usize, texels: &[u32], values: &[f32], n: usize) {
    let width = file.header.coefficients_per_vertex();
    for (&i, texel) in texels.iter().zip(values.chunks_exact(n.max(1))) {
        let i = i as usize;
        for (j, &v) in texel.iter().enumerate() {
            let col = first + j;
            match (col < width, file.ao.as_mut()) {
                (true, _) => file.coefficients[i * width + col] = v,
                (false, Some(ao)) => ao[i] = lightmap::clamp_accessibility(v),
                (false, None) => unreachable!("column_count counts the accessibility"),
            }
        }
    }
}

/// The stitched file: the unstitched `file` (key `key`, at `path`) with every shard's columns
/// (`columns`, any order) put back, the accessibility clamped as the whole bake clamps it.
pub fn join(
    path: &Path,
    key: u64,
    mut file: CoefficientFile,
    columns: &[PathBuf],
) -> Result<CoefficientFile> {
    let total = column_count(&file);
    let width = file.header.coefficients_per_vertex();
    let texels = file.coefficients.len() / width.max(1);
    let mut seen = ShardsSeen::default();
    for column_path in columns {
        let c = Columns::read(column_path)?;
        let head = ColumnsHead {
            key: c.key,
            shard: c.shard,
            first: c.first,
            count: c.count,
            stitched: c.texels.len() as u64,
            lightmap_texels: c.lightmap_texels,
        };
        let range = seen.check(path, key, column_path, &head, total, texels)?;
        put(
            &mut file,
            range.start,
            &c.texels,
            &c.values,
            c.count as usize,
        );
    }
    seen.finish()?;
    file.header.checksum = 0;
    Ok(file)
}
