//! `prt-bake compress`: a bake through clustered PCA (Sloan et al. 2003) into a version-2
//! file that `relight`, `export` and the viewer read as its reconstruction.

use std::path::PathBuf;

use clap::ValueEnum;
use prt_baker::Error;
use prt_baker::export::compress::{FitOptions, compress_file};
use prt_baker::math::light_prior::LightPrior;

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
    /// The lights to fit for: `sphere` (from every direction alike) or `upper-hemisphere`
    /// (above the scene's horizon, as suns and skies over a ground; lights below it count a
    /// tenth: docs/explanation/performance.md, "CPCA compression").
    #[arg(long, value_enum, default_value_t = LightPriorArg::Sphere)]
    light_prior: LightPriorArg,
    /// k-means++ seedings to fit from, keeping the best: the time grows with them, the
    /// error falls (the demo torus: 6 % less from 1 to 4).
    #[arg(long, default_value_t = prt_baker::math::cpca::STARTS)]
    starts: usize,
}

/// `--light-prior` of `compress` and `bake`.
#[derive(Clone, Copy, ValueEnum)]
pub enum LightPriorArg {
    Sphere,
    UpperHemisphere,
}

impl From<LightPriorArg> for LightPrior {
    fn from(arg: LightPriorArg) -> LightPrior {
        match arg {
            LightPriorArg::Sphere => LightPrior::Sphere,
            LightPriorArg::UpperHemisphere => LightPrior::UpperHemisphere,
        }
    }
}

pub fn run(args: CompressArgs) -> Result<(), Error> {
    let options = FitOptions {
        clusters: args.clusters,
        pcs: args.pcs,
        prior: args.light_prior.into(),
        starts: args.starts,
    };
    let s = compress_file(&args.file, &args.output, &options)?;
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
