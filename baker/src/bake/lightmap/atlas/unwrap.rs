//! The default generator: the `uvunwrap` crate (pure Rust, in the spirit of xatlas): charts
//! grown within a normal cone, flattened by LSCM + ARAP (planar projection where flat),
//! split until free of flips, overlaps and strong area distortion, and packed by their
//! rasterised shapes. Built with its `direct-solver` feature: charts are flattened by faer's
//! sparse Cholesky (the faer the seam stitch uses) instead of conjugate gradients, whose
//! iterations grow with a chart's size: a 720,000-triangle terrain unwraps in 10 s instead of
//! 106 (docs/guides/lightmaps.md, "Atlas"). faer chooses its SIMD kernels at run time, so two kinds of
//! CPU may unwrap a scene in different last bits; shards on a mixed cluster share one prepared
//! lightmap (`prepare-lightmap`) rather than each unwrapping. Its `parallel` feature is kept:
//! the crate collects parallel results in input order, and our tests check that 1 and 2
//! threads give bit-identical UVs.

use glam::Vec2;

use super::placed::{PADDING, Placed};
use crate::scene::Scene;
use crate::support::error::{Error, Result};

/// uvunwrap's `padding` keeps charts `2 × padding` texels apart (and `padding` from the
/// page's edges), measured between its conservative rasterisations, which cover every texel
/// ours does; half of [`PADDING`] (rounded up) is therefore enough.
const UNWRAP_PADDING: u32 = PADDING.div_ceil(2);

/// Unwraps `scene` into a `resolution`² atlas: at `texel_size` world units per texel, or at
/// the largest density (within 0.25 %) that fits one page.
pub(super) fn generate(scene: &Scene, resolution: u32, texel_size: Option<f32>) -> Result<Placed> {
    let positions: Vec<[f32; 3]> = scene.positions.iter().map(|p| p.to_array()).collect();
    let indices: Vec<u32> = scene.triangles.iter().flatten().copied().collect();
    // One "material" per object: a chart never spans two objects that happen to share a
    // position (uvunwrap welds bit-identical positions).
    let mut object = vec![0u32; scene.triangles.len()];
    for (k, o) in scene.objects.iter().enumerate() {
        for t in o.triangles.clone() {
            object[t as usize] = k as u32;
        }
    }
    let mesh = uvunwrap::MeshInput {
        face_materials: Some(&object),
        ..uvunwrap::MeshInput::new(&positions, &indices)
    };
    let density = match texel_size {
        Some(s) => uvunwrap::Density::Fixed {
            texels_per_unit: 1.0 / s,
            page_size: Some(resolution),
        },
        None => uvunwrap::Density::Auto {
            page_size: resolution,
        },
    };
    let options = uvunwrap::Options {
        density,
        padding: UNWRAP_PADDING,
        ..uvunwrap::Options::default()
    };
    let too_small = |charts: u32| {
        Error::InvalidOption(match texel_size {
            Some(s) => format!(
                "--texel-size {s}: the scene's {charts} charts do not fit a {resolution}² \
                 lightmap; use a larger texel or --lightmap"
            ),
            None => format!(
                "the scene's {charts} charts do not fit a {resolution}² lightmap even at the \
                 smallest scale (each needs {PADDING} texels of padding): use a larger \
                 --lightmap"
            ),
        })
    };
    let atlas = match uvunwrap::generate(&[mesh], &options) {
        Ok(atlas) => atlas,
        Err(uvunwrap::Error::ChartTooLarge { .. }) => return Err(too_small(1)),
        Err(uvunwrap::Error::AtlasTooLarge { texels }) => {
            return Err(Error::InvalidOption(format!(
                "--texel-size {}: the charts would need {texels} texels; use a larger texel",
                texel_size.unwrap_or(0.0)
            )));
        }
        Err(e) => {
            return Err(Error::InvalidOption(format!(
                "the lightmap unwrap failed: {e}"
            )));
        }
    };
    if atlas.page_count > 1 {
        return Err(too_small(atlas.chart_count));
    }
    // uvunwrap's UVs are relative to its page, which it may crop below `resolution` rows.
    let page = Vec2::new(atlas.width as f32, atlas.height as f32);
    let out = &atlas.meshes[0];
    let mut placed = Placed::empty(scene.triangles.len(), atlas.chart_count as usize);
    for (t, corners) in out.indices.chunks_exact(3).enumerate() {
        let v = [0, 1, 2].map(|k| out.vertices[corners[k] as usize]);
        let Some(chart) = v[0].chart else { continue };
        let texels = v.map(|v| Vec2::from_array(v.uv) * page);
        // Degenerate triangles get no area of their own (their corners collapse onto a
        // neighbour's UV): left out, as the planar unwrapper leaves them out.
        if (texels[1] - texels[0]).perp_dot(texels[2] - texels[0]) == 0.0 {
            continue;
        }
        placed.texels[t] = Some(texels);
        placed.chart[t] = chart;
    }
    Ok(placed)
}
