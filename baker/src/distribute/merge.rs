//! `prt-bake merge`: shard parts back into the file a single machine would have baked, byte
//! for byte. The parts must come from one bake (same header: scene fingerprint, options,
//! seed, backend) and hold every shard of it exactly once; anything else is refused before
//! an output is written.
//!
//! In interreflected mode the parts' bounce rows are most of what travels (kilobytes per
//! vertex), so the merge never holds them all: it checks every part, keeps the direct
//! transfer and aux arrays, and re-reads one part's rows at a time in each bounce. Its
//! memory is the transfer arrays (previous bounce, next bounce, total) plus one part.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::CoefficientFile;
use crate::bake::interreflection::{self, RowSource};
use crate::bake::transfer::{BounceTargets, Estimator, Mode};
use crate::distribute::lightmap_parts::Lookup;
use crate::distribute::shard::{Part, PartId, header_difference, options_of, shard_range};
use crate::formats::header::Header;
use crate::math::sh;
use crate::support::error::{Error, Result};
use crate::support::progress::Progress;

/// Reads, checks and merges the parts at `paths` (in any order).
pub fn merge(paths: &[PathBuf], progress: &dyn Progress) -> Result<CoefficientFile> {
    merge_with(paths, true, progress)
}

/// [`merge`]; a texel bake's lightmap is stitched only with `stitch` (without, `prt-bake
/// stitch` stitches it apart, in shards of columns).
pub fn merge_with(
    paths: &[PathBuf],
    stitch: bool,
    progress: &dyn Progress,
) -> Result<CoefficientFile> {
    let first_path = paths
        .first()
        .ok_or_else(|| Error::InvalidOption("merge needs at least one part".into()))?;
    if crate::distribute::probe_shards::is_probe_part(first_path)? {
        return crate::distribute::probe_shards::merge(paths);
    }
    let (header, order, mut whole) = join(paths, true)?;
    if header.mode != Mode::Interreflected {
        let coefficients = std::mem::take(&mut whole.coefficients);
        return Ok(whole.into_file_with(coefficients, stitch));
    }
    merge_bounces(&header, &order, whole, stitch, progress)
}

/// A merge's parts joined: the bake's header, each part's path and identity, the joined part.
pub(crate) type Joined<'a> = (Header, Vec<(&'a Path, PartId)>, Part);

/// Reads and checks every part at `paths` (without their bounce rows; without `aux`, without
/// their aux arrays and guides too) and joins them: the bake's header, each part's path and
/// identity in shard order, and the joined part.
pub(crate) fn join(paths: &[PathBuf], aux: bool) -> Result<Joined<'_>> {
    let first_path = paths
        .first()
        .ok_or_else(|| Error::InvalidOption("merge needs at least one part".into()))?;
    let mut parts = Vec::with_capacity(paths.len());
    for path in paths {
        // The rows are read again, one part at a time, by each bounce (or by the gathers).
        let part = Part::read_without_rows(path, aux)?;
        if let Some((_, first)) = parts.first() {
            check_same_bake(first, &part, path, first_path)?;
        }
        parts.push((path.as_path(), part));
    }
    let (header, first_shard) = (parts[0].1.header.clone(), parts[0].1.id.shard);
    let receivers = parts[0].1.receiver_count();
    let by_index = index_parts(parts, &header, first_path)?;

    let id = PartId {
        shard: first_shard,
        first_vertex: 0,
        vertices: receivers as u32,
    };
    let order: Vec<(&Path, PartId)> = by_index.values().map(|(p, part)| (*p, part.id)).collect();
    let parts = by_index.into_values().map(|(_, part)| part).collect();
    // Texel bakes: the joined part keeps shard 0's lightmap, whose part carries the arrays
    // for every part (the others' lightmaps are checked equal by fingerprint).
    let whole = Part::join(parts, id);
    Ok((header, order, whole))
}

/// Refuses `part` (at `path`) unless it is of the bake of `first`: the same header (scene,
/// options, seed, backend), the same kind (vertex or texel bake) and, for texels, the same
/// lightmap: atlas, resolution, baked texels and their fingerprint.
fn check_same_bake(first: &Part, part: &Part, path: &Path, first_path: &Path) -> Result<()> {
    let difference = header_difference(&first.header, &part.header).or_else(|| {
        match (&first.lightmap, &part.lightmap) {
            (None, None) => None,
            (Some(a), Some(b)) => a.difference(b),
            (Some(_), None) => Some("a vertex bake's part, not a lightmap bake's".to_string()),
            (None, Some(_)) => Some("a lightmap bake's part, not a vertex bake's".to_string()),
        }
    });
    match difference {
        Some(difference) => Err(refuse(format!(
            "{}: a part of another bake than {}: {difference}",
            path.display(),
            first_path.display()
        ))),
        None => Ok(()),
    }
}

