//! `prt-bake bake` and `prepare-lightmap`: the command line, lowered in one place ([`plan`])
//! into a [`BakePlan`] (the library's options, what is baked, the tracer, the outputs, the
//! compression), each checked before the scene is read; `commands::bake_run` runs it.

use std::path::PathBuf;

use prt_baker::bake::{lightmap, memory};
use prt_baker::distribute::shard::ShardId;
use prt_baker::export::compress;
use prt_baker::trace;
use prt_baker::{BakeOptions, Error, Mode};

use super::UpArg;
use super::bake_plan::{BakePlan, LightmapPlan, LoadPlan, Report, Split, What, tracer_options};
use super::bake_values::{
    AtlasArg, AuxArg, BackendArg, DenoiseArg, ModeArg, SamplingArg, TransferArgs, default_samples,
};
use super::scene_load::{DoubleSidedArg, InstancesArg};

#[derive(clap::Args)]
pub struct BakeArgs {
    /// A scene file (one `"object.obj" "texture.tga"` per line), a bare .obj, or a glTF 2.0
    /// file (.gltf, .glb).
    scene: PathBuf,
    /// A materials file (TOML; docs/guides/subsurface.md): per material name, a subsurface medium
    /// whose surfaces get subsurface transfer (RGB) from random walks inside the mesh.
    #[arg(long, value_name = "MATS.toml", conflicts_with_all = ["shard", "checkpoint", "target_error"])]
    materials: Option<PathBuf>,
    /// The scene's up axis, recorded in the file: rigs, skies and the viewer turn to it.
    /// Default: y for glTF (its specification's axis), z for OBJ and scene files.
    #[arg(long, value_enum)]
    up: Option<UpArg>,
    /// Output coefficient file.
    #[arg(short, long)]
    output: PathBuf,
    /// SH order n: bands 0..n-1, n² coefficients per vertex.
    #[arg(long, default_value_t = 4)]
    order: usize,
    /// Rays per vertex or texel (directions in unshadowed mode), best a power of two or a
    /// multiple of 16. Default: 64 where denoised (--denoise), else 1,024 (--target-error's cap).
    #[arg(long)]
    samples: Option<u32>,
    #[arg(long, value_enum, default_value_t = ModeArg::Shadowed)]
    mode: ModeArg,
    #[command(flatten)]
    transfer: TransferArgs,
    /// Seed of the sample directions; the same seed gives a bit-identical file.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads (default: all cores). The output does not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// How directions are drawn.
    #[arg(long, value_enum, default_value_t = SamplingArg::OwenSobol)]
    sampling: SamplingArg,
    /// Interreflection bounces (interreflected mode; default 1 there).
    #[arg(long)]
    bounces: Option<u32>,
    /// Rays per vertex whose hits feed the bounces (interreflected mode; default a quarter of --samples): closest-hit rays cost 2–4 times occlusion rays, bounced light needs fewer.
    #[arg(long)]
    bounce_samples: Option<u32>,
    /// Per-vertex arrays to store beside the coefficients: ambient accessibility and the bent normal (comma-separated).
    #[arg(long, value_enum, value_delimiter = ',')]
    aux: Vec<AuxArg>,
    /// Memory (MiB) the interreflected mode may use to cache first hits; beyond it the bounces re-trace (slower, same result).
    #[arg(long, default_value_t = 1024)]
    hit_cache_mb: u64,
    /// Ray-tracing backend: Embree, or obvhs (pure Rust, watertight, about a quarter of Embree's speed; the only one in a build without Embree). Recorded in the file.
    #[arg(long, value_enum, default_value_t = BackendArg::DEFAULT)]
    backend: BackendArg,
    /// Embree's robust mode for every ray (about 30 % slower). Without it, only the rays of
    /// vertices near another surface's edge use it, which already makes the answers
    /// watertight. Applies to --backend embree only.
    #[arg(long)]
    robust: bool,
    /// Adaptive sampling: each vertex (with --lightmap: texel) casts rays until its estimated
    /// RMS coefficient error is at most this, the error after denoising when denoised
    /// (--samples caps the rays): a pilot of 256 points, then more where the error is predicted
    /// above the target; shadowed, owen-sobol only.
    #[arg(long, conflicts_with_all = ["shard", "checkpoint"])]
    target_error: Option<f32>,
    /// Denoise the baked transfer (a filter in world space whose weights every coefficient
    /// shares, so every light sees it denoised; docs/explanation/denoising.md). auto: on for
    /// lightmap bakes (whole, shards, checkpoints) that cast owen-sobol rays, as lightmappers
    /// do, and adaptive bakes of every vertex; off for other vertex bakes and probes.
    #[arg(long, value_enum, default_value_t = DenoiseArg::Auto)]
    denoise: DenoiseArg,
    /// No progress bar (the summary line is still printed).
    #[arg(long)]
    quiet: bool,
    /// Print each stage's wall time on stderr (texel bakes: atlas, rasterisation, seam texels,
    /// leak test, bake, dilation, seam points, stitching).
    #[arg(long)]
    verbose: bool,
    /// Bake only part K of N (0 ≤ K < N), a range of vertices (with --lightmap: of baked
    /// texels, so every part casts the same rays), into a part file for `prt-bake merge`. `auto` reads K and N from a Slurm array task; `auto/N` takes K from
    /// a Kubernetes Indexed Job's JOB_COMPLETION_INDEX (or set PRT_SHARD_COUNT and use `auto`).
    #[arg(long, value_name = "K/N|auto|auto/N")]
    shard: Option<String>,
    /// Write completed blocks of vertices into DIR as the bake goes; the same command run
    /// again after a crash or a kill continues from them (same file as an uninterrupted bake).
    #[arg(long, value_name = "DIR")]
    checkpoint: Option<PathBuf>,
    /// Vertices (with --lightmap: baked texels) per checkpoint block (default: about 67 million rays' worth).
    #[arg(long, requires = "checkpoint")]
    checkpoint_vertices: Option<usize>,
    /// Bake per texel of a RES×RES lightmap atlas instead of per vertex (docs/guides/lightmaps.md):
    /// the scene's lightmap UVs (glTF TEXCOORD_1) where it has them and no --texel-size is
    /// given, else an atlas unwrapped here (--atlas). Every mode; --shard and --checkpoint
    /// too (every part computes the same atlas and records its fingerprint).
    #[arg(long, value_name = "RES")]
    lightmap: Option<u32>,
    /// With --lightmap: the world size of a texel (default: the charts fill the atlas).
    #[arg(long, value_name = "S", requires = "lightmap")]
    texel_size: Option<f32>,
    /// With --lightmap: unwrap the atlas here (even where the scene has lightmap UVs) with
    /// `unwrap` (the default: few large charts, curved meshes too) or `planar` (charts within
    /// a 30° cone, projected, shelf-packed: exact on flat surfaces, more charts on curved ones).
    #[arg(long, value_enum, requires = "lightmap")]
    atlas: Option<AtlasArg>,
    /// With --lightmap on the scene's own lightmap UVs: refuse (exit 3) an object whose UVs
    /// overlap themselves instead of warning and unwrapping it here. Objects that overlap
    /// one another are packed per object either way (docs/guides/lightmaps.md).
    #[arg(long, requires = "lightmap")]
    strict_uvs: bool,
    /// With --lightmap and --shard or --checkpoint: read the atlas, the baked texels after the
    /// leak test and the seam partners from FILE (`prt-bake prepare-lightmap` with this
    /// scene and the same lightmap options, --seed, --backend and --mode) instead of computing
    /// them in every shard; one of another scene or options is refused (exit 3).
    #[arg(long, value_name = "FILE", requires = "lightmap")]
    prepared: Option<PathBuf>,
    /// Set by `prt-bake prepare-lightmap`: write the preparation to -o and stop.
    #[arg(skip)]
    prepare_only: bool,
    /// Bake only the objects whose name, or (glTF) whose node's or an ancestor node's name,
    /// matches one of these globs (`*`, `?`, `[…]`); the others occlude and, interreflected,
    /// reflect. Default: every object but those a glTF node marks
    /// `"extras": {"prt": {"receive": false}}`. The file records the receivers
    /// (docs/reference/coefficient-format.md). With --lightmap, only the receivers are in the atlas
    /// (not interreflected). Whole bakes (not with --shard, --checkpoint or compression).
    #[arg(long, value_name = "GLOB", value_delimiter = ',',
          conflicts_with_all = ["shard", "checkpoint", "clusters", "pcs"])]
    receivers: Vec<String>,
    /// Trace non-receiving glTF nodes of a shared mesh as instances (docs/guides/production-assets.md).
    #[arg(long, value_enum, default_value_t)]
    instances: InstancesArg,
    /// glTF `doubleSided` materials: auto bakes a back sheet of receivers (docs/guides/production-assets.md).
    #[arg(long, value_enum, default_value_t)]
    double_sided: DoubleSidedArg,
    /// Write the bake compressed by clustered PCA into K clusters, as `prt-bake compress`
    /// would (default 64 where only --pcs is given). Not with --shard or --checkpoint:
    /// compress the merged file with `prt-bake compress`.
    #[arg(long, value_name = "K", conflicts_with_all = ["shard", "checkpoint"])]
    clusters: Option<usize>,
    /// With compression: M principal components per cluster (default 4 where only
    /// --clusters is given).
    #[arg(long, value_name = "M", conflicts_with_all = ["shard", "checkpoint"])]
    pcs: Option<usize>,
    /// With compression: the lights to fit for, as `prt-bake compress --light-prior`.
    #[arg(long, value_enum, conflicts_with_all = ["shard", "checkpoint"])]
    light_prior: Option<super::compress::LightPriorArg>,
    /// With compression: the seedings to fit from, as `prt-bake compress --starts`.
    #[arg(long, value_name = "S", conflicts_with_all = ["shard", "checkpoint"])]
    starts: Option<usize>,
    /// Bake transfer probes instead of vertices (docs/guides/probes.md): at each point the n²×n²
    /// matrix of the radiance arriving from the whole sphere, --samples rays per probe.
    /// POINTS.txt (one `x y z` a line), or grid:NX,NY,NZ over the scene's bounds (cell
    /// centres), or grid:NX,NY,NZ:X0,Y0,Z0,X1,Y1,Z1 over a box of its own.
    #[arg(long, value_name = "POINTS.txt|grid:NX,NY,NZ", conflicts_with_all = ["lightmap", "clusters", "pcs", "target_error"])]
    probes: Option<String>,
    #[command(flatten)]
    occluder: super::bake_occluder::OccluderArgs,
}

