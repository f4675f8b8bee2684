//! `prt-bake`: bakes per-vertex SH transfer coefficients, inspects and exports them, projects
//! light rigs and relights bakes with them.
//! Everything it does is a library call; this file parses arguments and reports.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use prt_baker::checkpoint;
use prt_baker::light::Rig;
use prt_baker::output::Output;
use prt_baker::progress::{Progress, ProgressBar, Silent};
use prt_baker::sampling::Sampling;
use prt_baker::shard::{self, ShardId, shard_range};
use prt_baker::trace::{self, Backend, TracerOptions};
use prt_baker::transfer::Aux;
use prt_baker::{BakeOptions, CoefficientFile, Error, Mode, Scene, limits, sh};

/// Exit codes: 0 success, 1 failure (I/O, backend), 2 bad command line, 3 bad input files.
const EXIT_FAILURE: u8 = 1;
const EXIT_BAD_COMMAND_LINE: u8 = 2;
const EXIT_BAD_INPUT: u8 = 3;

#[derive(Parser)]
#[command(
    name = "prt-bake",
    version,
    about = "Precomputed radiance transfer baker"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Memory the command may use, in MiB (default: 3/4 of the physical memory). Inputs and
    /// bakes that need more are refused before anything is allocated.
    #[arg(long, global = true, value_name = "MIB")]
    max_memory: Option<u64>,
}

