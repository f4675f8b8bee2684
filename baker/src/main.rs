//! `prt-bake`: bakes per-vertex SH transfer coefficients, inspects and exports them.
//! Everything it does is a library call; this file parses arguments and reports.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use prt_baker::progress::{Progress, ProgressBar, Silent};
use prt_baker::sampling::Sampling;
use prt_baker::trace::{self, Backend, TracerOptions};
use prt_baker::{BakeOptions, CoefficientFile, Error, Mode, Scene};

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
    /// Ray-tracing backend (shadowed mode): Embree, or obvhs (pure Rust, about a third of
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
}

#[derive(Clone, Copy, ValueEnum)]
enum ModeArg {
    /// Cosine-weighted reflectance only (no rays).
    Unshadowed,
    /// With occlusion rays.
    Shadowed,
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
    let options = BakeOptions {
        order: args.order,
        samples: args.samples,
        mode: match args.mode {
            ModeArg::Unshadowed => Mode::Unshadowed,
            ModeArg::Shadowed => Mode::Shadowed,
        },
        seed: args.seed,
        sampling: match args.sampling {
            SamplingArg::OwenSobol => Sampling::OwenSobol,
            SamplingArg::ThesisRandom => Sampling::ThesisRandom,
        },
    };
    options.validate()?;
    let tracer_options = TracerOptions {
        threads: args.threads,
        robust: args.robust,
    };
    if options.mode == Mode::Shadowed {
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
    let tracer = match options.mode {
        Mode::Unshadowed => None,
        Mode::Shadowed => Some(trace::build(
            args.backend.backend(),
            &scene,
            tracer_options,
        )?),
    };
    let progress: Box<dyn Progress> = if args.quiet {
        Box::new(Silent)
    } else {
        Box::new(ProgressBar::new("baking"))
    };
    let transfer = prt_baker::bake(&scene, tracer.as_deref(), &options, progress.as_ref())?;
    let mut file = CoefficientFile::from_bake(&scene, &transfer);
    file.write(&args.output)?;

    let rays = match transfer.rays_cast {
        0 => String::from("no rays"),
        rays => format!(
            "{rays} rays, {:.2} Mrays/s",
            rays as f64 / transfer.seconds.max(1e-9) / 1e6
        ),
    };
    println!(
        "baked {} vertices, {rays}, {:.2} s (order {}, {}, {} samples, {}) -> {}",
        transfer.vertex_count,
        transfer.seconds,
        options.order,
        options.mode.name(),
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
    let json = serde_json::to_string_pretty(&file.header).expect("the header serialises");
    println!("{json}");
    Ok(())
}
