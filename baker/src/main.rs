//! `prt-bake`: bakes per-vertex SH transfer coefficients, inspects and exports them, projects
//! light rigs and relights bakes with them.
//! Everything it does is a library call; this file parses arguments and reports.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use prt_baker::light::Rig;
use prt_baker::progress::{Progress, ProgressBar, Silent};
use prt_baker::sampling::Sampling;
use prt_baker::trace::{self, Backend, TracerOptions};
use prt_baker::transfer::Aux;
use prt_baker::{BakeOptions, CoefficientFile, Error, Mode, Scene, sh};

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
    /// Write a coefficient file and its scene as NumPy arrays (positions, normals, albedo, transfer).
    Export {
        /// The .prt file.
        file: PathBuf,
        /// The scene it was baked from.
        #[arg(long)]
        scene: PathBuf,
        /// Output .npz file.
        #[arg(long)]
        npz: PathBuf,
    },
    /// Project a light rig (TOML) to SH and write the summed RGB coefficients as JSON.
    Light {
        /// The rig file (docs/lights.md).
        rig: PathBuf,
        /// SH order n: n² coefficients per colour channel.
        #[arg(long, default_value_t = 4)]
        order: usize,
        /// Output .json file.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Light a bake with a rig on the CPU and write per-vertex radiance as a PLY mesh.
    Relight(RelightArgs),
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
    /// Output .ply file.
    #[arg(short, long)]
    output: PathBuf,
    /// Exposure of the 8-bit colour in stops: radiance × 2^EV before clamping to [0, 1]
    /// (the float radiance is written unscaled).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f64,
}

#[derive(clap::Args)]
struct BakeArgs {
    /// A scene file (one `"object.obj" "texture.tga"` per line) or a bare .obj.
    scene: PathBuf,
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
    /// Ray-tracing backend: Embree, or obvhs (pure Rust, watertight, about a sixth of
    /// Embree's speed; the only one in a build without Embree). Recorded in the file.
    #[arg(long, value_enum, default_value_t = BackendArg::DEFAULT)]
    backend: BackendArg,
    /// Embree's robust mode: no accuracy-reducing optimisations (about 30 % slower). Applies
    /// to --backend embree only.
    #[arg(long)]
    robust: bool,
    /// No progress bar (the summary line is still printed).
    #[arg(long)]
    quiet: bool,
    /// Bake per texel of a RES×RES lightmap atlas (xatlas unwrap) instead of per vertex
    /// (docs/lightmaps.md). Unshadowed and shadowed modes.
    #[arg(long, value_name = "RES")]
    lightmap: Option<u32>,
    /// With --lightmap: the world size of a texel (default: the charts fill the atlas).
    #[arg(long, value_name = "S")]
    texel_size: Option<f32>,
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

#[derive(Clone, Copy, ValueEnum)]
enum SamplingArg {
    /// Owen-scrambled Sobol points, cosine-weighted (lower error).
    OwenSobol,
    /// The thesis's independent uniform directions (the baseline).
    ThesisRandom,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Bake(args) => bake(args),
        Command::Inspect { file } => inspect(&file),
        Command::Export { file, scene, npz } => check_output_folder(&npz)
            .and_then(|()| prt_baker::export::export_npz(&file, &scene, &npz)),
        Command::Light { rig, order, output } => light(&rig, order, &output),
        Command::Relight(args) => relight(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("prt-bake: error: {err}");
            // Option values clap accepts but the bake cannot honour (`--samples 0`) are a bad
            // command line too.
            ExitCode::from(if matches!(err, Error::InvalidOption(_)) {
                EXIT_BAD_COMMAND_LINE
            } else if err.is_bad_input() {
                EXIT_BAD_INPUT
            } else {
                EXIT_FAILURE
            })
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
    };
    options.validate()?;
    if args.texel_size.is_some() && args.lightmap.is_none() {
        return Err(Error::InvalidOption("--texel-size needs --lightmap".into()));
    }
    let tracer_options = TracerOptions {
        threads: args.threads,
        robust: args.robust,
    };
    if options.mode.casts_rays() {
        trace::check(args.backend.backend(), tracer_options)?;
    }
    check_output_folder(&args.output)?;
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

