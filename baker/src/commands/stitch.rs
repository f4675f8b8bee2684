//! `prt-bake stitch`: a texel bake's seams stitched in shards of columns, then joined
//! (docs/guides/clusters.md).

use std::path::PathBuf;
use std::time::Instant;

use prt_baker::Error;
use prt_baker::distribute::factor_file::FactorFile;
use prt_baker::distribute::shard::ShardId;
use prt_baker::distribute::stitch_columns::Seams;
use prt_baker::distribute::{column_join, prepared_file, stitch_columns};
use prt_baker::support::cpu_time::process_cpu_seconds;
use prt_baker::support::output::Output;

#[derive(clap::Args)]
pub struct StitchArgs {
    /// The merged, unstitched texel file (`merge --unstitched`).
    file: PathBuf,
    /// Stitch only columns shard K of N (`auto`, `auto/N` as `bake --shard`) into a column
    /// file for --join.
    #[arg(long, value_name = "K/N|auto|auto/N", conflicts_with = "join")]
    columns: Option<String>,
    /// With --columns: the bake's prepared lightmap (`prt-bake prepare-lightmap`), for its
    /// seams (the shard factors their system); with --factor, checked against it.
    #[arg(long, value_name = "FILE")]
    prepared: Option<PathBuf>,
    /// With --columns: the seams' system factored once for all shards (`prt-bake
    /// factor-seams`): the shard only solves.
    #[arg(long, value_name = "FILE", requires = "columns")]
    factor: Option<PathBuf>,
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
    inputs.extend(args.factor.clone());
    inputs.extend(args.join.clone());
    let output = Output::new(&args.output, &inputs)?;
    let started = Instant::now();
    let mut reading = String::new();
    let what = match &args.columns {
        Some(spec) => {
            let (key, file) = stitch_columns::read_unstitched(&args.file)?;
            let shard = ShardId::parse(spec, &|name| std::env::var(name).ok())?;
            let columns = match (&args.factor, &args.prepared) {
                (Some(path), prepared) => {
                    let (read, cpu) = (Instant::now(), process_cpu_seconds().unwrap_or(0.0));
                    let factor = FactorFile::read(path)?;
                    reading = format!(
                        " (the factor read in {:.2} s, {:.2} CPU-s)",
                        read.elapsed().as_secs_f64(),
                        process_cpu_seconds().unwrap_or(0.0) - cpu
                    );
                    if let Some(prepared) = prepared {
                        let (key, sum, _) = prepared_file::read_identified(prepared)?;
                        factor.check_prepared(path, prepared, key, sum)?;
                    }
                    let seams = Seams::Factored(&factor, path);
                    stitch_columns::stitch_shard(&args.file, key, &file, seams, shard)?
                }
                (None, Some(prepared)) => {
                    let prepared = prepared_file::read_any(prepared)?;
                    let seams = Seams::Prepared(&prepared);
                    stitch_columns::stitch_shard(&args.file, key, &file, seams, shard)?
                }
                (None, None) => {
                    return Err(Error::InvalidOption(
                        "--columns needs --prepared FILE or --factor FILE".into(),
                    ));
                }
            };
            output.write(&columns.to_bytes())?;
            format!(
                "stitched columns {}..{} ({shard}){reading}",
                columns.first,
                columns.first + columns.count
            )
        }
        _ => {
            let bytes = std::fs::read(&args.file).map_err(|err| Error::io(&args.file, err))?;
            output.write(&column_join::join(&args.file, bytes, &args.join)?)?;
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
