//! `prt-bake bake --shard / --checkpoint` and `prt-bake prepare-lightmap`: a bake in parts
//! (docs/guides/clusters.md), and the lightmap preparation its texel shards share.

use std::ops::Range;
use std::path::Path;

use prt_baker::bake::lightmap::{self, Prepared};
use prt_baker::distribute::checkpoint;
use prt_baker::distribute::part_baker::PartBaker;
use prt_baker::distribute::prepared_file;
use prt_baker::distribute::row_encoding::EncodedRows;
use prt_baker::distribute::shard::{Part, ShardId, shard_range};
use prt_baker::support::progress::Progress;
use prt_baker::trace::Tracer;
use prt_baker::{BakeOptions, Error, Scene};

/// What a bake in parts takes from `bake`'s arguments (`commands::bake` builds it; this file
/// does not import it back).
pub struct PartsArgs<'a> {
    pub lightmap: Option<u32>,
    pub checkpoint: Option<&'a Path>,
    pub checkpoint_vertices: Option<usize>,
    pub output: &'a Path,
    pub prepared: Option<&'a Path>,
    /// The key a prepared lightmap of this scene and these options has.
    pub prepared_key: u64,
    pub verbose: bool,
    /// `--lightmap RES`'s atlas of the scene.
    pub atlas: &'a dyn Fn(u32) -> Result<lightmap::Atlas, Error>,
}

/// A texel bake's preparation: read from `--prepared` (checked against this bake's key), or
/// computed here; and the tracer watertight for its texels' ray origins.
fn prepare<'t>(
    stages: &mut lightmap::Stages,
    args: &PartsArgs<'_>,
    scene: &Scene,
    tracer: Option<&'t dyn Tracer>,
    options: &BakeOptions,
    resolution: u32,
) -> Result<(Prepared, Option<Box<dyn Tracer + 't>>), Error> {
    match args.prepared {
        Some(path) => {
            let prepared = stages.time("reading the prepared lightmap", || {
                prepared_file::read(path, args.prepared_key)
            })?;
            if prepared.atlas.uv1.len() != scene.triangles.len() {
                return Err(Error::Shards(format!(
                    "{}: a prepared lightmap of {} triangles, the scene has {}",
                    path.display(),
                    prepared.atlas.uv1.len(),
                    scene.triangles.len()
                )));
            }
            let watertight = match tracer {
                Some(tracer) => {
                    let seam = prepared.seam_points.as_deref();
                    stages.time("seam texels", || {
                        prepared.texels.watertight_known(scene, tracer, seam)
                    })?
                }
                None => None,
            };
            Ok((prepared, watertight))
        }
        None => {
            let atlas = (args.atlas)(resolution)?;
            Ok(lightmap::prepare_traced(
                scene,
                tracer,
                options.seed,
                atlas,
            )?)
        }
    }
}

/// `prt-bake prepare-lightmap`: the atlas, the texels after the leak test and the seam
/// partners, written to `-o` for every shard of the texel bake to read.
pub(super) fn prepare_lightmap(
    args: &PartsArgs<'_>,
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
) -> Result<(), Error> {
    let started = std::time::Instant::now();
    let resolution = args
        .lightmap
        .ok_or_else(|| Error::InvalidOption("prepare-lightmap needs --lightmap RES".into()))?;
    let atlas = (args.atlas)(resolution)?;
    let prepared = lightmap::prepare(scene, tracer, options.seed, atlas)?;
    prepared_file::write(args.output, args.prepared_key, &prepared)?;
    if args.verbose {
        eprintln!("prt-bake: stages: {}", prepared.stages.line());
    }
    println!(
        "prepared {} baked texels of {}×{} ({} moved out, {} left out as leaking), {:.2} s -> {}",
        prepared.texels.valid_count(),
        prepared.atlas.width,
        prepared.atlas.height,
        prepared.settled.moved,
        prepared.settled.leaking,
        started.elapsed().as_secs_f64(),
        args.output.display()
    );
    Ok(())
}

