//! `prt-bake bake`: a scene's transfer, per vertex or per lightmap texel, whole or in shard
//! parts and checkpoint blocks.

use std::path::PathBuf;

use clap::ValueEnum;
use prt_baker::bake::lightmap;
use prt_baker::bake::memory;
use prt_baker::bake::options::Aux;
use prt_baker::bake::receiver_names::receiver_objects;
use prt_baker::bake::receiver_subset::bake_objects_translucent;
use prt_baker::bake::subsurface;
use prt_baker::distribute::prepared_file;
use prt_baker::distribute::shard::ShardId;
use prt_baker::export::compress;
use prt_baker::math::medium::Medium;
use prt_baker::math::sampling::Sampling;
use prt_baker::support::limits;
use prt_baker::support::output::Output;
use prt_baker::support::progress::Progress;
use prt_baker::trace::{self, Backend, Tracer, TracerOptions};
use prt_baker::{BakeOptions, CoefficientFile, Error, Mode, Scene, Transfer};

use super::scene_load::{self, DoubleSidedArg, InstancesArg};
use super::{UpArg, bake_parts};

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
    /// Rays cast per vertex (directions per vertex in unshadowed mode).
    #[arg(long, default_value_t = 1024)]
    samples: u32,
    #[arg(long, value_enum, default_value_t = ModeArg::Shadowed)]
    mode: ModeArg,
    /// What is stored per vertex: the diffuse transfer vector (n² floats per channel), or the
    /// transfer matrix (n²×n², for glossy BRDFs; any mode, per vertex).
    #[arg(long, value_enum, default_value_t = TransferArg::Vector)]
    transfer: TransferArg,
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
    /// Rays per vertex whose hits feed the bounces (interreflected mode; default a quarter of
    /// --samples): closest-hit rays cost 2–4 times occlusion rays, bounced light needs fewer.
    #[arg(long)]
    bounce_samples: Option<u32>,
    /// Per-vertex arrays to store beside the coefficients: ambient accessibility and the
    /// bent normal (comma-separated).
    #[arg(long, value_enum, value_delimiter = ',')]
    aux: Vec<AuxArg>,
    /// Memory (MiB) the interreflected mode may use to cache first hits; beyond it the
    /// bounces re-trace (slower, same result).
    #[arg(long, default_value_t = 1024)]
    hit_cache_mb: u64,
    /// Ray-tracing backend: Embree, or obvhs (pure Rust, watertight, about a quarter of
    /// Embree's speed; the only one in a build without Embree). Recorded in the file.
    #[arg(long, value_enum, default_value_t = BackendArg::DEFAULT)]
    backend: BackendArg,
    /// Embree's robust mode for every ray (about 30 % slower). Without it, only the rays of
    /// vertices near another surface's edge use it, which already makes the answers
    /// watertight. Applies to --backend embree only.
    #[arg(long)]
    robust: bool,
    /// Adaptive sampling: each vertex (with --lightmap: texel) casts rays until its estimated
    /// RMS coefficient error is at most this (--samples becomes the most it may cast): a pilot
    /// of 4 independently scrambled point sets, then one net of the predicted size; shadowed,
    /// owen-sobol only.
    #[arg(long, conflicts_with_all = ["shard", "checkpoint"])]
    target_error: Option<f32>,
    /// Denoise the baked transfer (a filter in world space whose weights every coefficient
    /// shares, so every light sees it denoised; docs/denoising.md). auto: on for whole
    /// lightmap bakes that cast a fixed number of owen-sobol rays, as lightmappers do; off
    /// for vertex bakes, parts, probes and adaptive bakes.
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
    /// Vertices (with --lightmap: baked texels) per checkpoint block (default: about 67
    /// million rays' worth).
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
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum DenoiseArg {
    Auto,
    On,
    Off,
}

#[derive(Clone, Copy, ValueEnum)]
enum TransferArg {
    Vector,
    Matrix,
}

