//! `prt-bake factor-seams`: a texel bake's seam stitch factored once, from its prepared
//! lightmap, for every `stitch --columns K/N --factor FILE` shard (docs/guides/clusters.md).

use std::path::PathBuf;
use std::time::Instant;

use prt_baker::Error;
use prt_baker::distribute::{factor_file, prepared_file};
use prt_baker::support::cpu_time::process_cpu_seconds;
use prt_baker::support::output::Output;

#[derive(clap::Args)]
pub struct FactorSeamsArgs {
    /// The bake's prepared lightmap (`prt-bake prepare-lightmap`).
    prepared: PathBuf,
    /// Output: the seam factor, for `stitch --columns K/N --factor FILE`.
    #[arg(short, long)]
    output: PathBuf,
}

pub fn run(args: FactorSeamsArgs) -> Result<(), Error> {
    let output = Output::new(&args.output, std::slice::from_ref(&args.prepared))?;
    // Wall and CPU seconds at each step's end: the bench (scripts/bench/lightmap_scale.sh)
    // reports the file's reading, factoring and writing apart.
    let mut marks = vec![(Instant::now(), process_cpu_seconds().unwrap_or(0.0))];
    let mut mark = || marks.push((Instant::now(), process_cpu_seconds().unwrap_or(0.0)));
    let (key, sum, prepared) = prepared_file::read_identified(&args.prepared)?;
    mark();
    let file = factor_file::factor_prepared(&prepared, key, sum);
    drop(prepared);
    mark();
    let bytes = file.encode();
    output.write_parts(&bytes.parts())?;
    mark();
    let (unknowns, nonzeros) = file
        .factored
        .factor()
        .map_or((0, 0), |f| (f.texels().len(), f.len()));
    let step = |k: usize| {
        let ((t0, c0), (t1, c1)) = (marks[k], marks[k + 1]);
        format!("{:.2} s ({:.2} CPU-s)", (t1 - t0).as_secs_f64(), c1 - c0)
    };
    println!(
        "factored {unknowns} seam unknowns ({nonzeros} factor values, {:.1} MB): read {}, \
         factor {}, write {} -> {}",
        bytes.len() as f64 / 1e6,
        step(0),
        step(1),
        step(2),
        args.output.display()
    );
    Ok(())
}