/// A bake with `--shard` or `--checkpoint`: a part file, or the whole file from checkpoint
/// blocks.
pub(super) fn bake_in_parts(
    args: &PartsArgs<'_>,
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    shard: Option<ShardId>,
    progress: &dyn Progress,
) -> Result<(), Error> {
    let started = std::time::Instant::now();
    let mut stages = lightmap::Stages::default();
    // A texel bake's parts split its baked texels: every shard reads the prepared lightmap
    // (or computes the same atlas and leak test), and bakes through a tracer watertight for
    // the texels, as a whole bake does.
    let (prepared, watertight);
    let (mut baker, noun) = match args.lightmap {
        None => (PartBaker::vertices(scene, tracer, options)?, "vertices"),
        Some(resolution) => {
            (prepared, watertight) =
                prepare(&mut stages, args, scene, tracer, options, resolution)?;
            let tracer = watertight.as_deref().or(tracer);
            // A shard's denoiser guides are its own receivers' only.
            let all = prepared.texels.valid_count();
            let receivers = shard.map_or(0..all, |shard| shard_range(all, shard));
            let baker = stages.time("estimator", || {
                PartBaker::texels_in(scene, tracer, options, &prepared, receivers)
            })?;
            (baker, "baked texels")
        }
    };
    let vertex_count = baker.receivers();
    let (id, vertices) = match shard {
        Some(shard) => (shard, shard_range(vertex_count, shard)),
        None => (ShardId { index: 0, count: 1 }, 0..vertex_count),
    };
    let range = (id, vertices.clone());
    let (part, rows, rays, blocks) = bake_range(
        args,
        &mut baker,
        options,
        range,
        shard.is_some(),
        &mut stages,
        progress,
    )?;
    let what = match shard {
        Some(shard) => {
            stages.time("writing", || match rows {
                Some(rows) => part.write_with(args.output, Some(rows)),
                None => part.write(args.output),
            })?;
            format!(
                "{shard} ({noun} {}..{} of {vertex_count})",
                vertices.start, vertices.end
            )
        }
        None => {
            part.finish(progress).write(args.output)?;
            format!("{vertex_count} {noun}")
        }
    };
    if args.verbose && !stages.0.is_empty() {
        eprintln!("prt-bake: stages: {}", stages.line());
    }
    let seconds = started.elapsed().as_secs_f64();
    println!(
        "baked {what}, {rays} rays, {seconds:.2} s (order {}, {}, {} samples{blocks}) -> {}",
        options.order,
        options.mode.name(),
        options.samples,
        args.output.display()
    );
    Ok(())
}

/// A part's bake: the part, a shard's rows encoded for its file, the rays cast, and the
/// checkpoint blocks for the summary line.
type BakedPart = (Part, Option<EncodedRows>, u64, String);

/// Bakes `range` of `baker`'s receivers: in checkpoint blocks, as a shard's part (`shard`),
/// or whole.
fn bake_range(
    args: &PartsArgs<'_>,
    baker: &mut PartBaker,
    options: &BakeOptions,
    (id, vertices): (ShardId, Range<usize>),
    shard: bool,
    stages: &mut lightmap::Stages,
    progress: &dyn Progress,
) -> Result<BakedPart, Error> {
    Ok(match args.checkpoint {
        Some(dir) => {
            let block_vertices = args
                .checkpoint_vertices
                .unwrap_or_else(|| checkpoint::default_block_vertices(options));
            let done =
                checkpoint::bake(baker, options, id, vertices, dir, block_vertices, progress)?;
            let blocks = format!(
                ", {} blocks ({} resumed from {})",
                done.blocks,
                done.reused,
                dir.display()
            );
            (done.part, None, done.rays, blocks)
        }
        // A shard's rows go from its direct pass straight to the part's bytes.
        None if shard => {
            let (part, rows, rays) =
                stages.time("bake", || baker.bake_encoded(id, vertices, progress))?;
            (part, rows, rays, String::new())
        }
        None => {
            let (part, rays) = baker.bake(id, vertices, progress)?;
            (part, None, rays, String::new())
        }
    })
}
