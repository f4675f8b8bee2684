//! A CPCA-compressed bake (a version-2 `.prt`, `prt-bake compress`) in a `.glb`, in the form
//! Sloan et al. 2003 render it: per vertex its cluster index (`_PRT_CLUSTER`) and its M
//! weights (`_PRT_W0`, … VEC4s), and per cluster the mean and M principal components as two
//! float arrays of the file's buffer, named by `asset.extras.prt.cpca`. Per frame a runtime
//! dots the light into each cluster's M + 1 vectors once, and each vertex combines M + 1 of
//! those values: the transfer of an RGB order-4 bake, 12 VEC4 attributes as floats, takes
//! 2 attributes at M = 4, which leaves WebGL's 16 room for tangents and a second UV set.

use serde_json::{Value, json};

use std::path::Path;

use super::builder::Builder;
use crate::formats::coefficient_file::CoefficientFile;
use crate::formats::cpca_block;
use crate::math::cpca::Cpca;
use crate::math::sh::{self, rotation::ShRotation};
use crate::support::error::{Error, Result};

/// Name of the per-vertex cluster index attribute (SCALAR float, an exact integer).
pub const CLUSTER_ATTRIBUTE: &str = "_PRT_CLUSTER";

/// The per-vertex and per-cluster arrays of a compressed bake, turned to glTF's frame.
pub(super) struct CompressedTransfer {
    /// `_PRT_W0`, …: ⌈M/4⌉ VEC4 attribute names.
    pub names: Vec<String>,
    /// Per attribute, VEC4s over all vertices (weights beyond M are 0).
    pub weights: Vec<Vec<f32>>,
    /// Per vertex, its cluster index as a float.
    pub cluster: Vec<f32>,
    /// K × D means, each channel's n² coefficients turned to the file's frame.
    means: Vec<f32>,
    /// K × M × D components, turned likewise.
    bases: Vec<f32>,
    clusters: usize,
    pcs: usize,
    dim: usize,
    order: usize,
    channels: usize,
    matrix: bool,
}

/// `cpca`'s arrays for a `.glb` whose SH coefficients are turned by `turn` (None: unturned).
/// The SH rotation is linear, so turning the means and components turns every reconstructed
/// vector (or, for a `matrix` bake, matrix: R·M·Rᵀ), and the weights stay as they are.
pub(super) fn compressed_transfer(
    cpca: &Cpca,
    order: usize,
    channels: usize,
    turn: Option<&ShRotation>,
    matrix: bool,
) -> CompressedTransfer {
    let n2 = sh::coeff_count(order);
    let turned = |vectors: &[f32]| -> Vec<f32> {
        let Some(rotation) = turn else {
            return vectors.to_vec();
        };
        if matrix {
            return super::glossy::turned_matrices(vectors, rotation);
        }
        vectors
            .chunks_exact(n2)
            .flat_map(|c| {
                let c: Vec<f64> = c.iter().map(|&x| f64::from(x)).collect();
                rotation.rotate(&c).into_iter().map(|x| x as f32)
            })
            .collect()
    };
    let (m, count) = (cpca.pcs, cpca.receivers());
    let names: Vec<String> = (0..m.div_ceil(4)).map(|k| format!("_PRT_W{k}")).collect();
    let mut weights = vec![vec![0.0f32; 4 * count]; names.len()];
    for v in 0..count {
        for i in 0..m {
            weights[i / 4][4 * v + i % 4] = cpca.weights[v * m + i];
        }
    }
    CompressedTransfer {
        names,
        weights,
        cluster: cpca.cluster.iter().map(|&k| k as f32).collect(),
        means: turned(&cpca.means),
        bases: turned(&cpca.bases),
        clusters: cpca.clusters(),
        pcs: m,
        dim: cpca.dim,
        order,
        channels,
        matrix,
    }
}

impl CompressedTransfer {
    /// Writes the means and components into the buffer and returns `asset.extras.prt.cpca`.
    pub(super) fn write_clusters(&self, b: &mut Builder) -> Value {
        let mut json = json!({
            "clusters": self.clusters,
            "pcs": self.pcs,
            "dim": self.dim,
            "order": self.order,
            "channels": self.channels,
            "means": b.data_floats(&self.means),
            "bases": b.data_floats(&self.bases),
            "cluster_attribute": CLUSTER_ATTRIBUTE,
            "weight_attributes": self.names,
            "layout": "means: accessor of K x D floats, cluster k's mean at k*D; bases: K x M x D, \
                cluster k's component i at (k*M + i)*D; D = channels x n^2, channel-major (channel \
                c's coefficient j at c*n^2 + j), in this file's frame",
            "reconstruct": "transfer(v) = means[k] + sum over i < M of w_i * bases[k, i], with \
                k = _PRT_CLUSTER and w_i component i % 4 of _PRT_W(i / 4)",
            "render": "per frame and cluster, dot the light into the mean and each component \
                (per channel); per vertex, shading_c = s[k, 0]_c + sum_i w_i * s[k, 1 + i]_c",
        });
        if self.matrix {
            let extra = super::glossy::cpca_extras(self.order);
            for (key, value) in extra.as_object().into_iter().flatten() {
                json[key] = value.clone();
            }
        }
        json
    }
}

/// The file at `path` and, if it is CPCA-compressed (version 2), its clusters: the file is
/// the reconstruction either way, and the clusters are what a compressed `.glb` carries.
pub(super) fn read_maybe_compressed(path: &Path) -> Result<(CoefficientFile, Option<Cpca>)> {
    let bytes = crate::support::limits::read_file(path)?;
    let parsed = if cpca_block::is_compressed(&bytes) {
        cpca_block::from_bytes(&bytes).map(|c| (c.file, Some(c.cpca)))
    } else {
        CoefficientFile::from_bytes(&bytes).map(|file| (file, None))
    };
    parsed.map_err(|message| Error::coefficient_file(path, message))
}
