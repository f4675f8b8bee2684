//! The lightmap atlas: where every triangle corner lies in the W×H lightmap.
//!
//! UVs are normalised to [0, 1] and per triangle corner, not per vertex, because an unwrap
//! cuts seams: one scene vertex on a seam lies in two charts. Texel (x, y) of a W×H lightmap
//! covers uv·(W, H) ∈ [x, x+1] × [y, y+1] (no flip: row 0 is v = 0). The normalised UVs are
//! what a file stores, and the texel points are always computed from them
//! ([`Atlas::texel_corners`]), so reading a file back gives the same texels as the bake.
//!
//! Generated atlases come from one of two unwrappers ([`AtlasMethod`]):
//! * [`unwrap`] (the default): the `uvunwrap` crate (pure Rust, xatlas-like): charts grown
//!   within a normal cone, flattened by LSCM + ARAP, packed by their shapes. The torus demo
//!   at 512² becomes 19 charts covering 84 % of the texels (the planar unwrapper: 101
//!   charts, 48 %); the Cornell room 14 charts, 87 % (planar: 14, 58 %).
//! * [`planar`] (`--atlas planar`): charts within a 30° cone, projected and shelf-packed.
//!   Kept because it is exact on flat surfaces, instant (0.02 s on the torus) and
//!   independent of the crate, so the atlas tests check two paths.
//!
//! Both keep [`PADDING`] empty texels between charts, are deterministic (bit-identical UVs
//! for any thread count) and honour `--texel-size`; `tests/lightmap_atlas.rs` checks all
//! of it. (xatlas itself was the plan; the crate `xatlas-rs` 0.1.3 links only on Windows:
//! its bindings name MSVC-mangled symbols. docs/guides/lightmaps.md, "Atlas".)

mod chart_overlap;
mod placed;
mod planar;
mod unwrap;

pub use placed::PADDING;
pub use planar::{Chart, planar_charts};

use glam::Vec2;

pub use crate::formats::header::{AtlasSource, ObjectPlacement, ObjectUvs};

use crate::formats::coefficient_file::LightmapBlock;
use crate::scene::Scene;
use crate::support::error::{Error, Result};

/// A lightmap parameterisation of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Atlas {
    pub width: u32,
    pub height: u32,
    /// Per triangle (the scene's order), its three corners' lightmap UVs in [0, 1];
    /// (−1, −1) at every corner of a triangle left out of the atlas.
    pub uv1: Vec<[Vec2; 3]>,
    pub source: AtlasSource,
    /// World size of a texel asked for (`--texel-size`); `None`: the charts fill the atlas.
    pub texel_size: Option<f32>,
    /// [`AtlasSource::PerObject`] only: per scene object, where its own UVs went
    /// ([`super::objects`]); empty otherwise.
    pub objects: Vec<ObjectPlacement>,
}

impl Atlas {
    /// The atlas a baked file's lightmap block stores, as the bake that wrote it had it.
    pub fn of_block(block: &LightmapBlock) -> Atlas {
        Atlas {
            width: block.width,
            height: block.height,
            uv1: block.uv1.clone(),
            source: block.source,
            texel_size: (block.texel_size > 0.0).then_some(block.texel_size),
            objects: block.objects.clone(),
        }
    }

    /// An atlas from per-vertex lightmap UVs in [0, 1] (the scene's TEXCOORD_1, or a test's).
    /// The glTF loader's lightmap UVs come here instead of being unwrapped.
    pub fn from_vertex_uvs(scene: &Scene, uvs: &[Vec2], width: u32, height: u32) -> Result<Atlas> {
        check_resolution(width)?;
        check_resolution(height)?;
        if uvs.len() != scene.vertex_count() {
            return Err(Error::InvalidOption(format!(
                "{} lightmap UVs for {} vertices",
                uvs.len(),
                scene.vertex_count()
            )));
        }
        Ok(Atlas {
            width,
            height,
            uv1: scene
                .triangles
                .iter()
                .map(|t| t.map(|v| uvs[v as usize]))
                .collect(),
            source: AtlasSource::SceneUvs,
            texel_size: None,
            objects: Vec::new(),
        })
    }

    /// Unwraps the scene into a `resolution`² atlas with [`PADDING`] empty texels between
    /// charts, with the default unwrapper ([`AtlasMethod::Unwrap`]). With `texel_size` a
    /// texel spans that world distance (an error if the charts then do not fit); without,
    /// the charts are scaled to fill the atlas.
    pub fn generate(scene: &Scene, resolution: u32, texel_size: Option<f32>) -> Result<Atlas> {
        Ok(generate(scene, resolution, texel_size, AtlasMethod::default())?.atlas)
    }

    /// Per triangle, its corners in texel units (uv · (W, H)).
    pub fn texel_corners(&self) -> impl Iterator<Item = [Vec2; 3]> + '_ {
        let size = Vec2::new(self.width as f32, self.height as f32);
        self.uv1.iter().map(move |c| c.map(|p| p * size))
    }
}

/// Which unwrapper makes a generated atlas (`bake --atlas`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AtlasMethod {
    /// The `uvunwrap` crate: curved surfaces in few large charts ([`unwrap`]).
    #[default]
    Unwrap,
    /// Planar charts, shelf-packed ([`planar`]).
    Planar,
}

impl AtlasMethod {
    pub fn name(self) -> &'static str {
        match self {
            AtlasMethod::Unwrap => "unwrap",
            AtlasMethod::Planar => "planar",
        }
    }
}

