//! Probe bakes in parts ([`crate::distribute::probe_parts`]): a shard's or a checkpoint
//! block's probes baked into a part, `--checkpoint` blocks reused after a kill, and the merge
//! of every shard's part into the file one machine would have written, byte for byte.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use crate::bake::probes::ProbeBaker;
use crate::distribute::checkpoint;
use crate::distribute::probe_parts::ProbePart;
use crate::distribute::shard::{PartId, ShardId, shard_range};
use crate::formats::coefficient_file::CoefficientFile;
use crate::formats::header::{Header, PROBE_HEADER_SIZE};
use crate::formats::probe_block::ProbeBlock;
use crate::scene::Scene;
use crate::support::error::{Error, Result};
use crate::support::progress::Progress;

/// The header every part and block of `baker`'s bake of `probes` carries: the whole file's.
pub fn whole_header(scene: &Scene, baker: &ProbeBaker, probes: usize) -> Header {
    let (options, backend) = (&baker.options, baker.backend());
    Header::for_bake(scene, options, backend, baker.channels(), probes, 0)
}

/// An empty part of the bake of `header` over `probes` (positions and grid): what every
/// part and block of it must match.
pub fn template(header: &Header, probes: &ProbeBlock, id: PartId) -> ProbePart {
    ProbePart {
        header: header.clone(),
        grid: probes.grid,
        id,
        coefficients: Vec::new(),
        positions: Vec::new(),
        backfaces: Vec::new(),
    }
}

/// Bakes the probes of `id`'s range of `probes` into a part; returns it and the rays cast
/// (the vertex pass of interreflected mode counted by [`ProbeBaker::prepared_rays`]).
pub fn bake_part(
    baker: &ProbeBaker,
    header: &Header,
    probes: &ProbeBlock,
    id: PartId,
    progress: &dyn Progress,
) -> Result<(ProbePart, u64)> {
    let range = id.range();
    let (coefficients, rays) = baker.bake(range.clone(), progress)?;
    let positions = probes.positions[range.clone()].to_vec();
    let backfaces = crate::bake::probe_validity::backface_fractions(
        baker.tracer(),
        baker.options.seed,
        &positions,
        range.start,
    );
    let part = ProbePart {
        coefficients,
        positions,
        backfaces,
        ..template(header, probes, id)
    };
    Ok((part, rays))
}

/// What a checkpointed probe bake produced.
pub struct Checkpointed {
    /// Every probe of the range baked.
    pub part: ProbePart,
    pub blocks: usize,
    /// Blocks found in the folder rather than baked.
    pub reused: usize,
    /// Rays cast by this run's probe passes.
    pub rays: u64,
}

/// Bakes probes `range` (shard `shard`'s, or all as shard 0 of 1) in blocks of `block`
/// probes, each written into `dir` when done, reusing the blocks already there. The blocks
/// of another bake or another split are refused, never overwritten.
#[allow(clippy::too_many_arguments)]
pub fn bake_checkpointed(
    baker: &ProbeBaker,
    header: &Header,
    probes: &ProbeBlock,
    shard: ShardId,
    range: Range<usize>,
    dir: &Path,
    block: usize,
    progress: &dyn Progress,
) -> Result<Checkpointed> {
    let blocks = checkpoint::blocks_of(&range, block)?;
    std::fs::create_dir_all(dir).map_err(|err| Error::io(dir, err))?;
    let id_of = |b: &Range<usize>| PartId {
        shard,
        first_vertex: b.start as u64,
        vertices: b.len() as u32,
    };
    let expected = template(header, probes, id_of(&range));
    let mut done: Vec<Option<ProbePart>> = vec![None; blocks.len()];
    for (path, index) in checkpoint::block_files(dir)? {
        let part = ProbePart::read(&path)?;
        if let Some(difference) = expected.bake_difference(&part) {
            return Err(Error::Shards(format!(
                "{}: a checkpoint of another bake: {difference}; use another --checkpoint folder",
                path.display()
            )));
        }
        match index.filter(|&i| i < blocks.len()) {
            Some(i) if part.id == id_of(&blocks[i]) => done[i] = Some(part),
            _ => {
                let held = part.id.range();
                return Err(Error::Shards(format!(
                    "{}: holds probes {}..{} of {}, which is not a block of this bake ({}, \
                     probes {}..{}, {block} per block): use another --checkpoint folder",
                    path.display(),
                    held.start,
                    held.end,
                    part.id.shard,
                    shard,
                    range.start,
                    range.end
                )));
            }
        }
    }
    let reused = done.iter().flatten().count();
    let mut rays = 0;
    for (i, b) in blocks.iter().enumerate() {
        if done[i].is_none() {
            let (part, block_rays) = bake_part(baker, header, probes, id_of(b), progress)?;
            part.write(&checkpoint::block_path(dir, i))?;
            rays += block_rays;
            done[i] = Some(part);
        }
    }
    let parts = done.into_iter().map(|d| d.expect("every block done"));
    Ok(Checkpointed {
        part: ProbePart::join(parts.collect(), id_of(&range)),
        blocks: blocks.len(),
        reused,
        rays,
    })
}

