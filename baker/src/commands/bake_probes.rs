//! `prt-bake bake --probes`: transfer probes instead of vertices (docs/guides/probes.md).

use std::path::Path;

use prt_baker::bake::probes::{self, ProbeSpec};
use prt_baker::distribute::probe_shards;
use prt_baker::distribute::shard::{PartId, ShardId, shard_range};
use prt_baker::support::output::Output;
use prt_baker::trace::Tracer;
use prt_baker::{BakeOptions, CoefficientFile, Error, Scene};

/// What a memory error names: the points file, or the grid.
fn spec_name(spec: &ProbeSpec) -> String {
    match spec {
        ProbeSpec::Points(path) => path.display().to_string(),
        ProbeSpec::Grid { counts, .. } => {
            format!("--probes grid:{},{},{}", counts[0], counts[1], counts[2])
        }
    }
}

/// `--shard`, `--checkpoint DIR` and `--checkpoint-vertices` of a probe bake.
pub type Parts<'a> = (Option<ShardId>, Option<&'a Path>, Option<usize>);

/// Bakes the probes `spec` names in `scene` into the probe file `output` (a shard's part
/// with `--shard`, through checkpoint blocks with `--checkpoint`), and prints a summary.
pub fn bake(
    spec: &str,
    output: &Path,
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    parts: Parts,
    progress: &dyn prt_baker::support::progress::Progress,
) -> Result<(), Error> {
    let spec = ProbeSpec::parse(spec)?;
    let mut inputs = scene.input_files();
    if let ProbeSpec::Points(path) = &spec {
        inputs.push(path.clone());
    }
    let output_file = Output::new(output, &inputs)?;
    let probes = spec.probes(scene)?;
    let count = probes.positions.len();
    // Two hemisphere matrices per probe in up to 3 channels, beside the vertex bake.
    let n2 = (options.order * options.order) as u64;
    let needed = (count as u64)
        .checked_mul(2 * 3 * n2 * n2 * 4)
        .and_then(|b| {
            b.checked_add(prt_baker::bake::memory::bake_bytes(
                options,
                scene.vertex_count() as u64,
                scene.triangles.len() as u64,
            )?)
        });
    prt_baker::support::limits::check(
        spec_name(&spec),
        &format!("baking {count} probes at order {}", options.order),
        needed,
    )?;
    if parts.0.is_some() || parts.1.is_some() {
        return bake_in_parts(
            output_file,
            output,
            scene,
            tracer,
            options,
            probes,
            parts,
            progress,
        );
    }
    let transfer = probes::bake(scene, tracer, options, &probes.positions, progress)?;
    let file = CoefficientFile::from_probe_bake(scene, &transfer, tracer, probes);
    output_file.write(&file.to_bytes().0)?;
    let rays = match transfer.rays_cast {
        0 => String::from("no rays"),
        rays => format!(
            "{rays} rays, {:.2} Mrays/s",
            rays as f64 / transfer.seconds.max(1e-9) / 1e6
        ),
    };
    println!(
        "baked {} probes, {rays}, {:.2} s (order {}, {}, {} channels, {} samples, {}) -> {}",
        count,
        transfer.seconds,
        options.order,
        options.mode.name(),
        transfer.channels,
        options.samples,
        transfer.backend.name(),
        output.display()
    );
    Ok(())
}

/// A probe bake with `--shard` or `--checkpoint`: a part file, or the whole file from
/// checkpoint blocks (docs/guides/probes.md, "Shards and checkpoints").
#[allow(clippy::too_many_arguments)]
fn bake_in_parts(
    output_file: Output,
    output: &Path,
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    probes: prt_baker::formats::probe_block::ProbeBlock,
    (shard, checkpoint, block): Parts,
    progress: &dyn prt_baker::support::progress::Progress,
) -> Result<(), Error> {
    let started = std::time::Instant::now();
    let count = probes.positions.len();
    let whole = ShardId { index: 0, count: 1 };
    let range = shard_range(count, shard.unwrap_or(whole));
    let id = PartId {
        shard: shard.unwrap_or(whole),
        first_vertex: range.start as u64,
        vertices: range.len() as u32,
    };
    let positions = probes.positions.clone();
    let (part, rays, blocks) = probes::with_baker(scene, tracer, options, &positions, |baker| {
        let header = probe_shards::whole_header(scene, baker, count);
        let (part, rays, blocks) = match checkpoint {
            Some(dir) => {
                let block = block.unwrap_or_else(|| {
                    prt_baker::distribute::checkpoint::default_block_vertices(options)
                });
                let done = probe_shards::bake_checkpointed(
                    baker,
                    &header,
                    &probes,
                    id.shard,
                    range.clone(),
                    dir,
                    block,
                    progress,
                )?;
                let blocks = format!(
                    ", {} blocks ({} resumed from {})",
                    done.blocks,
                    done.reused,
                    dir.display()
                );
                (done.part, done.rays, blocks)
            }
            None => {
                let (part, rays) = probe_shards::bake_part(baker, &header, &probes, id, progress)?;
                (part, rays, String::new())
            }
        };
        Ok((part, rays + baker.prepared_rays(), blocks))
    })?;
    let what = match shard {
        Some(shard) => {
            output_file.write(&part.to_bytes())?;
            format!("{shard}: probes {}..{} of {count}", range.start, range.end)
        }
        None => {
            output_file.write(&part.into_file().to_bytes().0)?;
            format!("{count} probes")
        }
    };
    println!(
        "baked {what}, {rays} rays, {:.2} s (order {}, {}, {} samples{blocks}) -> {}",
        started.elapsed().as_secs_f64(),
        options.order,
        options.mode.name(),
        options.samples,
        output.display()
    );
    Ok(())
}
