//! `prt-bake`: bakes per-vertex or per-texel SH transfer, inspects and exports it, projects
//! light rigs and relights bakes with them. Every command lives in `commands/`, one file
//! each; this file parses the command line, dispatches, and maps errors to exit codes.

mod commands;

use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use prt_baker::Error;
use prt_baker::support::{input_path, limits, output};

use commands::{
    bake, compress, export, factor_seams, gather, inspect, light, merge, relight, stitch,
};

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
    /// Let inputs (glTF uris, OBJ mtllib and map_Kd, scene-file entries, rig maps) name files
    /// outside their own folder, or by absolute path.
    #[arg(long, global = true)]
    allow_outside_uris: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Bake per-vertex transfer coefficients of a scene into a .prt file.
    Bake(bake::BakeArgs),
    /// Print a coefficient file's header as JSON.
    Inspect {
        /// The .prt file.
        file: std::path::PathBuf,
    },
    /// Write a coefficient file and its scene as NumPy arrays (--npz), as a binary glTF
    /// with the transfer as vertex attributes or the lightmap UVs (--gltf), and a lightmap
    /// bake as OpenEXR images (--exr).
    Export(export::ExportArgs),
    /// Project a light rig (TOML) to SH and write the summed RGB coefficients as JSON.
    Light(light::LightArgs),
    /// Light a bake with a rig on the CPU and write per-vertex radiance as a PLY mesh.
    Relight(relight::RelightArgs),
    /// Compress a bake by clustered PCA (Sloan et al. 2003) into a version-2 .prt file that
    /// `relight`, `export` and the viewer read as its reconstruction.
    Compress(compress::CompressArgs),
    /// Merge the shard parts of a bake (`bake --shard`) into the file one machine would have
    /// baked, byte for byte; refuses missing, duplicated or foreign parts (docs/guides/clusters.md).
    Merge(merge::MergeArgs),
    // The staged pipeline's internals (docs/guides/clusters.md): scripts call them, a user
    // rarely does, so the help lists them apart, after the user's commands ([`command`]).
    /// Prepare a texel bake's lightmap once for all its shards: the atlas, the baked texels
    /// after the leak test and the seam partners, for `bake --shard K/N --prepared FILE` and
    /// `stitch` (takes `bake`'s options; docs/guides/clusters.md).
    #[command(hide = true)]
    PrepareLightmap(bake::BakeArgs),
    /// One shard's bounce k of an interreflected bake distributed bounce by bounce: gathered
    /// from its part's rows and the merged bounce k − 1 (docs/guides/clusters.md).
    #[command(hide = true)]
    Gather(gather::GatherArgs),
    /// Stitch a merged, unstitched texel bake's seams in shards of columns, and join them
    /// into the whole bake's file (docs/guides/clusters.md).
    #[command(hide = true)]
    Stitch(stitch::StitchArgs),
    /// Factor a texel bake's seam stitch once, from its prepared lightmap, for every
    /// `stitch --columns K/N --factor FILE` shard (docs/guides/clusters.md).
    #[command(hide = true)]
    FactorSeams(factor_seams::FactorSeamsArgs),
}

/// The command line: the user's commands under clap's "Commands:", the hidden cluster stages
/// after them under their own heading, each with its description.
fn command() -> clap::Command {
    let command = Cli::command();
    let stages: Vec<_> = command
        .get_subcommands()
        .filter(|c| c.is_hide_set())
        .collect();
    let width = stages.iter().map(|c| c.get_name().len()).max().unwrap_or(0) + 2;
    let mut text = String::from("Cluster stages (docs/guides/clusters.md):");
    for stage in stages {
        let about = stage
            .get_about()
            .map(ToString::to_string)
            .unwrap_or_default();
        text.push_str(&format!("\n  {:<width$}{about}", stage.get_name()));
    }
    command.after_help(text)
}

fn main() -> ExitCode {
    let parsed = command().try_get_matches();
    let cli = match parsed.and_then(|mut matches| Cli::from_arg_matches_mut(&mut matches)) {
        Ok(cli) => cli,
        Err(err) => return usage_error(err),
    };
    if let Some(mib) = cli.max_memory {
        limits::set_max_memory(mib.saturating_mul(1 << 20));
    }
    input_path::set_allow_outside(cli.allow_outside_uris);
    prt_baker::support::input_path::set_allow_outside(cli.allow_outside_uris);
    // A panic is a bug, but still ends with one clear line and exit code 1; the output's
    // temporary file is removed as the panic unwinds (prt_baker::support::output).
    output::install_panic_hook("prt-bake");
    let result = std::panic::catch_unwind(|| match cli.command {
        Command::Bake(args) => bake::run(args),
        Command::Inspect { file } => inspect::run(&file),
        Command::Export(args) => export::run(args),
        Command::Light(args) => light::run(args),
        Command::Relight(args) => relight::run(args),
        Command::Compress(args) => compress::run(args),
        Command::Merge(args) => merge::run(args),
        Command::PrepareLightmap(args) => bake::run_prepare(args),
        Command::Gather(args) => gather::run(args),
        Command::Stitch(args) => stitch::run(args),
        Command::FactorSeams(args) => factor_seams::run(args),
    });
    match result {
        Ok(Ok(())) => ExitCode::SUCCESS,
        Ok(Err(err)) => {
            eprintln!("prt-bake: error: {err}");
            ExitCode::from(exit_code(&err))
        }
        Err(_panic) => ExitCode::from(EXIT_FAILURE),
    }
}

/// A command line clap refuses: one line, as every other error (help and version print as
/// clap prints them). Its rules (ranges, `requires`, `conflicts_with`) are declared on the
/// arguments; this only formats what it says.
fn usage_error(err: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    if matches!(
        err.kind(),
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion
    ) || matches!(
        err.kind(),
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    ) {
        err.exit();
    }
    let text = err.render().to_string();
    let message: Vec<&str> = text
        .lines()
        .take_while(|line| !line.starts_with("Usage:") && !line.starts_with("For more information"))
        .map(str::trim)
        .filter(|line| !line.is_empty())
        .collect();
    let message = message.join(" ");
    let message = message.strip_prefix("error: ").unwrap_or(&message);
    eprintln!("prt-bake: error: {message} (see prt-bake --help)");
    ExitCode::from(EXIT_BAD_COMMAND_LINE)
}

/// Option values clap accepts but the bake cannot honour (`--samples 0`), and outputs the
/// output policy refuses, are a bad command line too.
fn exit_code(err: &Error) -> u8 {
    if matches!(err, Error::InvalidOption(_) | Error::Output { .. }) {
        EXIT_BAD_COMMAND_LINE
    } else if err.is_bad_input() {
        EXIT_BAD_INPUT
    } else {
        EXIT_FAILURE
    }
}