/// Whether the file at `path` is a probe bake's part (so `merge` merges probe parts). Its
/// header says so: only that is read, not a texel part of hundreds of megabytes.
pub fn is_probe_part(path: &Path) -> Result<bool> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(|err| Error::io(path, err))?;
    let mut header = Vec::with_capacity(PROBE_HEADER_SIZE);
    (file.take(PROBE_HEADER_SIZE as u64).read_to_end(&mut header))
        .map_err(|err| Error::io(path, err))?;
    Ok(ProbePart::is_probe_part(&header))
}

/// Reads, checks and merges the probe parts at `paths` (in any order): one bake's (same
/// header and grid), split the same number of ways, each a whole shard, every shard once.
pub fn merge(paths: &[PathBuf]) -> Result<CoefficientFile> {
    let first_path = &paths[0];
    let mut by_index: BTreeMap<u32, (&Path, ProbePart)> = BTreeMap::new();
    let mut first: Option<ProbePart> = None;
    for path in paths {
        let part = ProbePart::read(path)?;
        let first = first.get_or_insert_with(|| part.clone());
        if let Some(difference) = first.bake_difference(&part) {
            return Err(Error::Shards(format!(
                "{}: a part of another bake than {}: {difference}",
                path.display(),
                first_path.display()
            )));
        }
        let count = first.id.shard.count;
        if part.id.shard.count != count {
            return Err(Error::Shards(format!(
                "{}: {} of a bake split {} ways, but {} is of one split {count} ways",
                path.display(),
                part.id.shard,
                part.id.shard.count,
                first_path.display()
            )));
        }
        let expected = shard_range(part.header.vertex_count as usize, part.id.shard);
        if part.id.range() != expected {
            return Err(Error::Shards(format!(
                "{}: holds probes {}..{}, but {} is probes {}..{} (a checkpoint block, not a part)",
                path.display(),
                part.id.range().start,
                part.id.range().end,
                part.id.shard,
                expected.start,
                expected.end
            )));
        }
        if let Some((other, _)) = by_index.get(&part.id.shard.index) {
            return Err(Error::Shards(format!(
                "{} and {}: both are {}",
                other.display(),
                path.display(),
                part.id.shard
            )));
        }
        by_index.insert(part.id.shard.index, (path, part));
    }
    let first = first.expect("at least one part");
    let count = first.id.shard.count;
    let missing: Vec<String> = (0..count)
        .filter(|k| !by_index.contains_key(k))
        .map(|k| k.to_string())
        .collect();
    if !missing.is_empty() {
        let held: Vec<String> = by_index.keys().map(|k| k.to_string()).collect();
        return Err(Error::Shards(format!(
            "shard{} {} of {count} missing: the parts given hold shards {}",
            if missing.len() > 1 { "s" } else { "" },
            missing.join(", "),
            held.join(", ")
        )));
    }
    let id = PartId {
        shard: first.id.shard,
        first_vertex: 0,
        vertices: first.header.vertex_count as u32,
    };
    let parts = by_index.into_values().map(|(_, part)| part).collect();
    Ok(ProbePart::join(parts, id).into_file())
}
