//! `prt-bake compress` and `bake --clusters/--pcs`: a coefficient file's transfer through
//! clustered PCA ([`crate::math::cpca`]) into a version-2 file ([`crate::formats::cpca_block`]).

use std::path::Path;

use serde::Serialize;

use crate::formats::coefficient_file::CoefficientFile;
use crate::formats::encoded::Encoded;
use crate::math::cpca::{Cpca, STARTS, compress_from, rms_error};
use crate::math::light_prior::{LightPrior, Metric};
use crate::support::error::{Error, Result};

/// What [`compress_file`] wrote, for the CLI's summary line and `inspect`.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// Clusters stored (at most the K asked for: empty ones are dropped).
    pub clusters: usize,
    pub pcs: usize,
    /// Floats per receiver, shared cluster data included ([`Cpca::floats_per_vertex`]).
    pub floats_per_vertex: f64,
    /// RMS coefficient error of the reconstruction over every receiver and coefficient.
    pub rms_error: f64,
    /// The uncompressed file's floats per receiver (channels × n²).
    pub uncompressed_floats_per_vertex: usize,
}

impl Summary {
    pub fn new(cpca: &Cpca, rms_error: f64) -> Summary {
        Summary {
            clusters: cpca.clusters(),
            pcs: cpca.pcs,
            floats_per_vertex: cpca.floats_per_vertex(),
            rms_error,
            uncompressed_floats_per_vertex: cpca.dim,
        }
    }
}

/// What a CPCA fit is asked for: `compress`'s options, and `bake`'s with --clusters/--pcs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FitOptions {
    /// K clusters at most.
    pub clusters: usize,
    /// M principal components per cluster.
    pub pcs: usize,
    /// The lights the fit is to be accurate for.
    pub prior: LightPrior,
    /// k-means++ seedings the fit runs from, the best kept ([`crate::math::cpca::STARTS`]).
    pub starts: usize,
}

impl FitOptions {
    /// K clusters of M components, for lights from anywhere, from the default starts.
    pub fn new(clusters: usize, pcs: usize) -> FitOptions {
        FitOptions {
            clusters,
            pcs,
            prior: LightPrior::Sphere,
            starts: STARTS,
        }
    }

    /// K ≥ 1 and at least one start (M against the receiver's floats is checked where the
    /// file is known).
    fn check(&self) -> Result<()> {
        if self.clusters == 0 {
            return Err(Error::InvalidOption("--clusters must be at least 1".into()));
        }
        if self.starts == 0 {
            return Err(Error::InvalidOption("--starts must be at least 1".into()));
        }
        Ok(())
    }
}

/// Compresses a coefficient file in memory: the CPCA of its transfer, fitted for the lights
/// of the prior about the file's up axis, and the error of the reconstruction as it will be
/// read back (from the stored f32 values).
pub fn compress_coefficients(
    file: &CoefficientFile,
    options: &FitOptions,
) -> Result<(Cpca, Summary)> {
    options.check()?;
    let FitOptions {
        clusters,
        pcs,
        prior,
        starts,
    } = *options;
    let dim = file.header.coefficients_per_vertex();
    let v = file.header.vertex_count;
    // The fit's working set: the f64 scatter matrices, means and bases, per-receiver indices
    // and weights, the reconstruction used to measure the error, and every receiver's f64
    // error in every cluster (V × K: the refinement's and the moves' bookkeeping).
    let k = (clusters as u64).min(v);
    let (d, m) = (dim as u64, pcs as u64);
    let needed = k
        .checked_mul(d * d + (m + 2) * d)
        .and_then(|n| n.checked_mul(8))
        .and_then(|n| n.checked_add(v.checked_mul((m + 2 + d) * 8)?))
        .and_then(|n| n.checked_add(v.checked_mul(k)?.checked_mul(8)?));
    crate::support::limits::check("compress", "clustered PCA of the transfer", needed)?;
    let cpca = match prior {
        LightPrior::Sphere => compress_from(&file.coefficients, dim, clusters, pcs, starts)?,
        LightPrior::UpperHemisphere => {
            let order = file.header.order as usize;
            Metric::upper_hemisphere(order, file.header.up.vector()).compress(
                &file.coefficients,
                dim,
                clusters,
                pcs,
                starts,
            )?
        }
    };
    let error = rms_error(&file.coefficients, &cpca.reconstruct());
    let summary = Summary::new(&cpca, error);
    Ok((cpca, summary))
}

