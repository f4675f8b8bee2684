//! `prt-bake merge`: shard parts joined into the file one machine would have baked; or, for
//! a bake distributed bounce by bounce, one stage's files joined for the next stage
//! (docs/guides/clusters.md).

use std::path::PathBuf;

use prt_baker::distribute::bounce_stages::{self, Merged};
use prt_baker::distribute::merge::merge_with;
use prt_baker::distribute::stitch_columns;
use prt_baker::support::output::Output;
use prt_baker::{CoefficientFile, Error};

#[derive(clap::Args)]
pub struct MergeArgs {
    /// Every part of the bake, in any order (with --lower: every shard's gather of a bounce).
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// Output coefficient file (with --direct, or --lower before the last bounce: a bounce
    /// file for `prt-bake gather`).
    #[arg(short, long)]
    output: PathBuf,
    /// Interreflected parts: write bounce file 0 (every receiver's direct transfer) for
    /// `prt-bake gather`, leaving the bounces to the shards, instead of gathering them here.
    #[arg(long, conflicts_with_all = ["lower", "unstitched", "factor"])]
    direct: bool,
    /// The PARTS are the shards' gathers of bounce k (`prt-bake gather`) and FILE the merged
    /// bounce file k − 1: write bounce file k, or after the last bounce the bake's file.
    #[arg(long, value_name = "FILE")]
    lower: Option<PathBuf>,
    /// Texel bakes: place and dilate the lightmap but leave the seams unstitched, for
    /// `prt-bake stitch` to stitch in shards of columns.
    #[arg(long)]
    unstitched: bool,
    /// Texel bakes: stitch the seams with their system factored once (`prt-bake
    /// factor-seams`), checked against the lightmap, instead of factoring it here: the last
    /// merge then writes the stitched file, with no stitch shards after it.
    #[arg(long, value_name = "FILE", conflicts_with = "unstitched")]
    factor: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

pub fn run(args: MergeArgs) -> Result<(), Error> {
    let (parts, output) = (args.parts.as_slice(), args.output.as_path());
    let mut inputs = parts.to_vec();
    inputs.extend(args.lower.clone());
    inputs.extend(args.factor.clone());
    let output_policy = Output::new(output, &inputs)?;
    let started = std::time::Instant::now();
    let progress = super::progress(args.quiet);
    let stitch = !args.unstitched && args.factor.is_none();
    let bounce = match (&args.lower, args.direct) {
        (Some(lower), _) => Some(bounce_stages::merge(parts, lower)?),
        (None, true) => Some(bounce_stages::direct(parts)?),
        (None, false) => None,
    };
    let file = match bounce {
        Some(merged) if args.factor.is_some() && !merged.file.is_last() => {
            return Err(Error::Shards(format!(
                "--factor: the gathers of bounce {} of {} make a bounce file, not the bake's: \
                 give --factor to the last bounce's merge",
                merged.file.k, merged.file.stub.header.bounces
            )));
        }
        Some(merged) if !merged.file.is_last() || args.direct => {
            return write_bounce(&merged, parts.len(), &output_policy, started);
        }
        Some(merged) => merged.file.into_file(stitch),
        None => merge_with(parts, stitch, progress.as_ref())?,
    };
    let file = match &args.factor {
        // The lightmap came from the lower bounce file, or from the parts.
        Some(factor_path) => {
            let from = args.lower.as_deref().unwrap_or(&parts[0]);
            stitch_columns::stitch_with_factor(from, file, factor_path)?
        }
        None => file,
    };
    // In pieces, the arrays borrowed: no copy of the whole file (172 MB at 2048²).
    output_policy.write_parts(&file.encode().0.parts())?;
    println!(
        "merged {} parts, {}{}, {:.2} s -> {}",
        parts.len(),
        what(&file),
        match (args.unstitched, &args.factor) {
            (true, _) => ", unstitched".to_string(),
            (_, Some(factor)) => format!(", stitched with {}", factor.display()),
            _ => String::new(),
        },
        started.elapsed().as_secs_f64(),
        output.display()
    );
    Ok(())
}

fn write_bounce(
    merged: &Merged,
    parts: usize,
    output: &Output,
    started: std::time::Instant,
) -> Result<(), Error> {
    output.write_parts(&merged.encode().parts())?;
    let bounce = &merged.file;
    println!(
        "merged {parts} files, bounce {} of {} of {} receivers, {:.2} s -> {}",
        bounce.k,
        bounce.stub.header.bounces,
        bounce.count,
        started.elapsed().as_secs_f64(),
        output.path().display()
    );
    Ok(())
}

/// "W×H texels", "N probes", "N vertices".
fn what(file: &CoefficientFile) -> String {
    match (&file.lightmap, &file.probes) {
        (Some(l), _) => format!("{}×{} texels", l.width, l.height),
        (None, Some(_)) => format!("{} probes", file.header.vertex_count),
        (None, None) => format!("{} vertices", file.header.vertex_count),
    }
}
