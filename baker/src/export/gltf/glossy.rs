//! A transfer-matrix bake (glossy PRT, docs/guides/glossy.md) in a `.glb`: only CPCA-compressed,
//! as Sloan et al. 2003 render it. An order-n matrix is n⁴ floats per vertex and channel
//! (64 VEC4 attributes at order 4), far beyond any engine's attribute budget, while its CPCA
//! form is a cluster index and M weights per vertex, like a compressed vector bake's; the
//! clusters' means and components are n² × n² matrices instead of n² vectors.
//!
//! What a runtime needs beside the transfer is each material's glossy lobe: its exponent,
//! the reflectance `ks`, the diffuse weight, and the lobe's band factors ĝ_l(s) at the
//! file's order (so a runtime needs no Legendre integrals), in the material's
//! `extras.prt_glossy`.

use glam::Vec3;
use serde_json::{Value, json};

use crate::formats::coefficient_file::{CoefficientFile, Header};
use crate::formats::header::TransferKind;
use crate::light::LightCoefficients;
use crate::math::cpca::Cpca;
use crate::math::glossy::lobe_bands;
use crate::math::sh::rotation::ShRotation;
use crate::scene::{Material, Scene};
use crate::support::error::{Error, Result};
use std::path::Path;

/// Refuses an uncompressed matrix bake, which has no form a `.glb` can carry.
pub(super) fn check_compressed(
    file: &CoefficientFile,
    path: &Path,
    cpca: Option<&Cpca>,
) -> Result<()> {
    if cpca.is_some() {
        return Ok(());
    }
    let n2 = crate::math::sh::coeff_count(file.header.order as usize);
    Err(Error::SceneMismatch {
        path: path.to_path_buf(),
        message: format!(
            "an uncompressed transfer-matrix bake ({} floats per vertex and channel, {} VEC4 \
             attributes: more than any engine binds); compress it first, e.g. `prt-bake \
             compress {} -o C.prt --clusters 64 --pcs 4`, and export that (docs/reference/gltf.md, \
             \"Glossy transfer\")",
            n2 * n2,
            (n2 * n2).div_ceil(4),
            path.display()
        ),
    })
}

/// The n² × n² row-major matrices in `values` (one after another), each turned into the
/// frame `rotation` turns directions into: M′ = R·M·Rᵀ, since the incident radiance R·M·L
/// must answer the turned light R·L.
pub(super) fn turned_matrices(values: &[f32], rotation: &ShRotation) -> Vec<f32> {
    let n2 = crate::math::sh::coeff_count(rotation.order());
    let mut out = Vec::with_capacity(values.len());
    for m in values.chunks_exact(n2 * n2) {
        // A = R·M, column by column.
        let mut a = vec![0.0f64; n2 * n2];
        for j in 0..n2 {
            let column: Vec<f64> = (0..n2).map(|i| f64::from(m[i * n2 + j])).collect();
            for (i, x) in rotation.rotate(&column).into_iter().enumerate() {
                a[i * n2 + j] = x;
            }
        }
        // M′ = A·Rᵀ: row i of it is R times row i of A.
        for row in a.chunks_exact(n2) {
            out.extend(rotation.rotate(row).into_iter().map(|x| x as f32));
        }
    }
    out
}

/// COLOR_0 of a matrix bake: the diffuse render with albedo 1 (`relight` without `--view`,
/// the glossy layers left out): times the base colour it is the diffuse radiance.
pub(super) fn diffuse_colour(
    file: &CoefficientFile,
    cpca: Option<&Cpca>,
    scene: &Scene,
    light: &LightCoefficients,
) -> Vec<f32> {
    let ones = vec![Vec3::ONE; scene.vertex_count()];
    let receivers = crate::export::relight_glossy::Receivers::of_scene(scene, &ones);
    crate::export::relight_glossy::matrix_vertex_radiance(file, cpca, &receivers, light, None)
        .iter()
        .flat_map(|rgb| rgb.map(|x| x.clamp(0.0, 1.0)))
        .collect()
}

/// Each glossy material's `extras.prt_glossy`, where the bake is a matrix bake (a vector
/// bake cannot render the lobe, so its export says nothing of it).
pub(super) fn add_material_extras(materials: &mut [Value], scene: &Scene, header: &Header) {
    if header.transfer != TransferKind::Matrix {
        return;
    }
    for (json, m) in materials.iter_mut().zip(&scene.materials) {
        if let Some(extras) = material_extras(m, header.order as usize) {
            json["extras"]["prt_glossy"] = extras;
        }
    }
}

/// A glossy material's `extras.prt_glossy` at SH `order`; None for a diffuse material.
fn material_extras(m: &Material, order: usize) -> Option<Value> {
    let g = m.glossy?;
    Some(json!({
        "exponent": g.exponent,
        "ks": g.ks.to_array(),
        "diffuse_weight": g.diffuse_weight,
        "bands": lobe_bands(g.exponent, order),
    }))
}

/// `asset.extras.prt.cpca`'s additions for a matrix bake: the diffuse band factors and how
/// to render.
pub(super) fn cpca_extras(order: usize) -> Value {
    json!({
        "transfer": "matrix",
        "diffuse_bands": lobe_bands(1.0, order),
        "layout_matrix": "each n^2 block of D is a row-major n^2 x n^2 matrix M (channel c's at \
            c*n^4); the incident radiance is L' = M L, in this file's frame",
        "render_glossy": "per frame and cluster, project the light through the mean and each \
            component (per channel, n^2 values each); per vertex, L'_c = P[k, 0]_c + sum_i w_i \
            P[k, 1 + i]_c, and radiance_c = albedo_c * w * sum_lm diffuse_bands[l] L'_lm \
            y_lm(n) + ks_c * sum_lm bands[l] L'_lm y_lm(r), r the mirror direction of the unit \
            vector to the eye about the normal n; w, ks and bands from the material's \
            extras.prt_glossy (w = 1 and no second term without it)",
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DMat3;

    /// Turning the matrix and the light together turns the incident radiance: R·M·L
    /// = M′·(R·L).
    #[test]
    fn a_turned_matrix_answers_the_turned_light() {
        let order = 3;
        let n2 = 9;
        let m: Vec<f32> = (0..n2 * n2)
            .map(|i| ((i * 37 % 17) as f32 - 8.0) / 10.0)
            .collect();
        let light: Vec<f64> = (0..n2).map(|i| (i as f64 * 0.3).sin()).collect();
        let turn =
            DMat3::from_rotation_x(-std::f64::consts::FRAC_PI_2) * DMat3::from_rotation_z(0.4);
        let rotation = ShRotation::from_matrix(order, turn);
        let turned = turned_matrices(&m, &rotation);
        let product = |m: &[f32], l: &[f64]| -> Vec<f64> {
            (0..n2)
                .map(|i| (0..n2).map(|j| f64::from(m[i * n2 + j]) * l[j]).sum())
                .collect()
        };
        let expected = rotation.rotate(&product(&m, &light));
        let got = product(&turned, &rotation.rotate(&light));
        for (a, b) in expected.iter().zip(&got) {
            assert!((a - b).abs() < 1e-5, "{a} against {b}");
        }
    }
}