pub fn run(args: BakeArgs) -> Result<(), Error> {
    if args.occluder.occluder {
        return super::bake_occluder::run(&args.scene, &args.output, &args.occluder);
    }
    super::bake_run::run(&plan(args)?)
}

/// `prt-bake prepare-lightmap`: [`run`] up to the texel bake's preparation, written to -o.
pub fn run_prepare(mut args: BakeArgs) -> Result<(), Error> {
    super::bake_occluder::refuse_in_prepare(&args.occluder)?;
    args.prepare_only = true;
    run(args)
}

/// What is baked: probes, the lightmap's preparation, a bake in parts, or a whole bake.
fn what(args: &BakeArgs) -> What {
    match &args.probes {
        Some(spec) => What::Probes(spec.clone()),
        None if args.prepare_only => What::Prepare,
        None if args.shard.is_some() || args.checkpoint.is_some() => What::Parts,
        None => What::Whole,
    }
}

/// The library's options for the arguments (their values are checked by
/// [`BakeOptions::validate`] and against the memory limit).
fn options(args: &BakeArgs, what: &What) -> BakeOptions {
    let mode = args.mode.mode();
    // `prepare-lightmap` takes its shards' default: every stage casts the same rays.
    let receivers_denoised = denoised(args, !matches!(what, What::Probes(_)));
    let samples = default_samples(receivers_denoised, args.target_error.is_some());
    let bounces = if mode == Mode::Interreflected { 1 } else { 0 };
    BakeOptions {
        order: args.order,
        samples: args.samples.unwrap_or(samples),
        mode,
        seed: args.seed,
        sampling: args.sampling.sampling(),
        bounces: args.bounces.unwrap_or(bounces),
        bounce_samples: args.bounce_samples,
        aux: AuxArg::aux(&args.aux),
        hit_cache_limit: args.hit_cache_mb.saturating_mul(1 << 20),
        target_error: args.target_error,
        transfer: args.transfer.transfer.kind(),
        denoise: denoised(args, matches!(what, What::Whole | What::Parts)),
    }
}

