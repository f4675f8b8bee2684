//! `prt-bake stitch --join` on the unstitched file's bytes: every shard's stitched columns
//! written over them where they lie, the checksum set again, and nothing else touched. The
//! stitch changes only those columns, so re-parsing the 172 MB file into arrays and encoding
//! it again (what [`stitch_columns::join`] does) copied it three times for the same bytes.
//!
//! The file is checked as far as its layout needs (framing, checksum, a texel file's
//! header, the arrays' extent); its floats were checked by the stitch shards, which read the
//! very bytes the column files' key names. A file in another encoding (compressed) goes the
//! long way, through [`stitch_columns::join`].

use std::io::Read;
use std::path::{Path, PathBuf};

use crate::CoefficientFile;
use crate::bake::lightmap;
use crate::distribute::stitch_columns::{self, ColumnsBody, ColumnsHead};
use crate::formats::coefficient_file::LIGHTMAP_HEADER_SIZE;
use crate::formats::cpca_block;
use crate::formats::header::{CHECKSUM_OFFSET, HEADER_SIZE, checksum, parse_header};
use crate::formats::part_id::PartId;
use crate::support::error::{Error, Result};

/// Where a texel file's stitched arrays lie in its bytes.
#[derive(Debug)]
struct Layout {
    texels: usize,
    /// Coefficients per texel.
    width: usize,
    /// The first coefficient's byte.
    coefficients: usize,
    /// The first accessibility's byte, where the file has them.
    ao: Option<usize>,
}

/// The layout of a plain (uncompressed) texel file's `bytes`, checked; `None` for a file this
/// join leaves to the long way, `Err` for one that is no texel file.
fn layout(bytes: &[u8]) -> std::result::Result<Option<Layout>, String> {
    if cpca_block::is_compressed(bytes) {
        return Ok(None);
    }
    let (header, payload, header_size) = parse_header(bytes)?;
    if header_size != LIGHTMAP_HEADER_SIZE || PartId::from_header_bytes(bytes)?.is_some() {
        return Err("not a lightmap (texel) bake: nothing to stitch".into());
    }
    let texels = header.vertex_count as usize;
    let width = header.coefficients_per_vertex();
    let coefficient_bytes = texels.checked_mul(width * 4).ok_or("sizes overflow")?;
    let ao_bytes = if header.aux.ao { 4 * texels } else { 0 };
    if (coefficient_bytes as u64).saturating_add(ao_bytes as u64) > payload {
        return Err(format!(
            "{texels} texels × {width} coefficients need more than the {payload} bytes the header announces"
        ));
    }
    let coefficients = header_size;
    Ok(Some(Layout {
        texels,
        width,
        coefficients,
        ao: header.aux.ao.then_some(coefficients + coefficient_bytes),
    }))
}

/// The stitched file's bytes: the unstitched file's `bytes` (at `path`) with every shard's
/// columns (`columns`, any order) written over them, the accessibility clamped as the whole
/// bake clamps it; the same bytes as [`stitch_columns::join`] encodes.
pub fn join(path: &Path, mut bytes: Vec<u8>, columns: &[PathBuf]) -> Result<Vec<u8>> {
    let key = xxhash_rust::xxh3::xxh3_64(&bytes);
    let fail = |message: String| Error::coefficient_file(path, message);
    let Some(layout) = layout(&bytes).map_err(fail)? else {
        let file = CoefficientFile::from_bytes(&bytes).map_err(fail)?;
        if file.lightmap.is_none() {
            return Err(fail(
                "not a lightmap (texel) bake: nothing to stitch".into(),
            ));
        }
        let file = stitch_columns::join(path, key, file, columns)?;
        return Ok(file.to_bytes().0);
    };
    let total = layout.width + usize::from(layout.ao.is_some());
    let mut seen = stitch_columns::ShardsSeen::default();
    // One buffer for every column file: its pages are touched once, not once a file.
    let mut buffer = Vec::new();
    for column_path in columns {
        buffer.clear();
        std::fs::File::open(column_path)
            .and_then(|mut f| f.read_to_end(&mut buffer))
            .map_err(|err| Error::io(column_path, err))?;
        let (head, body) = ColumnsHead::parse(&buffer)
            .map_err(|message| Error::coefficient_file(column_path, message))?;
        let range = seen.check(path, key, column_path, &head, total, layout.texels)?;
        put(&mut bytes, &layout, range, &body);
    }
    seen.finish()?;
    let sum = checksum(&bytes);
    bytes[CHECKSUM_OFFSET..HEADER_SIZE].copy_from_slice(&sum.to_le_bytes());
    Ok(bytes)
}

