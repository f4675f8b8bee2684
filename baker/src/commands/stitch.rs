//! `prt-bake stitch`: a texel bake's seams stitched in shards of columns, then joined
//! (docs/distributed.md).

use std::path::PathBuf;

use prt_baker::Error;
use prt_baker::distribute::shard::ShardId;
use prt_baker::distribute::{prepared_file, stitch_columns};
use prt_baker::support::output::Output;

#[derive(clap::Args)]
pub struct StitchArgs {
    /// The merged, unstitched texel file (`merge --unstitched`).
    file: PathBuf,
    /// Stitch only columns shard K of N (`auto`, `auto/N` as `bake --shard`) into a column
    /// file for --join.
    #[arg(
        long,
        value_name = "K/N|auto|auto/N",
        requires = "prepared",
        conflicts_with = "join"
    )]
    columns: Option<String>,
    /// With --columns: the bake's prepared lightmap (`prt-bake prepare-lightmap`), for its
    /// seams.
    #[arg(long, value_name = "FILE")]
    prepared: Option<PathBuf>,
    /// Put every shard's column file into FILE: the stitched texel file.
    #[arg(long, value_name = "COLUMNS", num_args = 1.., required_unless_present = "columns")]
    join: Vec<PathBuf>,
    /// Output: a column file (--columns) or the stitched texel file (--join).
    #[arg(short, long)]
    output: PathBuf,
}

pub fn run(args: StitchArgs) -> Result<(), Error> {
    let mut inputs = vec![args.file.clone()];
    inputs.extend(args.prepared.clone());
    inputs.extend(args.join.clone());
    let output = Output::new(&args.output, &inputs)?;
    let started = std::time::Instant::now();
    let (key, file) = stitch_columns::read_unstitched(&args.file)?;
    let what = match (&args.columns, &args.prepared) {
        (Some(spec), Some(prepared)) => {
            let shard = ShardId::parse(spec, &|name| std::env::var(name).ok())?;
            let prepared = prepared_file::read_any(prepared)?;
            let columns = stitch_columns::stitch_shard(&args.file, key, &file, &prepared, shard)?;
            output.write(&columns.to_bytes())?;
            format!(
                "stitched columns {}..{} ({shard})",
                columns.first,
                columns.first + columns.count
            )
        }
        _ => {
            let file = stitch_columns::join(&args.file, key, file, &args.join)?;
            output.write(&file.to_bytes().0)?;
            format!("joined {} column files", args.join.len())
        }
    };
    println!(
        "{what}, {:.2} s -> {}",
        started.elapsed().as_secs_f64(),
        args.output.display()
    );
    Ok(())
}