#[derive(Subcommand)]
enum Command {
    /// Bake per-vertex transfer coefficients of a scene into a .prt file.
    Bake(BakeArgs),
    /// Print a coefficient file's header as JSON.
    Inspect {
        /// The .prt file.
        file: PathBuf,
    },
    /// Write a coefficient file and its scene as NumPy arrays (--npz), as a binary glTF
    /// with the transfer as vertex attributes or the lightmap UVs (--gltf), and a lightmap
    /// bake as OpenEXR images (--exr).
    Export(ExportArgs),
    /// Project a light rig (TOML) to SH and write the summed RGB coefficients as JSON.
    Light {
        /// The rig file (docs/lights.md).
        rig: PathBuf,
        /// SH order n: n² coefficients per colour channel.
        #[arg(long, default_value_t = 4)]
        order: usize,
        /// The up axis of the scene the coefficients are for: rigs are written for a z-up
        /// world and are turned to a y-up scene as `relight` and the viewer turn them.
        #[arg(long, value_enum, default_value_t = UpArg::Z)]
        up: UpArg,
        /// Output .json file (`-`: standard output).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Light a bake with a rig on the CPU and write per-vertex radiance as a PLY mesh.
    Relight(RelightArgs),
    /// Compress a bake by clustered PCA (Sloan et al. 2003) into a version-2 .prt file that
    /// `relight`, `export` and the viewer read as its reconstruction.
    Compress {
        /// The .prt file (a whole bake, vertex or texel).
        file: PathBuf,
        /// Output coefficient file.
        #[arg(short, long)]
        output: PathBuf,
        /// Clusters K.
        #[arg(long, default_value_t = 64)]
        clusters: usize,
        /// Principal components per cluster M.
        #[arg(long, default_value_t = 4)]
        pcs: usize,
    },
    /// Merge the shard parts of a bake (`bake --shard`) into the file one machine would have
    /// baked, byte for byte; refuses missing, duplicated or foreign parts (docs/distributed.md).
    Merge {
        /// Every part of the bake, in any order.
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// Output coefficient file.
        #[arg(short, long)]
        output: PathBuf,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
    },
}

#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("outputs").required(true).multiple(true).args(["npz", "gltf", "exr"])))]
struct ExportArgs {
    /// The .prt file.
    file: PathBuf,
    /// The scene it was baked from.
    #[arg(long)]
    scene: PathBuf,
    /// Output .npz file (positions, normals, albedo, transfer, uv, triangles, aux arrays).
    #[arg(long)]
    npz: Option<PathBuf>,
    /// Output .glb file: the scene in world space, y up, with the transfer as `_PRT_k`
    /// vertex attributes, or for a lightmap bake with its lightmap UVs as TEXCOORD_1
    /// (docs/gltf.md).
    #[arg(long, visible_alias = "glb")]
    gltf: Option<PathBuf>,
    /// With --gltf: a light rig (TOML) whose relit shading goes into COLOR_0 (vertex bakes)
    /// or into an embedded lightmap texture (lightmap bakes).
    #[arg(long, requires = "gltf")]
    lights: Option<PathBuf>,
    /// Output directory (created if missing) for a lightmap bake's coefficients as OpenEXR
    /// images, 4 per RGBA image, with the texel mask, AO, bent normals and a manifest.json
    /// (docs/lightmaps.md).
    #[arg(long, value_name = "DIR")]
    exr: Option<PathBuf>,
    /// With --exr: the images' pixel type.
    #[arg(long, value_enum, default_value_t = ExrTypeArg::F32, requires = "exr")]
    exr_type: ExrTypeArg,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum ExrTypeArg {
    /// 16-bit half floats (11 significant bits).
    F16,
    /// 32-bit floats: the .prt's values exactly.
    F32,
}

#[derive(clap::Args)]
struct RelightArgs {
    /// The scene the coefficient file was baked from.
    scene: PathBuf,
    /// The .prt file.
    file: PathBuf,
    /// The light rig (TOML).
    #[arg(long)]
    lights: PathBuf,
    /// Output .ply file; for a lightmap bake a .png (tone-mapped) or .exr (linear) image.
    #[arg(short, long)]
    output: PathBuf,
    /// Exposure of the 8-bit colour in stops: radiance × 2^EV before clamping to [0, 1]
    /// (the float radiance is written unscaled).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f64,
}

#[derive(clap::Args)]
struct BakeArgs {
    /// A scene file (one `"object.obj" "texture.tga"` per line), a bare .obj, or a glTF 2.0
    /// file (.gltf, .glb).
    scene: PathBuf,
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
    /// Adaptive sampling: cast rays in rounds until each vertex's estimated RMS coefficient
    /// error is at most this (--samples becomes the most a vertex may cast). The error is
    /// estimated from 16 independently scrambled point sets; shadowed, owen-sobol only.
    #[arg(long)]
    target_error: Option<f32>,
    /// No progress bar (the summary line is still printed).
    #[arg(long)]
    quiet: bool,
    /// Bake only part K of N (0 ≤ K < N), a range of vertices, into a part file for
    /// `prt-bake merge`. `auto` reads K and N from a Slurm array task; `auto/N` takes K from
    /// a Kubernetes Indexed Job's JOB_COMPLETION_INDEX (or set PRT_SHARD_COUNT and use `auto`).
    #[arg(long, value_name = "K/N|auto|auto/N")]
    shard: Option<String>,
    /// Write completed blocks of vertices into DIR as the bake goes; the same command run
    /// again after a crash or a kill continues from them (same file as an uninterrupted bake).
    #[arg(long, value_name = "DIR")]
    checkpoint: Option<PathBuf>,
    /// Vertices per checkpoint block (default: about 67 million rays' worth).
    #[arg(long, requires = "checkpoint")]
    checkpoint_vertices: Option<usize>,
    /// Bake per texel of a RES×RES lightmap atlas instead of per vertex (docs/lightmaps.md):
    /// the scene's lightmap UVs (glTF TEXCOORD_1) where it has them and no --texel-size is
    /// given, else an atlas unwrapped here (--atlas). Unshadowed and shadowed modes.
    #[arg(long, value_name = "RES")]
    lightmap: Option<u32>,
    /// With --lightmap: the world size of a texel (default: the charts fill the atlas).
    #[arg(long, value_name = "S")]
    texel_size: Option<f32>,
    /// With --lightmap: unwrap the atlas here (even where the scene has lightmap UVs) with
    /// `unwrap` (the default: few large charts, curved meshes too) or `planar` (flat charts,
    /// shelf-packed; no distortion, but one chart per few triangles on curved meshes).
    #[arg(long, value_enum)]
    atlas: Option<AtlasArg>,
    /// Write the bake compressed by clustered PCA into K clusters, as `prt-bake compress`
    /// would (default 64 where only --pcs is given).
    #[arg(long, value_name = "K")]
    clusters: Option<usize>,
    /// With compression: M principal components per cluster (default 4 where only
    /// --clusters is given).
    #[arg(long, value_name = "M")]
    pcs: Option<usize>,
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
enum UpArg {
    /// +z is up.
    Z,
    /// +y is up.
    Y,
}

impl UpArg {
    fn up(self) -> prt_baker::scene::Up {
        match self {
            UpArg::Z => prt_baker::scene::Up::Z,
            UpArg::Y => prt_baker::scene::Up::Y,
        }
    }
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

#[derive(Clone, Copy, ValueEnum)]
enum SamplingArg {
    /// Owen-scrambled Sobol points, cosine-weighted (lower error).
    OwenSobol,
    /// The thesis's independent uniform directions (the baseline).
    ThesisRandom,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Some(mib) = cli.max_memory {
        limits::set_max_memory(mib.saturating_mul(1 << 20));
    }
    // A panic is a bug, but still ends with one clear line and exit code 1; the output's
    // temporary file is removed as the panic unwinds (prt_baker::output).
    prt_baker::output::install_panic_hook("prt-bake");
    let result = std::panic::catch_unwind(|| match cli.command {
        Command::Bake(args) => bake(args),
        Command::Inspect { file } => inspect(&file),
        Command::Export(args) => export(args),
        Command::Light {
            rig,
            order,
            up,
            output,
        } => light(&rig, order, up, &output),
        Command::Relight(args) => relight(args),
        Command::Compress {
            file,
            output,
            clusters,
            pcs,
        } => compress(&file, &output, clusters, pcs),
        Command::Merge {
            parts,
            output,
            quiet,
        } => merge(&parts, &output, quiet),
    });
    let Ok(result) = result else {
        return ExitCode::from(EXIT_FAILURE);
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("prt-bake: error: {err}");
            // Option values clap accepts but the bake cannot honour (`--samples 0`), and
            // outputs the output policy refuses, are a bad command line too.
            ExitCode::from(
                if matches!(err, Error::InvalidOption(_) | Error::Output { .. }) {
                    EXIT_BAD_COMMAND_LINE
                } else if err.is_bad_input() {
                    EXIT_BAD_INPUT
                } else {
                    EXIT_FAILURE
                },
            )
        }
    }
}

fn bake(args: BakeArgs) -> Result<(), Error> {
    let mode = match args.mode {
        ModeArg::Unshadowed => Mode::Unshadowed,
        ModeArg::Shadowed => Mode::Shadowed,
        ModeArg::Interreflected => Mode::Interreflected,
    };
    let options = BakeOptions {
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
    };
    options.validate()?;
    limits::check_bake_options(&options)?;
    let shard = match &args.shard {
        Some(spec) => Some(ShardId::parse(spec, &|name| std::env::var(name).ok())?),
        None => None,
    };
    prt_baker::cpca::check_bake_options(args.clusters, args.pcs, options.order)?;
    if (args.clusters.is_some() || args.pcs.is_some())
        && (shard.is_some() || args.checkpoint.is_some())
    {
        return Err(Error::InvalidOption(
            "--clusters and --pcs cannot be combined with --shard or --checkpoint: compress \
             the merged file with `prt-bake compress`"
                .into(),
        ));
    }
    // Parts and checkpoint blocks do not carry an adaptive bake's per-vertex rays and errors.
    if options.target_error.is_some() && (shard.is_some() || args.checkpoint.is_some()) {
        return Err(Error::InvalidOption(
            "--target-error cannot be combined with --shard or --checkpoint (yet)".into(),
        ));
    }
    if args.texel_size.is_some() && args.lightmap.is_none() {
        return Err(Error::InvalidOption("--texel-size needs --lightmap".into()));
    }
    if args.atlas.is_some() && args.lightmap.is_none() {
        return Err(Error::InvalidOption("--atlas needs --lightmap".into()));
    }
    // Texel bakes are whole, fixed-sample bakes for now (docs/lightmaps.md).
    if args.lightmap.is_some()
        && (shard.is_some() || args.checkpoint.is_some() || options.target_error.is_some())
    {
        return Err(Error::InvalidOption(
            "--lightmap cannot be combined with --shard, --checkpoint or --target-error (yet)"
                .into(),
        ));
    }
    let tracer_options = TracerOptions {
        threads: args.threads,
        robust: args.robust,
    };
    if options.mode.casts_rays() {
        trace::check(args.backend.backend(), tracer_options)?;
    }
    Output::new(&args.output, std::slice::from_ref(&args.scene))?;
    if let Some(threads) = args.threads {
        if threads == 0 {
            return Err(Error::InvalidOption("--threads must be at least 1".into()));
        }
        // The process's one pool. (A pool of our own entered with `install` measured 14 %
        // slower on the demo bake, for no benefit in a single-bake process.)
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .map_err(|err| {
                Error::InvalidOption(format!("cannot start {threads} threads: {err}"))
            })?;
    }

    let mut scene = Scene::load(&args.scene)?;
    // --up overrides the format's axis; whole files, parts and checkpoints all record it.
    if let Some(up) = args.up {
        scene.up = up.up();
    }
    let output = Output::new(&args.output, &scene.input_files())?;
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
    let needed = limits::bake_bytes(&options, receivers, scene.triangles.len() as u64);
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
    let tracer = match options.mode.casts_rays() {
        false => None,
        true => Some(trace::build(
            args.backend.backend(),
            &scene,
            tracer_options,
        )?),
    };
    let progress: Box<dyn Progress> = if args.quiet {
        Box::new(Silent)
    } else {
        Box::new(ProgressBar::new())
    };
    if shard.is_some() || args.checkpoint.is_some() {
        return bake_in_parts(
            &args,
            &scene,
            tracer.as_deref(),
            &options,
            shard,
            progress.as_ref(),
        );
    }
    let (transfer, file, what) = match args.lightmap {
        None => {
            let transfer = prt_baker::bake(&scene, tracer.as_deref(), &options, progress.as_ref())?;
            let file = CoefficientFile::from_bake(&scene, &transfer);
            let what = format!("{} vertices", transfer.vertex_count);
            (transfer, file, what)
        }
        Some(resolution) => {
            use prt_baker::lightmap::Atlas;
            let atlas = match (&scene.lightmap_uvs, args.texel_size, args.atlas) {
                (Some(uvs), None, None) => {
                    Atlas::from_vertex_uvs(&scene, uvs, resolution, resolution)?
                }
                (_, texel_size, method) => {
                    let method = method.map_or(Default::default(), AtlasArg::method);
                    // The unwrap reports no progress of its own (seconds on the demo): a bar
                    // with its elapsed time shows that it runs.
                    progress.begin("atlas", 0, 0);
                    let generated = prt_baker::lightmap::atlas::generate(
                        &scene, resolution, texel_size, method,
                    );
                    progress.finish();
                    generated?.atlas
                }
            };
            let bake = prt_baker::lightmap::bake(
                &scene,
                tracer.as_deref(),
                &options,
                atlas,
                progress.as_ref(),
            )?;
            let file = CoefficientFile::from_lightmap_bake(&scene, &bake);
            let what = format!(
                "{} of {}×{} texels ({} moved out, {} left out as leaking)",
                bake.texels.valid_count(),
                bake.texels.width,
                bake.texels.height,
                bake.moved,
                bake.leaking
            );
            (bake.transfer, file, what)
        }
    };
    let (bytes, compressed) = prt_baker::cpca::bake_output(&file, args.clusters, args.pcs)?;
    output.write(&bytes)?;

    let rays = match transfer.rays_cast {
        0 => String::from("no rays"),
        rays => format!(
            "{rays} rays, {:.2} Mrays/s",
            rays as f64 / transfer.seconds.max(1e-9) / 1e6
        ),
    };
    let mode = match (options.mode, transfer.hit_cache_bytes) {
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
        Some(target) => format!(
            "{mode}, adaptive to {target:e}: {:.0} rays per vertex on average",
            transfer.rays_cast as f64 / transfer.vertex_count.max(1) as f64
        ),
        None => mode,
    };
    println!(
        "baked {what}, {rays}, {:.2} s (order {}, {mode}, {} samples, {}) -> {}",
        transfer.seconds,
        options.order,
        options.samples,
        transfer.backend.name(),
        args.output.display()
    );
    if let Some(c) = compressed {
        println!(
            "compressed to {} clusters × {} components: {:.2} floats per vertex (from {}), rms error {:.3e}",
            c.clusters, c.pcs, c.floats_per_vertex, c.uncompressed_floats_per_vertex, c.rms_error
        );
    }
    Ok(())
}

/// A bake with `--shard` or `--checkpoint`: a part file, or the whole file from checkpoint
/// blocks.
fn bake_in_parts(
    args: &BakeArgs,
    scene: &Scene,
    tracer: Option<&dyn trace::Tracer>,
    options: &BakeOptions,
    shard: Option<ShardId>,
    progress: &dyn Progress,
) -> Result<(), Error> {
    let started = std::time::Instant::now();
    let vertex_count = scene.vertex_count();
    let (id, vertices) = match shard {
        Some(shard) => (shard, shard_range(vertex_count, shard)),
        None => (ShardId { index: 0, count: 1 }, 0..vertex_count),
    };
    let (part, rays, blocks) = match &args.checkpoint {
        Some(dir) => {
            let block_vertices = args
                .checkpoint_vertices
                .unwrap_or_else(|| checkpoint::default_block_vertices(options));
            let done = checkpoint::bake(
                scene,
                tracer,
                options,
                id,
                vertices.clone(),
                dir,
                block_vertices,
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
            let (part, rays) =
                shard::bake_part(scene, tracer, options, id, vertices.clone(), progress)?;
            (part, rays, String::new())
        }
    };
    let what = match shard {
        Some(shard) => {
            part.write(&args.output)?;
            format!(
                "{shard} (vertices {}..{} of {vertex_count})",
                vertices.start, vertices.end
            )
        }
        None => {
            part.finish(progress).write(&args.output)?;
            format!("{vertex_count} vertices")
        }
    };
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

fn merge(parts: &[PathBuf], output: &Path, quiet: bool) -> Result<(), Error> {
    let output_policy = Output::new(output, parts)?;
    let started = std::time::Instant::now();
    let progress: Box<dyn Progress> = if quiet {
        Box::new(Silent)
    } else {
        Box::new(ProgressBar::new())
    };
    let file = prt_baker::merge::merge(parts, progress.as_ref())?;
    output_policy.write(&file.to_bytes().0)?;
    println!(
        "merged {} parts, {} vertices, {:.2} s -> {}",
        parts.len(),
        file.header.vertex_count,
        started.elapsed().as_secs_f64(),
        output.display()
    );
    Ok(())
}

fn compress(file: &Path, output: &Path, clusters: usize, pcs: usize) -> Result<(), Error> {
    let s = prt_baker::cpca::compress_file(file, output, clusters, pcs)?;
    println!(
        "compressed to {} clusters × {} components: {:.2} floats per vertex (from {}), rms error {:.3e} -> {}",
        s.clusters,
        s.pcs,
        s.floats_per_vertex,
        s.uncompressed_floats_per_vertex,
        s.rms_error,
        output.display()
    );
    Ok(())
}

/// "1 bounce", "2 bounces".
fn bounces(count: u32) -> String {
    match count {
        1 => String::from("1 bounce"),
        n => format!("{n} bounces"),
    }
}

fn export(args: ExportArgs) -> Result<(), Error> {
    // Checked before the inputs are read; the writers check again against all of them.
    let mut inputs = vec![args.file.clone(), args.scene.clone()];
    inputs.extend(args.lights.clone());
    for output in args.npz.iter().chain(&args.gltf) {
        Output::new(output, &inputs)?;
    }
    // First: it refuses a vertex bake before anything is written.
    if let Some(dir) = &args.exr {
        let pixel_type = match args.exr_type {
            ExrTypeArg::F16 => prt_baker::openexr::PixelType::F16,
            ExrTypeArg::F32 => prt_baker::openexr::PixelType::F32,
        };
        let written = prt_baker::export::export_exr(&args.file, &args.scene, dir, pixel_type)?;
        println!(
            "wrote {} {}×{} {} OpenEXR images of {} and {}",
            written.files.len(),
            written.width,
            written.height,
            pixel_type.name(),
            args.file.display(),
            written.manifest.display()
        );
    }
    if let Some(npz) = &args.npz {
        prt_baker::export::export_npz(&args.file, &args.scene, npz)?;
        println!(
            "wrote {} (NumPy arrays of {})",
            npz.display(),
            args.file.display()
        );
    }
    if let Some(glb) = &args.gltf {
        let written = prt_baker::gltf_export::export_glb(
            &args.file,
            &args.scene,
            glb,
            args.lights.as_deref(),
        )?;
        let prt = match written.prt_attributes.as_slice() {
            [] if written.lightmap.is_some() => {
                let [w, h] = written.lightmap.unwrap_or_default();
                format!(
                    "TEXCOORD_1 = the {w}×{h} lightmap's UVs{}",
                    if written.lightmap_texture {
                        ", the relit lightmap embedded (materials' extras.prt_lightmap)"
                    } else {
                        ""
                    }
                )
            }
            [] => String::from("no transfer"),
            [only] => format!("transfer in {only}"),
            [first, .., last] => format!(
                "transfer in {} VEC4 attributes {first}..{last}",
                written.prt_attributes.len()
            ),
        };
        println!(
            "wrote {} ({} bytes): {} vertices, {} triangles, {} material(s), {} texture(s), {prt}{}{}",
            glb.display(),
            written.bytes,
            written.vertex_count,
            written.triangle_count,
            written.materials,
            written.textures,
            if written.colour {
                ", COLOR_0 lit by the rig (unlit materials)"
            } else {
                ""
            },
            if written.turned_to_y_up {
                "; turned from z-up to glTF's y-up"
            } else {
                ""
            },
        );
    }
    Ok(())
}

fn inspect(path: &Path) -> Result<(), Error> {
    let bytes = limits::read_file(path)?;
    let is_part = bytes.len() >= prt_baker::coefficient_file::HEADER_SIZE
        && matches!(shard::PartId::from_header_bytes(&bytes), Ok(Some(_)));
    let json = if is_part {
        // A shard part: its header, plus which shard and vertices it holds.
        let part = shard::Part::read(path)?;
        let mut json = serde_json::to_value(&part.header).expect("the header serialises");
        json["shard"] = serde_json::to_value(part.id).expect("the identity serialises");
        json
    } else {
        let file = CoefficientFile::read(path)?;
        let mut json = serde_json::to_value(&file.header).expect("the header serialises");
        // Adaptive bakes: how the per-vertex rays and estimated errors are distributed.
        if let (Some(adaptive), Some(rays), Some(errors)) =
            (file.header.adaptive, &file.rays, &file.error_estimate)
        {
            let summary = prt_baker::adaptive::Summary::new(adaptive.target_error, rays, errors);
            json["per_vertex"] = serde_json::to_value(summary).expect("the summary serialises");
        }
        prt_baker::cpca_block::annotate_inspect(&bytes, &mut json);
        if let Some(l) = &file.lightmap {
            // Texel bakes: the lightmap block.
            let texels = |flags: &[bool]| flags.iter().filter(|&&f| f).count();
            json["lightmap"] = serde_json::json!({
                "width": l.width,
                "height": l.height,
                "baked_texels": texels(&l.valid),
                "dilated_texels": texels(&l.dilated),
                "texel_size": l.texel_size,
                "atlas": match l.source {
                    prt_baker::lightmap::AtlasSource::Generated => "generated",
                    prt_baker::lightmap::AtlasSource::SceneUvs => "scene-uvs",
                },
                "scene_vertex_count": l.scene_vertex_count,
                "scene_triangle_count": l.scene_triangle_count,
            });
        }
        json
    };
    let json = serde_json::to_string_pretty(&json).expect("JSON serialises");
    println!("{json}");
    Ok(())
}

fn light(rig: &Path, order: usize, up: UpArg, output: &Path) -> Result<(), Error> {
    if !(1..=sh::MAX_ORDER).contains(&order) {
        return Err(Error::InvalidOption(format!(
            "--order {order} is outside 1..={}",
            sh::MAX_ORDER
        )));
    }
    Output::new_or_stdout(output, &[rig.to_path_buf()])?;
    let rig = Rig::load(rig)?;
    let output = Output::new_or_stdout(output, &rig.input_files())?;
    let json = rig.project(order).in_scene_frame(up.up()).to_json() + "\n";
    output.write(json.as_bytes())
}

fn relight(args: RelightArgs) -> Result<(), Error> {
    if !args.exposure.is_finite() {
        return Err(Error::InvalidOption("--exposure must be finite".into()));
    }
    let inputs = [args.scene.clone(), args.file.clone(), args.lights.clone()];
    Output::new(&args.output, &inputs)?;
    let relit = prt_baker::relight::relight(
        &args.scene,
        &args.file,
        &args.lights,
        &args.output,
        args.exposure,
    )?;
    println!(
        "relit {} {} with {} light(s) at order {}, largest radiance {:.4} -> {}",
        relit.vertex_count,
        if relit.lightmap { "texels" } else { "vertices" },
        relit.light_count,
        relit.order,
        relit.max_radiance,
        args.output.display()
    );
    Ok(())
}

/// `bake --atlas`: which unwrapper makes a generated lightmap atlas.
#[derive(Clone, Copy, ValueEnum)]
enum AtlasArg {
    Unwrap,
    Planar,
}

impl AtlasArg {
    fn method(self) -> prt_baker::lightmap::atlas::AtlasMethod {
        match self {
            AtlasArg::Unwrap => prt_baker::lightmap::atlas::AtlasMethod::Unwrap,
            AtlasArg::Planar => prt_baker::lightmap::atlas::AtlasMethod::Planar,
        }
    }
}
