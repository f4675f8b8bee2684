//! `prt-bake compress`: a bake through clustered PCA (Sloan et al. 2003) into a version-2
//! file that `relight`, `export` and the viewer read as its reconstruction.

use std::path::PathBuf;

use prt_baker::Error;
use prt_baker::export::compress::compress_file;

#[derive(clap::Args)]
pub struct CompressArgs {
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
}

pub fn run(args: CompressArgs) -> Result<(), Error> {
    let s = compress_file(&args.file, &args.output, args.clusters, args.pcs)?;
    println!(
        "compressed to {} clusters × {} components: {:.2} floats per vertex (from {}), rms error {:.3e} -> {}",
        s.clusters,
        s.pcs,
        s.floats_per_vertex,
        s.uncompressed_floats_per_vertex,
        s.rms_error,
        args.output.display()
    );
    Ok(())
}