#[derive(Clone, Copy, ValueEnum)]
enum ModeArg {
    /// Cosine-weighted reflectance only (no rays).
    Unshadowed,
    /// With occlusion rays.
    Shadowed,
    /// Shadowed plus light bounced off other surfaces, in colour.
    Interreflected,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum AuxArg {
    /// Ambient accessibility: cosine-weighted fraction of the sky seen.
    Ao,
    /// Cosine-weighted mean unoccluded direction.
    BentNormal,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum BackendArg {
    /// Intel Embree (needs a build with the `embree` feature, the default).
    Embree,
    /// obvhs, a pure-Rust BVH.
    Obvhs,
}

impl BackendArg {
    const DEFAULT: BackendArg = match Backend::DEFAULT {
        Backend::Obvhs => BackendArg::Obvhs,
        _ => BackendArg::Embree,
    };

    fn backend(self) -> Backend {
        match self {
            BackendArg::Embree => Backend::Embree,
            BackendArg::Obvhs => Backend::Obvhs,
        }
    }
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum SamplingArg {
    /// Owen-scrambled Sobol points, cosine-weighted (lower error).
    OwenSobol,
    /// The thesis's independent uniform directions (the baseline).
    ThesisRandom,
}

/// `bake --atlas`: which unwrapper makes a generated lightmap atlas.
#[derive(Clone, Copy, ValueEnum)]
enum AtlasArg {
    Unwrap,
    Planar,
}

impl AtlasArg {
    fn method(self) -> prt_baker::bake::lightmap::atlas::AtlasMethod {
        match self {
            AtlasArg::Unwrap => prt_baker::bake::lightmap::atlas::AtlasMethod::Unwrap,
            AtlasArg::Planar => prt_baker::bake::lightmap::atlas::AtlasMethod::Planar,
        }
    }
}

/// The library's options for the arguments (their values are checked by
/// [`BakeOptions::validate`] and against the memory limit).
fn options(args: &BakeArgs) -> BakeOptions {
    let mode = match args.mode {
        ModeArg::Unshadowed => Mode::Unshadowed,
        ModeArg::Shadowed => Mode::Shadowed,
        ModeArg::Interreflected => Mode::Interreflected,
    };
    BakeOptions {
        order: args.order,
        samples: args.samples,
        mode,
        seed: args.seed,
        sampling: match args.sampling {
            SamplingArg::OwenSobol => Sampling::OwenSobol,
            SamplingArg::ThesisRandom => Sampling::ThesisRandom,
        },
        bounces: args
            .bounces
            .unwrap_or(if mode == Mode::Interreflected { 1 } else { 0 }),
        bounce_samples: args.bounce_samples,
        aux: Aux {
            ao: args.aux.contains(&AuxArg::Ao),
            bent_normal: args.aux.contains(&AuxArg::BentNormal),
        },
        hit_cache_limit: args.hit_cache_mb.saturating_mul(1 << 20),
        target_error: args.target_error,
        transfer: match args.transfer {
            TransferArg::Vector => prt_baker::bake::options::TransferKind::Vector,
            TransferArg::Matrix => prt_baker::bake::options::TransferKind::Matrix,
        },
        denoise: match args.denoise {
            DenoiseArg::On => true,
            DenoiseArg::Off => false,
            DenoiseArg::Auto => {
                args.lightmap.is_some()
                    && !args.in_parts()
                    && mode.casts_rays()
                    && args.target_error.is_none()
                    && args.sampling == SamplingArg::OwenSobol
            }
        },
    }
}

impl BakeArgs {
    /// Whether this process bakes a part of a bake (a shard, a checkpointed run, the
    /// prepared lightmap) or probes, rather than a whole bake's file.
    fn in_parts(&self) -> bool {
        self.shard.is_some()
            || self.checkpoint.is_some()
            || self.prepare_only
            || self.probes.is_some()
    }
}

/// `prt-bake prepare-lightmap`: [`run`] up to the texel bake's preparation, written to -o.
pub fn run_prepare(mut args: BakeArgs) -> Result<(), Error> {
    args.prepare_only = true;
    run(args)
}

impl BakeArgs {
    /// What a prepared lightmap depends on, hashed ([`prepared_file::key`]): the scene, the
    /// lightmap options, the seed, the backend, and whether rays are cast (the leak test).
    fn prepared_key(&self, scene: &Scene, options: &BakeOptions) -> u64 {
        let lightmap = format!(
            "{:?} {:?} {:?} {} {} {:?}",
            self.lightmap,
            self.texel_size.map(f32::to_bits),
            self.atlas.map(|a| a.method()),
            self.strict_uvs,
            self.robust,
            scene.up,
        );
        let backend = self.backend.backend().name();
        let rays = options.mode.casts_rays();
        prepared_file::key(scene.fingerprint(), &lightmap, options.seed, backend, rays)
    }
}

pub fn run(args: BakeArgs) -> Result<(), Error> {
    let options = options(&args);
    options.validate()?;
    if options.denoise && args.in_parts() {
        return Err(Error::InvalidOption(
            "--denoise on is for whole bakes: parts, checkpoints and probes are not denoised"
                .into(),
        ));
    }
    memory::check_bake_options(&options)?;
    let fit = compress::bake_fit(
        args.clusters,
        args.pcs,
        args.light_prior.map(Into::into),
        args.starts,
        options.order,
    )?;
    if let Some(resolution) = args.lightmap {
        lightmap::atlas::check_resolution(resolution)?;
    }
    let shard = match &args.shard {
        Some(spec) => Some(ShardId::parse(spec, &|name| std::env::var(name).ok())?),
        None => None,
    };
    let tracer_options = TracerOptions {
        threads: args.threads,
        robust: args.robust,
        // A texel bake casts no ray from a vertex: its texels' seam points are found apart.
        points_only: args.lightmap.is_some(),
        // Picks Embree's BVH quality; from the command line alone, so every process of a
        // staged or sharded bake picks the same.
        rays_per_receiver: options
            .samples
            .saturating_add(options.effective_bounce_samples()),
    };
    if options.mode.casts_rays() {
        trace::check(args.backend.backend(), tracer_options)?;
    }
    let mut inputs = vec![args.scene.clone()];
    inputs.extend(args.materials.clone());
    inputs.extend(args.prepared.clone());
    let in_parts = shard.is_some() || args.checkpoint.is_some();
    if args.prepared.is_some() && !in_parts {
        return Err(Error::InvalidOption(
            "--prepared is for texel bakes in parts: give --shard or --checkpoint".into(),
        ));
    }
    Output::new(&args.output, &inputs)?;
    if let Some(threads) = args.threads {
        start_threads(threads)?;
    }

    // Whole bakes, per vertex or texel: the non-receivers only occlude.
    let whole = !in_parts && !args.prepare_only;
    let instancing = whole && args.probes.is_none() && args.materials.is_none();
    let instancing = instancing && options.mode != Mode::Interreflected;
    // What every process of a bake pays before its own work (`--verbose`).
    let mut setup = lightmap::Stages::default();
    let mut scene = setup.time("scene", || {
        scene_load::load(
            &args.scene,
            args.instances,
            &args.receivers,
            instancing,
            args.double_sided,
        )
    })?;
    // --up overrides the format's axis; whole files, parts and checkpoints all record it.
    if let Some(up) = args.up {
        scene.up = up.up();
    }
    let mut inputs = scene.input_files();
    inputs.extend(args.materials.clone());
    inputs.extend(args.prepared.clone());
    let output = Output::new(&args.output, &inputs)?;
    // Whole bakes only (clap refuses --receivers with the others; glTF marks are not
    // applied to them).
    let receivers = match whole {
        true => receiver_objects(&scene, &args.receivers)?,
        false => None,
    };
    let media = super::bake_media::media(
        &scene,
        args.materials.as_deref(),
        &options,
        shard.is_some() || args.checkpoint.is_some(),
    )?;
    let subsurface = media.iter().any(Option::is_some);
    check_memory(&args, &options, &scene)?;
    let tracer = match options.mode.casts_rays() {
        false => None,
        true => Some(setup.time("tracer", || {
            trace::build(args.backend.backend(), &scene, tracer_options)
        })?),
    };
    if args.verbose {
        eprintln!("prt-bake: stages: {}", setup.line());
    }
    let progress = super::progress(args.quiet);
    if let Some(spec) = &args.probes {
        let tracer = tracer.as_deref();
        return super::bake_probes::bake(
            spec,
            &args.output,
            &scene,
            tracer,
            &options,
            (shard, args.checkpoint.as_deref(), args.checkpoint_vertices),
            progress.as_ref(),
        );
    }
    if args.prepare_only || in_parts {
        let tracer = tracer.as_deref();
        let atlas = |resolution| atlas(&args, &scene, resolution, progress.as_ref());
        let parts = bake_parts::PartsArgs {
            lightmap: args.lightmap,
            checkpoint: args.checkpoint.as_deref(),
            checkpoint_vertices: args.checkpoint_vertices,
            output: &args.output,
            prepared: args.prepared.as_deref(),
            prepared_key: args.prepared_key(&scene, &options),
            verbose: args.verbose,
            atlas: &atlas,
        };
        let progress = progress.as_ref();
        return match args.prepare_only {
            true => bake_parts::prepare_lightmap(&parts, &scene, tracer, &options),
            false => bake_parts::bake_in_parts(&parts, &scene, tracer, &options, shard, progress),
        };
    }
    let (transfer, file, what) = match (args.lightmap, receivers) {
        (None, Some(objects)) => {
            let transfer = bake_objects_translucent(
                &scene,
                tracer.as_deref(),
                &options,
                &objects,
                &media,
                progress.as_ref(),
            )?;
            let file = CoefficientFile::from_object_bake(&scene, &transfer, &objects);
            let what = format!(
                "{} vertices of {} receiving objects (of {})",
                transfer.receiver_count,
                objects.len(),
                scene.objects.len()
            );
            (transfer, file, what)
        }
        (None, None) => {
            // Subsurface transfer is added after the bake: denoised after it, with it.
            let direct = BakeOptions {
                denoise: options.denoise && !subsurface,
                ..options.clone()
            };
            let mut transfer =
                prt_baker::bake(&scene, tracer.as_deref(), &direct, progress.as_ref())?;
            if let (true, Some(tracer)) = (subsurface, tracer.as_deref()) {
                let started = std::time::Instant::now();
                subsurface::apply_to_vertices(
                    &scene,
                    tracer,
                    &media,
                    &mut transfer,
                    progress.as_ref(),
                )?;
                if options.denoise {
                    prt_baker::bake::denoise::denoise_baked(
                        prt_baker::bake::denoise::vertex_guides(&scene, Vec::new()),
                        prt_baker::bake::denoise::Settings::VERTICES,
                        &options,
                        &mut transfer.coefficients,
                        transfer.channels,
                        &transfer.visibility,
                    );
                    transfer.options.denoise = true;
                }
                transfer.seconds += started.elapsed().as_secs_f64();
            }
            let file = CoefficientFile::from_bake(&scene, &transfer);
            let what = format!("{} vertices", transfer.receiver_count);
            (transfer, file, what)
        }
        (Some(resolution), objects) => {
            let tracer = tracer.as_deref();
            bake_texels(
                &args,
                (&scene, objects.as_deref()),
                tracer,
                &media,
                &options,
                resolution,
                progress.as_ref(),
            )?
        }
    };
    let mut stages = lightmap::Stages::default();
    let compressed = stages.time("writing", || -> Result<_, Error> {
        let (bytes, compressed) = compress::bake_output(&file, fit.as_ref())?;
        output.write_parts(&bytes.parts())?;
        Ok(compressed)
    })?;
    if args.verbose {
        eprintln!("prt-bake: stages: {}", stages.line());
    }
    println!("{}", summary(&args, &options, &transfer, &what));
    if let Some(c) = compressed {
        println!(
            "compressed to {} clusters × {} components: {:.2} floats per vertex (from {}), rms error {:.3e}",
            c.clusters, c.pcs, c.floats_per_vertex, c.uncompressed_floats_per_vertex, c.rms_error
        );
    }
    Ok(())
}

/// `--threads`: the process's one pool. (A pool of our own entered with `install` measured
/// 14 % slower on the demo bake, for no benefit in a single-bake process.)
fn start_threads(threads: usize) -> Result<(), Error> {
    if threads == 0 {
        return Err(Error::InvalidOption("--threads must be at least 1".into()));
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .map_err(|err| Error::InvalidOption(format!("cannot start {threads} threads: {err}")))
}

/// Refuses a bake whose memory estimate exceeds `--max-memory`, and says so when it is large.
fn check_memory(args: &BakeArgs, options: &BakeOptions, scene: &Scene) -> Result<(), Error> {
    // A texel bake's receivers are the atlas's texels, besides the scene's own vertices.
    let (receivers, what) = match args.lightmap {
        Some(res) => {
            let texels = u64::from(res) * u64::from(res);
            (
                texels + scene.vertex_count() as u64,
                format!("{texels} texels"),
            )
        }
        None => (
            scene.vertex_count() as u64,
            format!("{} vertices", scene.vertex_count()),
        ),
    };
    let needed = memory::bake_bytes(options, receivers, scene.triangles.len() as u64);
    limits::check(
        args.scene.display().to_string(),
        &format!(
            "baking {what} at order {} with {} samples",
            options.order, options.samples
        ),
        needed,
    )?;
    if !args.quiet && needed.is_some_and(|n| n >= 1 << 30) {
        eprintln!(
            "prt-bake: this bake needs up to {} of memory (limit {})",
            limits::human(needed.unwrap_or(0)),
            limits::human(limits::max_memory())
        );
    }
    Ok(())
}

/// `--lightmap RES`: the atlas (the scene's lightmap UVs, or generated), then the texel bake.
fn bake_texels(
    args: &BakeArgs,
    (scene, receivers): (&Scene, Option<&[u32]>),
    tracer: Option<&dyn Tracer>,
    media: &[Option<Medium>],
    options: &BakeOptions,
    resolution: u32,
    progress: &dyn Progress,
) -> Result<(Transfer, CoefficientFile, String), Error> {
    let mut stages = lightmap::Stages::default();
    let atlas = stages.time("atlas", || match receivers {
        None => atlas(args, scene, resolution, progress),
        Some(objects) => {
            lightmap::receiving::check_mode(options.mode)?;
            let alone = lightmap::receiving::receiver_scene(scene, objects);
            let atlas = atlas(args, &alone, resolution, progress)?;
            Ok(lightmap::receiving::widen(scene, objects, atlas))
        }
    })?;
    let bake = lightmap::bake_texels(
        scene,
        tracer,
        options,
        atlas,
        media,
        lightmap::TexelPoints::Released,
        progress,
    )?;
    if args.verbose {
        eprintln!(
            "prt-bake: stages: {}, {}; stitching factor {} nonzeros",
            stages.line(),
            bake.stages.line(),
            bake.seams.factor_nonzeros
        );
    }
    let seams = match bake.seams.samples {
        0 => String::new(),
        n => format!(
            "; seams stitched at {n} points, step {:.1e} -> {:.1e}",
            bake.seams.step_before, bake.seams.step_after
        ),
    };
    let what = format!(
        "{} of {}×{} texels ({} moved out, {} left out as leaking{seams})",
        bake.texels.valid_count(),
        bake.texels.width,
        bake.texels.height,
        bake.moved,
        bake.leaking
    );
    let (file, transfer) = CoefficientFile::from_lightmap_bake_owned(scene, bake);
    Ok((transfer, file, what))
}

/// `--lightmap RES`'s atlas: the scene's lightmap UVs, or generated.
fn atlas(
    args: &BakeArgs,
    scene: &Scene,
    resolution: u32,
    progress: &dyn Progress,
) -> Result<lightmap::Atlas, Error> {
    Ok(match (&scene.lightmap_uvs, args.texel_size, args.atlas) {
        (Some(uvs), None, None) => {
            let (atlas, _, notes) =
                lightmap::objects::from_scene_uvs(scene, uvs, resolution, args.strict_uvs)?;
            notes.iter().for_each(|n| eprintln!("prt-bake: {n}"));
            atlas
        }
        (_, texel_size, method) => {
            let method = method.map_or(Default::default(), AtlasArg::method);
            // The unwrap reports no progress of its own (seconds on the demo): a bar
            // with its elapsed time shows that it runs.
            progress.begin("atlas", 0, 0);
            let generated = lightmap::atlas::generate(scene, resolution, texel_size, method);
            progress.finish();
            let generated = generated?;
            if let Some(note) = generated.fragmentation_note(method, scene.triangles.len()) {
                eprintln!("prt-bake: {note}");
            }
            generated.atlas
        }
    })
}

/// The line printed after a whole bake: what, how many rays, how fast, how.
fn summary(args: &BakeArgs, options: &BakeOptions, transfer: &Transfer, what: &str) -> String {
    let rays = match transfer.rays_cast {
        0 => String::from("no rays"),
        rays => format!(
            "{rays} rays, {:.2} Mrays/s",
            rays as f64 / transfer.seconds.max(1e-9) / 1e6
        ),
    };
    let mode = match (options.mode, transfer.hit_cache_bytes) {
        // A one-bounce matrix bake: its vector pass has no bounces, so no rows to cache.
        (Mode::Interreflected, Some(0)) => format!(
            "interreflected, {} from {} rays, {} channels",
            bounces(options.bounces),
            options.effective_bounce_samples(),
            transfer.channels,
        ),
        (Mode::Interreflected, Some(bytes)) => format!(
            "interreflected, {} from {} rays, {} channels, hit cache {:.0} MiB",
            bounces(options.bounces),
            options.effective_bounce_samples(),
            transfer.channels,
            bytes as f64 / f64::from(1 << 20)
        ),
        (Mode::Interreflected, None) => format!(
            "interreflected, {} from {} rays, {} channels, re-traced (hit cache over {} MiB)",
            bounces(options.bounces),
            options.effective_bounce_samples(),
            transfer.channels,
            args.hit_cache_mb
        ),
        (mode, _) => mode.name().to_string(),
    };
    let mode = match options.target_error {
        Some(target) => {
            // Texel bakes: the baked texels only (the others cast no rays).
            let baked = transfer.visibility.iter().filter(|v| v.rays > 0).count();
            format!(
                "{mode}, adaptive to {target:e}: {:.0} rays per {} on average",
                transfer.rays_cast as f64 / baked.max(1) as f64,
                if args.lightmap.is_some() {
                    "texel"
                } else {
                    "vertex"
                }
            )
        }
        None => mode,
    };
    format!(
        "baked {what}, {rays}, {:.2} s (order {}, {mode}, {} samples, {}) -> {}",
        transfer.seconds,
        options.order,
        options.samples,
        transfer.backend.name(),
        args.output.display()
    )
}

/// "1 bounce", "2 bounces".
fn bounces(count: u32) -> String {
    match count {
        1 => String::from("1 bounce"),
        n => format!("{n} bounces"),
    }
}
