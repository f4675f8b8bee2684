//! The lightmap atlas: where every triangle corner lies in the W×H lightmap.
//!
//! UVs are normalised to [0, 1] and per triangle corner, not per vertex, because an unwrap
//! cuts seams: one scene vertex on a seam lies in two charts. Texel (x, y) of a W×H lightmap
//! covers uv·(W, H) ∈ [x, x+1] × [y, y+1] (no flip: row 0 is v = 0). The normalised UVs are
//! what a file stores, and the texel points are always computed from them
//! ([`Atlas::texel_corners`]), so reading a file back gives the same texels as the bake.

use glam::Vec2;

use crate::error::{Error, Result};
use crate::scene::Scene;

/// Empty texels left between charts, so bilinear filtering of one chart does not read its
/// neighbour.
pub const PADDING: u32 = 2;

/// Where the atlas came from (stored in texel files).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AtlasSource {
    /// Unwrapped here ([`Atlas::generate`]).
    Generated,
    /// The scene's own lightmap UVs (glTF TEXCOORD_1), given to [`Atlas::from_vertex_uvs`].
    SceneUvs,
}

impl AtlasSource {
    pub fn code(self) -> u32 {
        match self {
            AtlasSource::Generated => 0,
            AtlasSource::SceneUvs => 1,
        }
    }

    pub fn from_code(code: u32) -> Option<AtlasSource> {
        match code {
            0 => Some(AtlasSource::Generated),
            1 => Some(AtlasSource::SceneUvs),
            _ => None,
        }
    }
}

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
}

impl Atlas {
    /// An atlas from per-vertex lightmap UVs in [0, 1] (the scene's TEXCOORD_1, or a test's).
    /// Hook for issue 10's glTF lightmap UVs: pass them here instead of unwrapping.
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
        })
    }

    /// Unwraps the scene into a `resolution`² atlas with [`PADDING`] empty texels between
    /// charts ([`planar_charts`], shelf-packed). With `texel_size` a texel spans that world
    /// distance (an error if the charts then do not fit); without, the charts are scaled to
    /// fill the atlas.
    pub fn generate(scene: &Scene, resolution: u32, texel_size: Option<f32>) -> Result<Atlas> {
        check_resolution(resolution)?;
        if let Some(s) = texel_size {
            if !(s.is_finite() && s > 0.0) {
                return Err(Error::InvalidOption(format!(
                    "--texel-size {s} must be a positive number"
                )));
            }
        }
        let charts = planar_charts(scene);
        if charts.is_empty() {
            return Err(Error::InvalidOption(
                "the scene has no triangles of positive area to put in a lightmap".into(),
            ));
        }
        let placed = match texel_size {
            Some(s) => pack(&charts, 1.0 / s, resolution).ok_or_else(|| {
                Error::InvalidOption(format!(
                    "--texel-size {s}: the scene's {} charts do not fit a {resolution}² \
                     lightmap; use a larger texel or --lightmap",
                    charts.len()
                ))
            })?,
            None => fill(&charts, resolution)?,
        };
        let mut uv1 = vec![[Vec2::splat(-1.0); 3]; scene.triangles.len()];
        let (scale, offsets) = placed;
        for (chart, offset) in charts.iter().zip(offsets) {
            for (&t, local) in chart.triangles.iter().zip(&chart.local) {
                uv1[t as usize] =
                    local.map(|p| (offset + (p - chart.min) * scale) / resolution as f32);
            }
        }
        Ok(Atlas {
            width: resolution,
            height: resolution,
            uv1,
            source: AtlasSource::Generated,
            texel_size,
        })
    }

    /// Per triangle, its corners in texel units (uv · (W, H)).
    pub fn texel_corners(&self) -> impl Iterator<Item = [Vec2; 3]> + '_ {
        let size = Vec2::new(self.width as f32, self.height as f32);
        self.uv1.iter().map(move |c| c.map(|p| p * size))
    }
}

/// The largest lightmap side accepted: 16,384 texels (268 M texels).
pub const MAX_RESOLUTION: u32 = 16_384;

fn check_resolution(r: u32) -> Result<()> {
    if (1..=MAX_RESOLUTION).contains(&r) {
        Ok(())
    } else {
        Err(Error::InvalidOption(format!(
            "--lightmap {r} is outside 1..={MAX_RESOLUTION}"
        )))
    }
}

/// Charts meet across an edge when their face normals differ by less than this (cos 5°).
const CHART_COS: f32 = 0.996_194_7;

/// A set of edge-connected triangles whose face normals lie within 5° of the first one's,
/// flattened by orthogonal projection onto that triangle's plane (world units).
#[derive(Clone, Debug)]
pub struct Chart {
    pub triangles: Vec<u32>,
    /// Per triangle, its corners projected onto the chart's plane.
    pub local: Vec<[Vec2; 3]>,
    pub min: Vec2,
    pub max: Vec2,
}