/// `prt-bake compress`: reads `input` (any whole bake, vertex or texel; a compressed one is
/// read as its reconstruction), fits K clusters of M components and writes the version-2 file
/// atomically to `output`.
pub fn compress_file(input: &Path, output: &Path, options: &FitOptions) -> Result<Summary> {
    options.check()?;
    let pcs = options.pcs;
    let out = crate::support::output::Output::new(output, &[input.to_path_buf()])?;
    let file = CoefficientFile::read(input)?;
    let dim = file.header.coefficients_per_vertex();
    if pcs > dim {
        return Err(Error::InvalidOption(format!(
            "--pcs {pcs} is more than the {dim} coefficients per receiver of {}",
            input.display()
        )));
    }
    if file.header.vertex_count == 0 {
        return Err(Error::coefficient_file(input, "no receivers to compress"));
    }
    if file.header.receivers.is_some() {
        return Err(Error::InvalidOption(format!(
            "{}: a bake of some objects (--receivers), which compress does not read yet",
            input.display()
        )));
    }
    let (cpca, summary) = compress_coefficients(&file, options)?;
    let bytes = crate::formats::cpca_block::to_bytes(&file, &cpca, summary.rms_error as f32);
    out.write(&bytes)?;
    Ok(summary)
}

/// The defaults of `bake --clusters K --pcs M` where only one is given.
const DEFAULT_CLUSTERS: usize = 64;
const DEFAULT_PCS: usize = 4;

/// `bake --clusters K --pcs M --light-prior P --starts S`, checked before the bake: the fit
/// to run after it (None without --clusters and --pcs; either takes its default, 64 clusters
/// or 4 components, where only the other is given), K ≥ 1, M at most the n² coefficients of
/// a grey bake of `order` (the smallest D a bake of that order can have), and a prior or
/// starts only with compression.
pub fn bake_fit(
    clusters: Option<usize>,
    pcs: Option<usize>,
    prior: Option<LightPrior>,
    starts: Option<usize>,
    order: usize,
) -> Result<Option<FitOptions>> {
    if clusters.is_none() && pcs.is_none() {
        if prior.is_some() || starts.is_some() {
            return Err(Error::InvalidOption(
                "--light-prior and --starts are for compressed bakes: give --clusters or --pcs too"
                    .into(),
            ));
        }
        return Ok(None);
    }
    let options = FitOptions {
        clusters: clusters.unwrap_or(DEFAULT_CLUSTERS),
        pcs: pcs.unwrap_or(DEFAULT_PCS),
        prior: prior.unwrap_or_default(),
        starts: starts.unwrap_or(STARTS),
    };
    options.check()?;
    let n2 = order * order;
    if options.pcs > n2 {
        return Err(Error::InvalidOption(format!(
            "--pcs {} is more than the {n2} coefficients of an order-{order} bake",
            options.pcs
        )));
    }
    Ok(Some(options))
}

/// The bytes a bake writes: `file` as version 1 (its arrays borrowed), or compressed
/// (version 2) by `fit`.
pub fn bake_output<'a>(
    file: &'a CoefficientFile,
    fit: Option<&FitOptions>,
) -> Result<(Encoded<'a>, Option<Summary>)> {
    let Some(fit) = fit else {
        return Ok((file.encode().0, None));
    };
    if file.header.vertex_count == 0 {
        return Err(Error::InvalidOption("no receivers to compress".into()));
    }
    let (cpca, summary) = compress_coefficients(file, fit)?;
    let bytes = crate::formats::cpca_block::to_bytes(file, &cpca, summary.rms_error as f32);
    Ok((bytes.into(), Some(summary)))
}
