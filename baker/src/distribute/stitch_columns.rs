//! A texel bake's seams stitched in shards of columns (`prt-bake stitch`), so that the merge
//! does no heavy work: stitching is most of a large texel bake's time (docs/performance.md).
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
//! A column file (`PRTCOL`): magic, the xxh3 of the unstitched file's bytes (u64), shard index
//! and count, first column and column count (u32), texel count (u64); the columns' values,
//! texel by texel; an xxh3 of everything before.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::CoefficientFile;
use crate::bake::lightmap::{self, Prepared, Stitching, Texels, stitch};
use crate::distribute::factor_file::FactorFile;
use crate::distribute::merge::refuse;
use crate::distribute::shard::{ShardId, shard_range};
use crate::support::error::{Error, Result};

const MAGIC: &[u8; 8] = b"PRTCOL\0\x01";
const HEAD: usize = 40;

/// Some columns of a stitched lightmap.
#[derive(Clone, Debug, PartialEq)]
pub struct Columns {
    /// xxh3 of the unstitched file's bytes.
    pub key: u64,
    pub shard: ShardId,
    pub first: u32,
    pub count: u32,
    /// `count` floats per texel of the W×H lightmap.
    pub values: Vec<f32>,
}

impl Columns {
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(HEAD + 8 + 4 * self.values.len());
        b.extend(MAGIC);
        b.extend(self.key.to_le_bytes());
        for x in [self.shard.index, self.shard.count, self.first, self.count] {
            b.extend(x.to_le_bytes());
        }
        let texels = self.values.len() as u64 / u64::from(self.count.max(1));
        b.extend(texels.to_le_bytes());
        b.extend(self.values.iter().flat_map(|v| v.to_le_bytes()));
        let sum = xxhash_rust::xxh3::xxh3_64(&b);
        b.extend(sum.to_le_bytes());
        b
    }

    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<Columns, String> {
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
        let texels = u64_at(32);
        let floats = &body[HEAD..];
        if Some(floats.len() as u64) != texels.checked_mul(4 * u64::from(count)) {
            return Err(format!(
                "{} bytes of values for {texels} texels × {count} columns",
                floats.len()
            ));
        }
        if index >= shards {
            return Err(format!("shard {index} of {shards}"));
        }
        Ok(Columns {
            key: u64_at(8),
            shard: ShardId {
                index,
                count: shards,
            },
            first,
            count,
            values: floats
                .chunks_exact(4)
                .map(|w| f32::from_le_bytes(w.try_into().expect("4")))
                .collect(),
        })
    }

    pub fn read(path: &Path) -> Result<Columns> {
        let bytes = std::fs::read(path).map_err(|err| Error::io(path, err))?;
        Columns::from_bytes(&bytes).map_err(|message| Error::coefficient_file(path, message))
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
    let mut values = Vec::with_capacity(l.valid.len() * count);
    for i in 0..l.valid.len() {
        for c in columns.clone() {
            values.push(match (c < width, &file.ao) {
                (true, _) => file.coefficients[i * width + c],
                (false, Some(ao)) => ao[i],
                (false, None) => unreachable!("column_count counts the accessibility"),
            });
        }
    }
    let fields = &mut [(&mut values[..], count)];
    match seams {
        Seams::Prepared(prepared) => {
            let texels = Texels::mask(l.width, l.height, l.valid.clone());
            let stitching = Stitching {
                partners: &prepared.seams,
                uv1: &l.uv1,
            };
            let samples = lightmap::seam_samples(&texels, &l.dilated, &stitching);
            stitch::stitch_fields(&samples, fields)
        }
        Seams::Factored(factor, _) => stitch::stitch_factored(&factor.factored, fields),
    };
    Ok(Columns {
        key,
        shard,
        first: columns.start as u32,
        count: count as u32,
        values,
    })
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
    let mut by_index: BTreeMap<u32, &Path> = BTreeMap::new();
    let mut shards = None;
    let width = file.header.coefficients_per_vertex();
    for column_path in columns {
        let c = Columns::read(column_path)?;
        let name = column_path.display();
        if c.key != key {
            return Err(refuse(format!(
                "{name}: columns of another file than {}",
                path.display()
            )));
        }
        if *shards.get_or_insert(c.shard.count) != c.shard.count {
            return Err(refuse(format!("{name}: {} of another split", c.shard)));
        }
        let range = shard_range(total, c.shard);
        if c.first as usize != range.start || c.count as usize != range.len() {
            return Err(refuse(format!("{name}: not the columns of {}", c.shard)));
        }
        if c.values.len() != file.coefficients.len() / width.max(1) * c.count as usize {
            return Err(refuse(format!(
                "{name}: not as many texels as {}",
                path.display()
            )));
        }
        if let Some(other) = by_index.insert(c.shard.index, column_path) {
            return Err(refuse(format!(
                "{} and {name}: both are {}",
                other.display(),
                c.shard
            )));
        }
        let n = c.count as usize;
        for (i, texel) in c.values.chunks_exact(n.max(1)).enumerate() {
            for (j, &v) in texel.iter().enumerate() {
                let col = range.start + j;
                match (col < width, file.ao.as_mut()) {
                    (true, _) => file.coefficients[i * width + col] = v,
                    (false, Some(ao)) => ao[i] = lightmap::clamp_accessibility(v),
                    (false, None) => unreachable!("column_count counts the accessibility"),
                }
            }
        }
    }
    let shards = shards.ok_or_else(|| Error::InvalidOption("no column files".into()))?;
    let missing: Vec<String> = (0..shards)
        .filter(|i| !by_index.contains_key(i))
        .map(|i| i.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(refuse(format!(
            "the columns of shards {} of {shards} are missing",
            missing.join(", ")
        )));
    }
    file.header.checksum = 0;
    Ok(file)
}
