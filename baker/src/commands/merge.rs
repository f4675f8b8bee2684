//! `prt-bake merge`: shard parts joined into the file one machine would have baked.

use std::path::PathBuf;

use prt_baker::Error;
use prt_baker::distribute::merge::merge;
use prt_baker::support::output::Output;

#[derive(clap::Args)]
pub struct MergeArgs {
    /// Every part of the bake, in any order.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// Output coefficient file.
    #[arg(short, long)]
    output: PathBuf,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

pub fn run(args: MergeArgs) -> Result<(), Error> {
    let (parts, output) = (args.parts.as_slice(), args.output.as_path());
    let output_policy = Output::new(output, parts)?;
    let started = std::time::Instant::now();
    let progress = super::progress(args.quiet);
    let file = merge(parts, progress.as_ref())?;
    output_policy.write(&file.to_bytes().0)?;
    let what = match (&file.lightmap, &file.probes) {
        (Some(l), _) => format!("{}×{} texels", l.width, l.height),
        (None, Some(_)) => format!("{} probes", file.header.vertex_count),
        (None, None) => format!("{} vertices", file.header.vertex_count),
    };
    println!(
        "merged {} parts, {what}, {:.2} s -> {}",
        parts.len(),
        started.elapsed().as_secs_f64(),
        output.display()
    );
    Ok(())
}
