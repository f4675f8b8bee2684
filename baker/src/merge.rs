//! `prt-bake merge`: shard parts back into the file a single machine would have baked, byte
//! for byte. The parts must come from one bake (same header: scene fingerprint, options,
//! seed, backend) and hold every shard of it exactly once; anything else is refused before
//! an output is written.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::CoefficientFile;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::shard::{Part, PartId, header_difference, shard_range};

/// Reads, checks and merges the parts at `paths` (in any order).
pub fn merge(paths: &[PathBuf], progress: &dyn Progress) -> Result<CoefficientFile> {
    let first_path = paths
        .first()
        .ok_or_else(|| Error::InvalidOption("merge needs at least one part".into()))?;
    let mut parts = Vec::with_capacity(paths.len());
    for path in paths {
        parts.push((path.as_path(), Part::read(path)?));
    }
    let (header, first_shard) = (parts[0].1.header.clone(), parts[0].1.id.shard);
    let count = first_shard.count;
    let mut by_index: BTreeMap<u32, (&Path, Part)> = BTreeMap::new();
    for (path, part) in parts {
        if let Some(difference) = header_difference(&header, &part.header) {
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
        let expected = shard_range(header.vertex_count as usize, part.id.shard);
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
    let id = PartId {
        shard: first_shard,
        first_vertex: 0,
        vertices: header.vertex_count as u32,
    };
    let parts = by_index.into_values().map(|(_, part)| part).collect();
    Ok(Part::join(parts, id).finish(progress))
}

fn refuse(message: String) -> Error {
    Error::Shards(message)
}