    let scene = Scene::load(&args.scene)?;
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
    let (transfer, mut file, what) = match args.lightmap {
        None => {
            let transfer = prt_baker::bake(&scene, tracer.as_deref(), &options, progress.as_ref())?;
            let file = CoefficientFile::from_bake(&scene, &transfer);
            let what = format!("{} vertices", transfer.vertex_count);
            (transfer, file, what)
        }
        Some(resolution) => {
            let atlas = prt_baker::lightmap::Atlas::generate(&scene, resolution, args.texel_size)?;
            let bake = prt_baker::lightmap::bake(
                &scene,
                tracer.as_deref(),
                &options,
                atlas,
                progress.as_ref(),
            )?;
            let file = CoefficientFile::from_lightmap_bake(&scene, &bake);
            let what = format!(
                "{} of {}×{} texels ({} left out as leaking)",
                bake.texels.valid_count(),
                bake.texels.width,
                bake.texels.height,
                bake.leaking
            );
            (bake.transfer, file, what)
        }
    };
    file.write(&args.output)?;

    let rays = match transfer.rays_cast {
        0 => String::from("no rays"),
        rays => format!(
            "{rays} rays, {:.2} Mrays/s",
            rays as f64 / transfer.seconds.max(1e-9) / 1e6
        ),
    };
    let mode = match (options.mode, transfer.hit_cache_bytes) {
        (Mode::Interreflected, Some(bytes)) => format!(
            "interreflected, {} bounces from {} rays, {} channels, hit cache {:.0} MiB",
            options.bounces,
            options.effective_bounce_samples(),
            transfer.channels,
            bytes as f64 / f64::from(1 << 20)
        ),
        (Mode::Interreflected, None) => format!(
            "interreflected, {} bounces from {} rays, {} channels, re-traced (hit cache over {} MiB)",
            options.bounces,
            options.effective_bounce_samples(),
            transfer.channels,
            args.hit_cache_mb
        ),
        (mode, _) => mode.name().to_string(),
    };
    println!(
        "baked {what}, {rays}, {:.2} s (order {}, {mode}, {} samples, {}) -> {}",
        transfer.seconds,
        options.order,
        options.samples,
        transfer.backend.name(),
        args.output.display()
    );
    Ok(())
}

/// Fails before a long bake rather than after it if the output cannot be written there.
fn check_output_folder(output: &Path) -> Result<(), Error> {
    let folder = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !folder.is_dir() {
        return Err(Error::io(
            output,
            std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!("folder {} does not exist", folder.display()),
            ),
        ));
    }
    Ok(())
}

fn inspect(path: &Path) -> Result<(), Error> {
    let file = CoefficientFile::read(path)?;
    let Some(l) = &file.lightmap else {
        let json = serde_json::to_string_pretty(&file.header).expect("the header serialises");
        println!("{json}");
        return Ok(());
    };
    // Texel bakes: the header (keys sorted) and the lightmap block.
    let mut json = serde_json::to_value(&file.header).expect("the header serialises");
    if let Some(object) = json.as_object_mut() {
        let texels = |flags: &[bool]| flags.iter().filter(|&&f| f).count();
        object.insert(
            "lightmap".into(),
            serde_json::json!({
                "width": l.width,
                "height": l.height,
                "baked_texels": texels(&l.valid),
                "dilated_texels": texels(&l.dilated),
                "texel_size": l.texel_size,
                "scene_vertex_count": l.scene_vertex_count,
                "scene_triangle_count": l.scene_triangle_count,
            }),
        );
    }
    let json = serde_json::to_string_pretty(&json).expect("JSON serialises");
    println!("{json}");
    Ok(())
}

fn light(rig: &Path, order: usize, output: &Path) -> Result<(), Error> {
    if !(1..=sh::MAX_ORDER).contains(&order) {
        return Err(Error::InvalidOption(format!(
            "--order {order} is outside 1..={}",
            sh::MAX_ORDER
        )));
    }
    check_output_folder(output)?;
    let rig = Rig::load(rig)?;
    let json = rig.project(order).to_json() + "\n";
    prt_baker::atomic::write(output, json.as_bytes())
}

fn relight(args: RelightArgs) -> Result<(), Error> {
    if !args.exposure.is_finite() {
        return Err(Error::InvalidOption("--exposure must be finite".into()));
    }
    check_output_folder(&args.output)?;
    let relit = prt_baker::relight::relight(
        &args.scene,
        &args.file,
        &args.lights,
        &args.output,
        args.exposure,
    )?;
    println!(
        "relit {} vertices with {} light(s) at order {}, largest radiance {:.4} -> {}",
        relit.vertex_count,
        relit.light_count,
        relit.order,
        relit.max_radiance,
        args.output.display()
    );
    Ok(())
}
