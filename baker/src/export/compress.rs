//! `prt-bake compress` and `bake --clusters/--pcs`: a coefficient file's transfer through
//! clustered PCA ([`crate::math::cpca`]) into a version-2 file ([`crate::formats::cpca_block`]).

use std::path::Path;

use serde::Serialize;

use crate::formats::coefficient_file::CoefficientFile;
use crate::math::cpca::{Cpca, compress, rms_error};
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

/// Compresses a coefficient file in memory: the CPCA of its transfer and the error of the
/// reconstruction as it will be read back (from the stored f32 values).
pub fn compress_coefficients(
    file: &CoefficientFile,
    clusters: usize,
    pcs: usize,
) -> Result<(Cpca, Summary)> {
    let dim = file.header.coefficients_per_vertex();
    let v = file.header.vertex_count;
    // The fit's working set: the f64 scatter matrices, means and bases, per-receiver indices
    // and weights, and the reconstruction used to measure the error.
    let k = (clusters as u64).min(v);
    let (d, m) = (dim as u64, pcs as u64);
    let needed = k
        .checked_mul(d * d + (m + 2) * d)
        .and_then(|n| n.checked_mul(8))
        .and_then(|n| n.checked_add(v.checked_mul((m + 2 + d) * 8)?));
    crate::support::limits::check("compress", "clustered PCA of the transfer", needed)?;
    let cpca = compress(&file.coefficients, dim, clusters, pcs)?;
    let error = rms_error(&file.coefficients, &cpca.reconstruct());
    let summary = Summary::new(&cpca, error);
    Ok((cpca, summary))
}

/// `prt-bake compress`: reads `input` (any whole bake, vertex or texel; a compressed one is
/// read as its reconstruction), fits K clusters of M components and writes the version-2 file
/// atomically to `output`.
pub fn compress_file(input: &Path, output: &Path, clusters: usize, pcs: usize) -> Result<Summary> {
    if clusters == 0 {
        return Err(Error::InvalidOption("--clusters must be at least 1".into()));
    }
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
    let (cpca, summary) = compress_coefficients(&file, clusters, pcs)?;
    let bytes = crate::formats::cpca_block::to_bytes(&file, &cpca, summary.rms_error as f32);
    out.write(&bytes)?;
    Ok(summary)
}

/// The defaults of `bake --clusters K --pcs M` where only one is given.
const DEFAULT_CLUSTERS: usize = 64;
const DEFAULT_PCS: usize = 4;

/// `bake --clusters K --pcs M`, checked before the bake: K ≥ 1 and M at most the n²
/// coefficients of a grey bake of `order` (the smallest D a bake of that order can have).
pub fn check_bake_options(clusters: Option<usize>, pcs: Option<usize>, order: usize) -> Result<()> {
    if clusters == Some(0) {
        return Err(Error::InvalidOption("--clusters must be at least 1".into()));
    }
    let n2 = order * order;
    match pcs {
        Some(m) if m > n2 => Err(Error::InvalidOption(format!(
            "--pcs {m} is more than the {n2} coefficients of an order-{order} bake"
        ))),
        _ => Ok(()),
    }
}

/// The bytes a bake writes: `file` as version 1, or compressed (version 2) when `bake` was
/// given --clusters or --pcs (the other then takes its default, 64 clusters or 4 components).
pub fn bake_output(
    file: &CoefficientFile,
    clusters: Option<usize>,
    pcs: Option<usize>,
) -> Result<(Vec<u8>, Option<Summary>)> {
    if clusters.is_none() && pcs.is_none() {
        return Ok((file.to_bytes().0, None));
    }
    let (k, m) = (
        clusters.unwrap_or(DEFAULT_CLUSTERS),
        pcs.unwrap_or(DEFAULT_PCS),
    );
    if file.header.vertex_count == 0 {
        return Err(Error::InvalidOption("no receivers to compress".into()));
    }
    let (cpca, summary) = compress_coefficients(file, k, m)?;
    let bytes = crate::formats::cpca_block::to_bytes(file, &cpca, summary.rms_error as f32);
    Ok((bytes, Some(summary)))
}
