//! `--checkpoint DIR`: a bake in blocks of consecutive vertices, each written into DIR (through
//! [`crate::support::atomic::write`]) as soon as it is done, so that a bake that is killed continues
//! where it stopped when it is started again with the same command.
//!
//! A block is a shard part ([`crate::distribute::shard`]) of the range being baked: the whole scene, or
//! the shard of `--shard`. Finishing joins the blocks as the merge joins parts, so the file is
//! byte-identical to an uninterrupted bake. A block whose header is not this bake's (another
//! scene, other options, seed or backend) or whose vertices are not this bake's block (another
//! `--shard` or `--checkpoint-vertices`) is refused, never overwritten.

use std::ops::Range;
use std::path::{Path, PathBuf};

use crate::bake::options::BakeOptions;
use crate::bake::receivers::RECEIVERS_PER_JOB;
use crate::distribute::part_baker::PartBaker;
use crate::distribute::shard::{Part, PartId, ShardId, header_difference};
use crate::support::error::{Error, Result};
use crate::support::progress::Progress;
use crate::trace::Backend;

/// Rays per block by default: about a second and a half on this project's 2-core machine, a
/// fraction of that on a cluster node, and few enough files for a large bake.
pub const BLOCK_RAYS: u64 = 1 << 26;

/// Vertices per block for `options` unless `--checkpoint-vertices` says otherwise: about
/// [`BLOCK_RAYS`] rays, whole parallel jobs, at least 64 vertices.
pub fn default_block_vertices(options: &BakeOptions) -> usize {
    let vertices = (BLOCK_RAYS / u64::from(options.samples.max(1))).max(64) as usize;
    vertices.next_multiple_of(RECEIVERS_PER_JOB)
}

/// What a checkpointed bake produced.
pub struct Checkpointed {
    /// Every vertex of the range baked.
    pub part: Part,
    pub blocks: usize,
    /// Blocks found in the folder rather than baked.
    pub reused: usize,
    /// Rays cast by this run.
    pub rays: u64,
}

/// `DIR/block-NNNNNN.prt`.
pub(super) fn block_path(dir: &Path, index: usize) -> PathBuf {
    dir.join(format!("block-{index:06}.prt"))
}

/// The block files in checkpoint folder `dir`, in the order the folder lists them: each
/// `block-N.prt`'s path and N (`None` where N is no number: a file the caller refuses).
/// Other names are passed over: hidden names are the atomic writer's temporary files of a
/// killed run.
pub(super) fn block_files(dir: &Path) -> Result<Vec<(PathBuf, Option<usize>)>> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|err| Error::io(dir, err))? {
        let path = entry.map_err(|err| Error::io(dir, err))?.path();
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        let Some(index) = name
            .strip_prefix("block-")
            .and_then(|rest| rest.strip_suffix(".prt"))
        else {
            continue;
        };
        let index = index.parse().ok();
        files.push((path, index));
    }
    Ok(files)
}

/// `range` cut into consecutive blocks of `block` items (vertices or probes), the last one
/// shorter; an empty range (a shard with nothing to bake) is one empty block.
pub fn blocks_of(range: &Range<usize>, block: usize) -> Result<Vec<Range<usize>>> {
    if block == 0 {
        return Err(Error::InvalidOption(
            "--checkpoint-vertices must be at least 1".into(),
        ));
    }
    let mut blocks: Vec<Range<usize>> = range
        .clone()
        .step_by(block)
        .map(|start| start..(start + block).min(range.end))
        .collect();
    if blocks.is_empty() {
        blocks.push(range.clone());
    }
    Ok(blocks)
}

