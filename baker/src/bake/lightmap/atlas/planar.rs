//! The planar unwrapper (`--atlas planar`): edge-connected triangles whose face normals lie
//! within 5° of the chart's first triangle, projected onto that triangle's plane and
//! shelf-packed. Exact on flat scenes (one chart per wall), but a curved mesh becomes one
//! chart per few triangles, and their padding wastes the atlas (docs/lightmaps.md, "Atlas").

use glam::Vec2;

use super::placed::{PADDING, Placed};
use crate::scene::Scene;
use crate::support::error::{Error, Result};

/// Planar charts of `scene`, packed into a `resolution`² atlas ([`Placed`]: per triangle its
/// corners in texels and its chart).
pub(super) fn generate(scene: &Scene, resolution: u32, texel_size: Option<f32>) -> Result<Placed> {
    let charts = planar_charts(scene);
    if charts.is_empty() {
        return Err(Error::InvalidOption(
            "the scene has no triangles of positive area to put in a lightmap".into(),
        ));
    }
    let (scale, offsets) = match texel_size {
        Some(s) => pack(&charts, 1.0 / s, resolution).ok_or_else(|| {
            Error::InvalidOption(format!(
                "--texel-size {s}: the scene's {} do not fit a {resolution}² \
                 lightmap; use a larger texel or --lightmap",
                chart_count(charts.len())
            ))
        })?,
        None => fill(&charts, resolution)?,
    };
    let mut placed = Placed::empty(scene.triangles.len(), charts.len());
    for (c, (chart, offset)) in charts.iter().zip(offsets).enumerate() {
        for (&t, local) in chart.triangles.iter().zip(&chart.local) {
            placed.texels[t as usize] = Some(local.map(|p| offset + (p - chart.min) * scale));
            placed.chart[t as usize] = c as u32;
        }
    }
    Ok(placed)
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
/// triangle order, so the result is deterministic. Flat surfaces (floors, walls, boxes)
/// become one chart each; curved ones become many small charts. Zero-area triangles are
/// left out.
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
        let frame = crate::math::sampling::Frame::from_normal(normal);
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
            "the scene's {} do not fit a {resolution}² lightmap even at the smallest \
             scale (each needs {} texels of padding): use a larger --lightmap",
            chart_count(charts.len()),
            1 + PADDING
        ))
    })
}

/// "1 chart", "14 charts".
fn chart_count(n: usize) -> String {
    match n {
        1 => String::from("1 chart"),
        n => format!("{n} charts"),
    }
}
