//! `prt-bake gather`: one shard's bounce k of an interreflected bake distributed bounce by
//! bounce (docs/guides/clusters.md).

use std::path::PathBuf;

use prt_baker::Error;
use prt_baker::distribute::bounce_stages;
use prt_baker::support::output::Output;

#[derive(clap::Args)]
pub struct GatherArgs {
    /// The shard's part (`bake --shard K/N`, interreflected): its bounce rows.
    part: PathBuf,
    /// The merged bounce file k − 1 (`merge --direct` for k = 1, `merge --lower` after).
    #[arg(long, value_name = "FILE")]
    lower: PathBuf,
    /// Output: the shard's bounce k, for `prt-bake merge --lower`.
    #[arg(short, long)]
    output: PathBuf,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

pub fn run(args: GatherArgs) -> Result<(), Error> {
    let inputs = [args.part.clone(), args.lower.clone()];
    let output = Output::new(&args.output, &inputs)?;
    let started = std::time::Instant::now();
    let progress = super::progress(args.quiet);
    let gathered = bounce_stages::gather(&args.part, &args.lower, progress.as_ref())?;
    output.write_parts(&gathered.encode().parts())?;
    let file = &gathered.file;
    let shard = file.shard.map_or(String::new(), |s| format!("{s}, "));
    println!(
        "gathered bounce {} of {} ({shard}receivers {}..{}), {:.2} s -> {}",
        file.k,
        file.stub.header.bounces,
        file.first,
        file.first + file.count,
        started.elapsed().as_secs_f64(),
        args.output.display()
    );
    Ok(())
}