/// Whether `--denoise` filters a bake of receivers (auto: lightmaps and adaptive bakes, as lightmappers do).
fn denoised(args: &BakeArgs, receivers: bool) -> bool {
    args.denoise.or_auto(
        receivers
            && args.mode.mode().casts_rays()
            && (args.lightmap.is_some() || args.target_error.is_some())
            && (args.lightmap.is_some() || args.receivers.is_empty())
            && args.sampling == SamplingArg::OwenSobol,
    )
}

/// The plan of the arguments, checked in this order: the options, denoising only receivers,
/// the sample tables' memory, the compression, the lightmap's resolution, the shard, the
/// backend, `--prepared` only in parts.
fn plan(args: BakeArgs) -> Result<BakePlan, Error> {
    let what = what(&args);
    let options = options(&args, &what);
    options.validate()?;
    super::bake_plan::check_denoise(&options, &what)?;
    memory::check_bake_options(&options)?;
    let prior = args.light_prior.map(Into::into);
    let fit = compress::bake_fit(args.clusters, args.pcs, prior, args.starts, options.order)?;
    if let Some(resolution) = args.lightmap {
        lightmap::atlas::check_resolution(resolution)?;
    }
    let shard = match &args.shard {
        Some(spec) => Some(ShardId::parse(spec, &|name| std::env::var(name).ok())?),
        None => None,
    };
    let tracer = tracer_options(args.threads, args.robust, args.lightmap.is_some(), &options);
    let backend = args.backend.backend();
    if options.mode.casts_rays() {
        trace::check(backend, tracer)?;
    }
    let split = Split {
        shard,
        checkpoint: args.checkpoint,
        checkpoint_vertices: args.checkpoint_vertices,
    };
    if args.prepared.is_some() && !split.any() {
        return Err(Error::InvalidOption(
            "--prepared is for texel bakes in parts: give --shard or --checkpoint".into(),
        ));
    }
    Ok(BakePlan {
        scene: args.scene,
        load: LoadPlan {
            up: args.up.map(UpArg::up),
            receivers: args.receivers,
            instances: args.instances,
            double_sided: args.double_sided,
            pose: args.transfer.pose.clone(),
        },
        materials: args.materials,
        output: args.output,
        what,
        whole_scene: !split.any() && !args.prepare_only,
        split,
        lightmap: LightmapPlan {
            resolution: args.lightmap,
            texel_size: args.texel_size,
            atlas: args.atlas.map(AtlasArg::method),
            strict_uvs: args.strict_uvs,
            prepared: args.prepared,
        },
        ldprt: args.transfer.ldprt_lobes()?,
        options,
        backend,
        tracer,
        threads: args.threads,
        fit,
        report: Report {
            quiet: args.quiet,
            verbose: args.verbose,
            hit_cache_mb: args.hit_cache_mb,
        },
    })
}