/// Splits the scene into planar charts: flood fill over shared edges (by vertex index) in
/// triangle order, so the result is deterministic. A simple unwrapper: flat surfaces (floors,
/// walls, boxes) become one chart each; curved ones become many small charts, which cost
/// atlas space in padding. Zero-area triangles are left out.
///
/// (xatlas was the plan; the crate `xatlas-rs` 0.1.3 links only on Windows: its bindings
/// name MSVC-mangled symbols. docs/lightmaps.md.)
pub fn planar_charts(scene: &Scene) -> Vec<Chart> {
    let face: Vec<Option<glam::Vec3>> = scene
        .triangles
        .iter()
        .map(|t| {
            let p = t.map(|v| scene.positions[v as usize]);
            (p[1] - p[0]).cross(p[2] - p[0]).try_normalize()
        })
        .collect();
    let mut edge_faces: std::collections::HashMap<(u32, u32), Vec<u32>> = Default::default();
    for (t, tri) in scene.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            edge_faces
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push(t as u32);
        }
    }
    let mut assigned = vec![false; scene.triangles.len()];
    let mut charts = Vec::new();
    for seed in 0..scene.triangles.len() {
        let Some(normal) = face[seed] else { continue };
        if assigned[seed] {
            continue;
        }
        let frame = crate::sampling::Frame::from_normal(normal);
        let mut chart = Chart {
            triangles: Vec::new(),
            local: Vec::new(),
            min: Vec2::splat(f32::INFINITY),
            max: Vec2::splat(f32::NEG_INFINITY),
        };
        assigned[seed] = true;
        let mut stack = vec![seed as u32];
        while let Some(t) = stack.pop() {
            let tri = scene.triangles[t as usize];
            let local = tri.map(|v| {
                let p = scene.positions[v as usize];
                Vec2::new(p.dot(frame.tangent), p.dot(frame.bitangent))
            });
            for p in local {
                chart.min = chart.min.min(p);
                chart.max = chart.max.max(p);
            }
            chart.triangles.push(t);
            chart.local.push(local);
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                for &n in &edge_faces[&(a.min(b), a.max(b))] {
                    let joins = face[n as usize].is_some_and(|f| f.dot(normal) >= CHART_COS);
                    if !assigned[n as usize] && joins {
                        assigned[n as usize] = true;
                        stack.push(n);
                    }
                }
            }
        }
        charts.push(chart);
    }
    charts
}

/// Shelf-packs the charts at `scale` texels per world unit into a `resolution`² atlas:
/// each chart's rectangle is its extent, one texel for conservative rasterisation, and
/// [`PADDING`]. Returns the scale and each chart's offset in texels, or `None` if they do
/// not fit.
fn pack(charts: &[Chart], scale: f32, resolution: u32) -> Option<(f32, Vec<Vec2>)> {
    let size = |c: &Chart| ((c.max - c.min) * scale).ceil() + Vec2::splat(1.0 + PADDING as f32);
    let mut order: Vec<usize> = (0..charts.len()).collect();
    // Tallest first, ties in chart order: deterministic.
    order.sort_by(|&a, &b| {
        size(&charts[b])
            .y
            .total_cmp(&size(&charts[a]).y)
            .then(a.cmp(&b))
    });
    let r = resolution as f32;
    let mut offsets = vec![Vec2::ZERO; charts.len()];
    let (mut x, mut y, mut shelf) = (0.0f32, 0.0f32, 0.0f32);
    for i in order {
        let s = size(&charts[i]);
        if s.x > r {
            return None;
        }
        if x + s.x > r {
            (x, y, shelf) = (0.0, y + shelf, 0.0);
        }
        if y + s.y > r {
            return None;
        }
        // Half a texel in from the rectangle's corner: the chart stays clear of its
        // rectangle's edge texels, which belong to the padding.
        offsets[i] = Vec2::new(x, y) + Vec2::splat(0.5);
        x += s.x;
        shelf = shelf.max(s.y);
    }
    Some((scale, offsets))
}

/// The largest scale (within 2 %) at which the charts fit, found by bisection.
fn fill(charts: &[Chart], resolution: u32) -> Result<(f32, Vec<Vec2>)> {
    let area: f32 = charts
        .iter()
        .map(|c| (c.max - c.min).x.max(1e-30) * (c.max - c.min).y.max(1e-30))
        .sum();
    // No chart set fits above the scale at which their boxes alone cover the atlas.
    let mut hi = resolution as f32 / area.sqrt();
    let mut lo = 0.0f32;
    let mut best = None;
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        match pack(charts, mid, resolution) {
            Some(p) => {
                lo = mid;
                best = Some(p);
            }
            None => hi = mid,
        }
        if best.is_some() && hi - lo <= 0.02 * lo {
            break;
        }
    }
    best.ok_or_else(|| {
        Error::InvalidOption(format!(
            "the scene's {} charts do not fit a {resolution}² lightmap even at the smallest \
             scale (each needs {} texels of padding): use a larger --lightmap",
            charts.len(),
            1 + PADDING
        ))
    })
}