/// The parts by shard index, each checked to be of the bake of `header` (the first part's),
/// split the same number of ways, a whole shard's range, and given once; none missing.
pub(crate) fn index_parts<'a>(
    parts: Vec<(&'a Path, Part)>,
    header: &Header,
    first_path: &Path,
) -> Result<BTreeMap<u32, (&'a Path, Part)>> {
    let count = parts[0].1.id.shard.count;
    let mut by_index: BTreeMap<u32, (&Path, Part)> = BTreeMap::new();
    for (path, part) in parts {
        if let Some(difference) = header_difference(header, &part.header) {
            return Err(refuse(format!(
                "{}: a part of another bake than {}: {difference}",
                path.display(),
                first_path.display()
            )));
        }
        if part.id.shard.count != count {
            return Err(refuse(format!(
                "{}: {} of a bake split {} ways, but {} is of one split {count} ways",
                path.display(),
                part.id.shard,
                part.id.shard.count,
                first_path.display()
            )));
        }
        let expected = shard_range(part.receiver_count(), part.id.shard);
        if part.range() != expected {
            return Err(refuse(format!(
                "{}: holds vertices {}..{}, but {} is vertices {}..{} (a checkpoint block, not a part)",
                path.display(),
                part.range().start,
                part.range().end,
                part.id.shard,
                expected.start,
                expected.end
            )));
        }
        if let Some((other, _)) = by_index.get(&part.id.shard.index) {
            return Err(refuse(format!(
                "{} and {}: both are {}",
                other.display(),
                path.display(),
                part.id.shard
            )));
        }
        by_index.insert(part.id.shard.index, (path, part));
    }
    let missing: Vec<String> = (0..count)
        .filter(|k| !by_index.contains_key(k))
        .map(|k| k.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(refuse(format!(
            "shard{} {} of {count} missing: the parts given hold shards {}",
            if missing.len() > 1 { "s" } else { "" },
            missing.join(", "),
            by_index
                .keys()
                .map(|k| k.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    Ok(by_index)
}

/// An interreflected merge: the bounces, as `interreflection::add_bounces` gathers them, one
/// part's rows at a time (re-read from `order`'s paths, so the merge never holds them all).
fn merge_bounces(
    header: &Header,
    order: &[(&Path, PartId)],
    mut whole: Part,
    stitch: bool,
    progress: &dyn Progress,
) -> Result<CoefficientFile> {
    let options = options_of(header);
    let n = sh::coeff_count(options.order);
    let channels = header.channels as usize;
    let norm = Estimator::norm_of(&options) as f32;
    let lookup = whole.lightmap.as_ref().map(Lookup::new);
    let fingerprint = whole.lightmap.as_ref().map(|l| l.fingerprint);
    let targets = lookup
        .as_ref()
        .map_or(BounceTargets::Vertices, Lookup::targets);
    let pass = |previous: Cow<[f32]>, previous_channels: usize, next: &mut [f32]| {
        // Texel bakes: the previous bounce in the lightmap, dilated, as the bake reads it.
        let previous = targets.slot_values(&previous, previous_channels * n);
        for &(path, id) in order {
            let part = Part::read(path)?;
            let part_fingerprint = part.lightmap.as_ref().map(|l| l.fingerprint);
            if header_difference(header, &part.header).is_some()
                || part.id != id
                || part_fingerprint != fingerprint
            {
                return Err(refuse(format!(
                    "{}: changed while it was being merged",
                    path.display()
                )));
            }
            let rows = part.rows.expect("an interreflected part has rows");
            let out = &mut next[id.range().start * channels * n..id.range().end * channels * n];
            interreflection::bounce_pass(
                &RowSource::Flat(&rows),
                norm,
                n,
                &previous,
                previous_channels,
                channels,
                out,
                progress,
            );
        }
        Ok(())
    };
    let t0 = std::mem::take(&mut whole.coefficients);
    let total = interreflection::sum_bounces(t0, channels, &options, 0, progress, pass)?;
    Ok(whole.into_file_with(total, stitch))
}

pub(crate) fn refuse(message: String) -> Error {
    Error::Shards(message)
}