/// Bakes `vertices` (shard `shard`'s receivers — vertices or baked texels — or all of them
/// as shard 0 of 1) in blocks of `block_vertices`, reusing the blocks already in `dir`.
pub fn bake(
    baker: &PartBaker,
    options: &BakeOptions,
    shard: ShardId,
    vertices: Range<usize>,
    dir: &Path,
    block_vertices: usize,
    progress: &dyn Progress,
) -> Result<Checkpointed> {
    let blocks = blocks_of(&vertices, block_vertices)?;
    std::fs::create_dir_all(dir).map_err(|err| Error::io(dir, err))?;
    let mut done = reuse_blocks(dir, baker, shard, &vertices, &blocks, block_vertices)?;

    let reused = done.iter().flatten().count();
    let remaining: usize = blocks
        .iter()
        .zip(&done)
        .filter(|(_, d)| d.is_none())
        .map(|(b, _)| b.len())
        .sum();
    let rays_per_vertex = if baker.header().backend == Backend::None {
        0
    } else {
        u64::from(options.samples)
    };
    progress.begin("direct", remaining as u64, rays_per_vertex);
    let rays = bake_missing_blocks(baker, options, shard, &blocks, &mut done, dir, progress)?;
    progress.finish();
    let id = PartId {
        shard,
        first_vertex: vertices.start as u64,
        vertices: vertices.len() as u32,
    };
    let parts = done
        .into_iter()
        .map(|d| d.expect("every block done"))
        .collect();
    // The blocks hold their lightmap's block only; the bake's own has the arrays.
    let mut part = Part::join(parts, id);
    part.lightmap = baker.lightmap_with_arrays();
    Ok(Checkpointed {
        part,
        blocks: blocks.len(),
        reused,
        rays,
    })
}

/// The blocks already in `dir`, by index: each must belong to this bake (`baker`'s header,
/// and lightmap for texel bakes) and be the block its name says, or the folder is refused
/// (it is another bake's).
fn reuse_blocks(
    dir: &Path,
    baker: &PartBaker,
    shard: ShardId,
    vertices: &Range<usize>,
    blocks: &[Range<usize>],
    block_vertices: usize,
) -> Result<Vec<Option<Part>>> {
    let expected_id = |block: &Range<usize>| PartId {
        shard,
        first_vertex: block.start as u64,
        vertices: block.len() as u32,
    };

    let mut done: Vec<Option<Part>> = vec![None; blocks.len()];
    for (path, index) in block_files(dir)? {
        let part = Part::read_block(&path)?;
        let lightmap_difference = match (baker.lightmap(), &part.lightmap) {
            (None, None) => None,
            (Some(a), Some(b)) => a.difference(b),
            _ => Some("a vertex bake and a lightmap bake".to_string()),
        };
        if let Some(difference) =
            header_difference(baker.header(), &part.header).or(lightmap_difference)
        {
            return Err(Error::Shards(format!(
                "{}: a checkpoint of another bake: {difference}; use another --checkpoint folder",
                path.display()
            )));
        }
        match index.and_then(|i| blocks.get(i).map(|b| (i, b))) {
            Some((i, block)) if part.id == expected_id(block) => done[i] = Some(part),
            _ => {
                return Err(Error::Shards(format!(
                    "{}: holds {}, which is not a block of this bake ({}, vertices {}..{}, \
                     {block_vertices} per block): use another --checkpoint folder",
                    path.display(),
                    part.id,
                    shard,
                    vertices.start,
                    vertices.end
                )));
            }
        }
    }

    Ok(done)
}

/// Bakes the blocks not yet `done`, writing each into `dir` as it finishes, and stops when
/// the bounce rows held so far exceed the hit-cache limit. Returns the rays cast.
fn bake_missing_blocks(
    baker: &PartBaker,
    options: &BakeOptions,
    shard: ShardId,
    blocks: &[Range<usize>],
    done: &mut [Option<Part>],
    dir: &Path,
    progress: &dyn Progress,
) -> Result<u64> {
    let quiet = OnePass(progress);
    let (mut rays, mut row_bytes) = (0, 0);
    for (i, block) in blocks.iter().enumerate() {
        if done[i].is_none() {
            let (part, block_rays) = baker.bake(shard, block.clone(), &quiet)?;
            // A block carries its texels, not the atlas (the run that resumes computes it).
            let part = part.into_block();
            part.write(&block_path(dir, i))?;
            rays += block_rays;
            done[i] = Some(part);
        }
        row_bytes += done[i]
            .as_ref()
            .and_then(|p| p.rows.as_ref())
            .map_or(0, |r| r.bytes());
        if row_bytes > options.hit_cache_limit {
            return Err(Error::InvalidOption(format!(
                "the bounce rows of blocks 0..={i} exceed --hit-cache-mb {}; the blocks are kept \
                 in {}: run again with a larger --hit-cache-mb to continue, or bake in shards",
                options.hit_cache_limit >> 20,
                dir.display()
            )));
        }
    }
    Ok(rays)
}

/// Forwards a block's progress to one pass over every block.
struct OnePass<'a>(&'a dyn Progress);

impl Progress for OnePass<'_> {
    fn advance(&self, vertices: u64) {
        self.0.advance(vertices);
    }
}