/// A generated atlas with its charts, for reports and tests.
#[derive(Clone, Debug)]
pub struct Generated {
    pub atlas: Atlas,
    /// Per triangle, its chart (`u32::MAX` for a triangle left out).
    pub chart: Vec<u32>,
    pub chart_count: usize,
}

impl Generated {
    /// A warning where the planar unwrapper shattered the scene: charts of a few triangles
    /// each (a rough heightfield in 5° charts: 233,508 for 720,000 triangles) leave most of the
    /// lightmap as padding and make nearly every texel a seam texel, whose stitching then
    /// costs as much as the rays (docs/guides/lightmaps.md, "Atlas"). `None` for a sound atlas.
    pub fn fragmentation_note(&self, method: AtlasMethod, triangles: usize) -> Option<String> {
        let shattered = method == AtlasMethod::Planar
            && self.chart_count >= FRAGMENTED_CHARTS
            && self.chart_count * FRAGMENTED_TRIANGLES_PER_CHART > triangles;
        shattered.then(|| {
            format!(
                "warning: the planar atlas cut {triangles} triangles into {} charts ({:.1} \
                 triangles a chart): most texels lie at chart edges, as padding or seams to \
                 stitch; --atlas unwrap (the default) makes few large charts of curved surfaces",
                self.chart_count,
                triangles as f64 / self.chart_count as f64
            )
        })
    }
}

/// [`Generated::fragmentation_note`] warns from this many charts (small scenes stay quiet)…
const FRAGMENTED_CHARTS: usize = 1_000;
/// …when they average fewer triangles than this.
const FRAGMENTED_TRIANGLES_PER_CHART: usize = 8;

/// Unwraps `scene` with `method` into a `resolution`² atlas ([`Atlas::generate`]).
pub fn generate(
    scene: &Scene,
    resolution: u32,
    texel_size: Option<f32>,
    method: AtlasMethod,
) -> Result<Generated> {
    check_resolution(resolution)?;
    if let Some(s) = texel_size {
        if !(s.is_finite() && s > 0.0) {
            return Err(Error::InvalidOption(format!(
                "--texel-size {s} must be a positive number"
            )));
        }
    }
    if !scene.triangles.iter().any(|t| {
        let p = t.map(|v| scene.positions[v as usize]);
        (p[1] - p[0]).cross(p[2] - p[0]).length_squared() > 0.0
    }) {
        return Err(Error::InvalidOption(
            "the scene has no triangles of positive area to put in a lightmap".into(),
        ));
    }
    let placed = match method {
        AtlasMethod::Unwrap => unwrap::generate(scene, resolution, texel_size)?,
        AtlasMethod::Planar => planar::generate(scene, resolution, texel_size)?,
    };
    let r = resolution as f32;
    let uv1 = placed
        .texels
        .iter()
        .map(|t| match t {
            // Clamped against rounding: the unwrappers keep charts inside the atlas.
            Some(c) => c.map(|p| (p / r).clamp(Vec2::ZERO, Vec2::ONE)),
            None => [Vec2::splat(-1.0); 3],
        })
        .collect();
    Ok(Generated {
        atlas: Atlas {
            width: resolution,
            height: resolution,
            uv1,
            source: AtlasSource::Generated,
            texel_size,
            objects: Vec::new(),
        },
        chart: placed.chart,
        chart_count: placed.chart_count,
    })
}

/// The largest lightmap side accepted: 16,384 texels (268 M texels).
pub const MAX_RESOLUTION: u32 = 16_384;
/// The smallest lightmap: a chart with its padding on both sides needs more than 2 × 2
/// texels (below it the unwrapper refuses with a message of its own).
pub const MIN_RESOLUTION: u32 = 8;

/// Refuses a `--lightmap` resolution outside [`MIN_RESOLUTION`]..=[`MAX_RESOLUTION`]: a
/// usage error, checked before the scene is read or its memory estimated.
pub fn check_resolution(r: u32) -> Result<()> {
    if (MIN_RESOLUTION..=MAX_RESOLUTION).contains(&r) {
        Ok(())
    } else {
        Err(Error::InvalidOption(format!(
            "--lightmap {r} is outside {MIN_RESOLUTION}..={MAX_RESOLUTION}"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn generated(chart_count: usize) -> Generated {
        let atlas = Atlas {
            width: 8,
            height: 8,
            uv1: Vec::new(),
            source: AtlasSource::Generated,
            texel_size: None,
            objects: Vec::new(),
        };
        Generated {
            atlas,
            chart: Vec::new(),
            chart_count,
        }
    }

    #[test]
    fn a_shattered_planar_atlas_is_warned_of_and_a_sound_one_is_not() {
        // The heightfield: 233,508 planar charts for 720,000 triangles.
        let note = generated(233_508).fragmentation_note(AtlasMethod::Planar, 720_000);
        assert!(note.is_some_and(|n| n.contains("233508 charts") && n.contains("3.1 triangles")));
        // The same counts from uvunwrap, few charts, or charts of many triangles: quiet.
        assert_eq!(
            generated(233_508).fragmentation_note(AtlasMethod::Unwrap, 720_000),
            None
        );
        assert_eq!(
            generated(999).fragmentation_note(AtlasMethod::Planar, 2_000),
            None
        );
        assert_eq!(
            generated(2_210).fragmentation_note(AtlasMethod::Planar, 26_228),
            None
        );
    }
}