/// Writes the stitched texels' values of columns `range` (`body`) over the file's `bytes`.
fn put(bytes: &mut [u8], layout: &Layout, range: std::ops::Range<usize>, body: &ColumnsBody<'_>) {
    let n = range.len();
    if n == 0 {
        return;
    }
    // The coefficient columns of the range, then the accessibility where the range holds it.
    let coefficients = range.start.min(layout.width)..range.end.min(layout.width);
    let run = 4 * coefficients.len();
    let ao = layout.ao.filter(|_| range.end > layout.width);
    let texels = body.texels.chunks_exact(4);
    for (t, texel) in texels.zip(body.values.chunks_exact(4 * n)) {
        // parse checked every index against the lightmap, check it against the file's.
        let i = u32::from_le_bytes(t.try_into().expect("4 bytes")) as usize;
        if run > 0 {
            let at = layout.coefficients + 4 * (i * layout.width + coefficients.start);
            bytes[at..at + run].copy_from_slice(&texel[..run]);
        }
        if let Some(ao) = ao {
            let v = f32::from_le_bytes(texel[4 * n - 4..].try_into().expect("4 bytes"));
            let at = ao + 4 * i;
            bytes[at..at + 4].copy_from_slice(&lightmap::clamp_accessibility(v).to_le_bytes());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distribute::shard::ShardId;
    use crate::distribute::stitch_columns::Columns;
    use crate::formats::coefficient_file::{LightmapBlock, fixture};
    use crate::formats::header::AtlasSource;

    /// A 4×3 texel file of order 2 (4 coefficients) with accessibility.
    fn texel_file() -> CoefficientFile {
        let texels = 12;
        let coefficients = (0..texels * 4).map(|i| i as f32 * 0.25).collect();
        let mut file = fixture(2, 1, texels as u64, coefficients);
        file.header.aux.ao = true;
        file.ao = Some((0..texels).map(|i| i as f32 / 16.0).collect());
        file.lightmap = Some(LightmapBlock {
            width: 4,
            height: 3,
            scene_vertex_count: 3,
            scene_triangle_count: 1,
            texel_size: 0.0,
            source: AtlasSource::Generated,
            valid: (0..texels).map(|i| i % 3 == 0).collect(),
            dilated: (0..texels).map(|i| i % 3 == 1).collect(),
            uv1: vec![[glam::Vec2::ZERO, glam::Vec2::X, glam::Vec2::Y]],
            objects: Vec::new(),
        });
        file
    }

    #[test]
    fn the_join_on_bytes_writes_what_the_long_way_encodes() {
        let dir = tempfile::tempdir().unwrap();
        let file = texel_file();
        let bytes = file.to_bytes().0;
        let key = xxhash_rust::xxh3::xxh3_64(&bytes);
        // 5 columns in 2 shards: 0..2, and 2..5 with the accessibility (clamped: 1.5 → 1).
        let shards = [(0u32, 0u32, 2u32, vec![7u32, 2]), (1, 2, 3, vec![11, 0, 5])];
        let mut paths = Vec::new();
        for (index, first, count, texels) in shards {
            let values = (0..texels.len() * count as usize)
                .map(|i| 1.5 - i as f32 * 0.125)
                .collect();
            let columns = Columns {
                key,
                shard: ShardId { index, count: 2 },
                first,
                count,
                lightmap_texels: 12,
                texels,
                values,
            };
            let path = dir.path().join(format!("c{index}.col"));
            std::fs::write(&path, columns.to_bytes()).unwrap();
            paths.push(path);
        }
        let path = dir.path().join("unstitched.prt");
        let fast = join(&path, bytes.clone(), &paths).unwrap();
        let long = stitch_columns::join(&path, key, file, &paths).unwrap();
        assert_eq!(fast, long.to_bytes().0);
        assert_ne!(fast, bytes, "the columns changed the file");
        let read = CoefficientFile::from_bytes(&fast).unwrap();
        assert_eq!(read.ao.as_ref().unwrap()[11], 1.0, "clamped");
        assert_eq!(
            read.vertex(2, 0)[..2],
            [1.25, 1.125],
            "texel 2's first columns"
        );
        // Another file's columns, and a missing shard, are refused.
        let mut other = bytes.clone();
        other[HEADER_SIZE] ^= 1;
        let sum = checksum(&other);
        other[CHECKSUM_OFFSET..HEADER_SIZE].copy_from_slice(&sum.to_le_bytes());
        let err = join(&path, other, &paths).unwrap_err().to_string();
        assert!(err.contains("columns of another file"), "{err}");
        let err = join(&path, bytes, &paths[..1]).unwrap_err().to_string();
        assert!(err.contains("shards 1 of 2 are missing"), "{err}");
    }

    #[test]
    fn column_files_of_old_or_outside_texels_are_refused() {
        let columns = Columns {
            key: 1,
            shard: ShardId { index: 0, count: 1 },
            first: 0,
            count: 1,
            lightmap_texels: 12,
            texels: vec![12],
            values: vec![0.5],
        };
        let err = Columns::from_bytes(&columns.to_bytes()).unwrap_err();
        assert!(err.contains("texel 12 outside"), "{err}");
        let mut old = columns.to_bytes();
        old[7] = 1;
        assert!(
            Columns::from_bytes(&old)
                .unwrap_err()
                .contains("earlier prt-bake")
        );
        let inside = Columns {
            texels: vec![11],
            ..columns
        };
        assert_eq!(Columns::from_bytes(&inside.to_bytes()).unwrap(), inside);
    }

    #[test]
    fn a_vertex_file_is_not_laid_out_here() {
        let file = fixture(2, 1, 2, vec![0.5; 8]);
        let bytes = file.to_bytes().0;
        assert!(layout(&bytes).unwrap_err().contains("not a lightmap"));
        assert!(layout(b"PRT").is_err());
    }
}
