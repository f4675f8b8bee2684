//! The planar unwrapper (`--atlas planar`): edge-connected triangles whose face normals lie
//! within 30° of the chart's first triangle, projected onto that triangle's plane (scaled
//! back to their surface's area) and shelf-packed. Exact on flat scenes (one chart per
//! wall); a curved mesh becomes many charts, and their padding wastes the atlas
//! (docs/guides/lightmaps.md, "Atlas").

use glam::Vec2;
use rayon::prelude::*;

use super::chart_overlap;
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

/// Charts grow over an edge to a triangle whose face normal lies within 30° of the chart's
/// first triangle's (cos 30°). Projected onto that plane, a triangle tilted by θ is shortened
/// by cos θ across its slope (at most 13 %), and the chart is scaled back to its surface's
/// area ([`Chart::local`]). Flat surfaces stay exact, one chart each; a smooth terrain
/// becomes charts of hundreds of triangles instead of the one to three of a 5° cone, whose
/// padding and seams cost more than their texels (a rough heightfield: 233,508
/// charts for 720,000 triangles).
const CHART_COS: f32 = 0.866_025_4;

/// A set of edge-connected triangles whose face normals lie within 30° of the first one's,
/// flattened by orthogonal projection onto that triangle's plane (world units), whose
/// projected triangles do not overlap.
#[derive(Clone, Debug)]
pub struct Chart {
    pub triangles: Vec<u32>,
    /// Per triangle, its corners projected onto the chart's plane, scaled by √(surface area
    /// / projected area) so that a texel covers the same surface area on a tilted chart as
    /// on a flat one (`--texel-size`); a flat chart keeps its exact projection.
    pub local: Vec<[Vec2; 3]>,
    pub min: Vec2,
    pub max: Vec2,
}

/// Splits the scene into planar charts: flood fill over shared edges (by vertex index) in
/// triangle order, so the result is deterministic. Flat surfaces (floors, walls, boxes)
/// become one chart each; curved ones become charts within the cone of [`CHART_COS`]. A chart
/// whose projection overlaps itself (a surface that winds round) is grown again, each
/// triangle joining only where it overlaps none already in. Zero-area triangles are left out.
pub fn planar_charts(scene: &Scene) -> Vec<Chart> {
    let face: Vec<Option<glam::Vec3>> = scene
        .triangles
        .par_iter()
        .map(|t| {
            let p = t.map(|v| scene.positions[v as usize]);
            (p[1] - p[0]).cross(p[2] - p[0]).try_normalize()
        })
        .collect();
    let edges = EdgeFaces::new(&scene.triangles);
    let mut grower = Grower {
        scene,
        face: &face,
        edges: &edges,
        assigned: vec![false; scene.triangles.len()],
    };
    let mut charts = Vec::new();
    for (seed, normal) in face.iter().enumerate() {
        if normal.is_none() || grower.assigned[seed] {
            continue;
        }
        let mut chart = grower.grow(seed, None);
        if chart_overlap::overlaps_itself(&chart.local) {
            for &t in &chart.triangles {
                grower.assigned[t as usize] = false;
            }
            let admission = chart_overlap::Admission::new(&chart.local);
            chart = grower.grow(seed, Some(admission));
        }
        charts.push(chart.scaled_to_its_area(scene));
    }
    charts
}

/// The flood fill of [`planar_charts`], over the triangles not yet in a chart.
struct Grower<'a> {
    scene: &'a Scene,
    face: &'a [Option<glam::Vec3>],
    edges: &'a EdgeFaces,
    assigned: Vec<bool>,
}

impl Grower<'_> {
    /// The chart grown from `seed`; with an [`chart_overlap::Admission`], a triangle whose
    /// projection would overlap the chart's stays out (for a later chart).
    fn grow(&mut self, seed: usize, mut admission: Option<chart_overlap::Admission>) -> Chart {
        let normal = self.face[seed].expect("seeds have a normal");
        let frame = crate::math::sampling::Frame::from_normal(normal);
        let mut chart = Chart {
            triangles: Vec::new(),
            local: Vec::new(),
            min: Vec2::splat(f32::INFINITY),
            max: Vec2::splat(f32::NEG_INFINITY),
        };
        self.assigned[seed] = true;
        let mut stack = vec![seed as u32];
        while let Some(t) = stack.pop() {
            let tri = self.scene.triangles[t as usize];
            let local = tri.map(|v| {
                let p = self.scene.positions[v as usize];
                Vec2::new(p.dot(frame.tangent), p.dot(frame.bitangent))
            });
            if admission.as_mut().is_some_and(|a| !a.admit(local)) {
                self.assigned[t as usize] = false;
                continue;
            }
            for p in local {
                chart.min = chart.min.min(p);
                chart.max = chart.max.max(p);
            }
            chart.triangles.push(t);
            chart.local.push(local);
            for k in 0..3 {
                for n in self.edges.faces(t as usize * 3 + k) {
                    let joins = self.face[n as usize].is_some_and(|f| f.dot(normal) >= CHART_COS);
                    if !self.assigned[n as usize] && joins {
                        self.assigned[n as usize] = true;
                        stack.push(n);
                    }
                }
            }
        }
        chart
    }
}

impl Chart {
    /// The chart scaled by √(surface area / projected area), where they differ by more than
    /// rounding: a tilted triangle's projection is smaller than its surface.
    fn scaled_to_its_area(mut self, scene: &Scene) -> Chart {
        let (mut surface, mut projected) = (0.0f64, 0.0f64);
        for (&t, local) in self.triangles.iter().zip(&self.local) {
            let p = scene.triangles[t as usize].map(|v| scene.positions[v as usize]);
            surface += f64::from((p[1] - p[0]).cross(p[2] - p[0]).length());
            projected += f64::from((local[1] - local[0]).perp_dot(local[2] - local[0]).abs());
        }
        let ratio = surface / projected.max(f64::MIN_POSITIVE);
        if ratio.is_finite() && ratio > 1.0 + 1e-4 {
            let s = ratio.sqrt() as f32;
            self.local.iter_mut().flatten().for_each(|p| *p *= s);
            (self.min, self.max) = (self.min * s, self.max * s);
        }
        self
    }
}

/// The triangles at each edge (by vertex index), in triangle order: a sorted list of every
/// triangle's edges rather than a hash map, which cost most of the atlas on a
/// large mesh. Grouping by the sorted key keeps the order of a map filled in triangle order.
struct EdgeFaces {
    /// Every (edge key, triangle · 3 + edge), sorted: the uses of one edge lie together, in
    /// triangle order.
    uses: Vec<(u64, u32)>,
    /// Per triangle · 3 + edge, where its edge's uses start in `uses`.
    start: Vec<u32>,
    /// Per triangle · 3 + edge, where its edge's uses end in `uses`.
    end: Vec<u32>,
}

impl EdgeFaces {
    fn new(triangles: &[[u32; 3]]) -> EdgeFaces {
        let mut uses: Vec<(u64, u32)> = triangles
            .par_iter()
            .enumerate()
            .flat_map_iter(|(t, tri)| {
                (0..3).map(move |k| {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
                    (key, (t * 3 + k) as u32)
                })
            })
            .collect();
        uses.par_sort_unstable();
        let (mut start, mut end) = (vec![0u32; uses.len()], vec![0u32; uses.len()]);
        let mut first = 0u32;
        for group in uses.chunk_by(|a, b| a.0 == b.0) {
            let last = first + group.len() as u32;
            for &(_, e) in group {
                (start[e as usize], end[e as usize]) = (first, last);
            }
            first = last;
        }
        EdgeFaces { uses, start, end }
    }

    /// The triangles at edge `e` (triangle · 3 + edge), in triangle order, a triangle
    /// twice where two of its edges are this one (a degenerate triangle).
    fn faces(&self, e: usize) -> impl Iterator<Item = u32> + '_ {
        let range = self.start[e] as usize..self.end[e] as usize;
        self.uses[range].iter().map(|&(_, f)| f / 3)
    }
}

/// Shelf-packs the charts at `scale` texels per world unit into a `resolution`² atlas:
/// each chart's rectangle is its extent, one texel for conservative rasterisation, and
/// [`PADDING`]. Returns the scale and each chart's offset in texels, or `None` if they do
/// not fit.
fn pack(charts: &[Chart], scale: f32, resolution: u32) -> Option<(f32, Vec<Vec2>)> {
    let size = |c: &Chart| ((c.max - c.min) * scale).ceil() + Vec2::splat(1.0 + PADDING as f32);
    let sizes: Vec<Vec2> = charts.iter().map(size).collect();
    let r = resolution as f32;
    let order = tallest_first(&sizes, r)?;
    let mut offsets = vec![Vec2::ZERO; charts.len()];
    let (mut x, mut y, mut shelf) = (0.0f32, 0.0f32, 0.0f32);
    for i in order {
        let s = sizes[i];
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

/// The packing order of charts of `sizes` (texels): tallest first, ties in chart order, so
/// it is deterministic. `None` where a chart is wider or taller than the `r`-texel atlas:
/// no order packs it. Heights are whole texels, so a counting sort orders them: the
/// bisection of [`fill`] packs up to 40 times, and a comparison sort of a large mesh's
/// hundreds of thousands of charts each time cost most of the atlas.
fn tallest_first(sizes: &[Vec2], r: f32) -> Option<Vec<usize>> {
    if sizes.iter().any(|s| s.x > r || s.y > r) {
        return None;
    }
    let whole = |s: &Vec2| s.y >= 0.0 && s.y.fract() == 0.0; // false for NaN and infinities
    if !sizes.iter().all(whole) {
        let mut order: Vec<usize> = (0..sizes.len()).collect();
        order.sort_by(|&a, &b| sizes[b].y.total_cmp(&sizes[a].y).then(a.cmp(&b)));
        return Some(order);
    }
    // Heights are whole and at most r: bucket i counts the charts i texels tall.
    let mut start = vec![0usize; r as usize + 2];
    for s in sizes {
        start[r as usize - s.y as usize + 1] += 1;
    }
    for i in 1..start.len() {
        start[i] += start[i - 1];
    }
    let mut order = vec![0usize; sizes.len()];
    for (i, s) in sizes.iter().enumerate() {
        let bucket = &mut start[r as usize - s.y as usize];
        order[*bucket] = i;
        *bucket += 1;
    }
    Some(order)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The triangles at each edge as a hash map filled in triangle order lists them: what
    /// [`EdgeFaces`] replaced.
    fn reference(triangles: &[[u32; 3]], e: usize) -> Vec<u32> {
        let mut map: std::collections::HashMap<(u32, u32), Vec<u32>> = Default::default();
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                map.entry((a.min(b), a.max(b))).or_default().push(t as u32);
            }
        }
        let (a, b) = (triangles[e / 3][e % 3], triangles[e / 3][(e % 3 + 1) % 3]);
        map[&(a.min(b), a.max(b))].clone()
    }

    #[test]
    fn edge_faces_list_each_edges_triangles_in_triangle_order() {
        // A fan, an edge of three triangles, both windings, and a degenerate triangle whose
        // two edges are one.
        let triangles = [
            [0, 1, 2],
            [2, 1, 3],
            [1, 0, 4],
            [5, 1, 2],
            [0, 2, 6],
            [7, 7, 8],
            [8, 7, 9],
            [1, 2, 10],
        ];
        let edges = EdgeFaces::new(&triangles);
        for e in 0..triangles.len() * 3 {
            let faces: Vec<u32> = edges.faces(e).collect();
            assert_eq!(faces, reference(&triangles, e), "edge {e}");
        }
        assert_eq!(edges.faces(3).collect::<Vec<_>>(), [0, 1, 3, 7]);
        assert_eq!(edges.faces(15).collect::<Vec<_>>(), [5]);
        assert_eq!(edges.faces(16).collect::<Vec<_>>(), [5, 5, 6]);
    }

    /// A ramp of `steps` 48ths of a turn round the z axis, rising `rise` a turn, radii 1 to
    /// 2: nearly flat, so one 30° cone holds all of it, and its turns lie over one another.
    fn spiral_ramp(steps: usize, rise: f32) -> Scene {
        let mut positions = Vec::new();
        for i in 0..=steps {
            let a = i as f32 / 48.0 * std::f32::consts::TAU;
            let z = rise * i as f32 / 48.0;
            for r in [1.0f32, 2.0] {
                positions.push(glam::Vec3::new(r * a.cos(), r * a.sin(), z));
            }
        }
        let triangles = (0..steps as u32)
            .flat_map(|i| {
                [
                    [2 * i, 2 * i + 1, 2 * i + 2],
                    [2 * i + 1, 2 * i + 3, 2 * i + 2],
                ]
            })
            .collect();
        let mesh = crate::scene::Mesh {
            name: "ramp".into(),
            positions,
            normals: None,
            uvs: None,
            triangles,
            material: crate::scene::Material::default(),
        };
        Scene::from_meshes(std::path::Path::new("ramp"), vec![mesh], Vec::new()).expect("valid")
    }

    #[test]
    fn a_ramp_that_winds_over_itself_is_split_where_its_turns_overlap() {
        // Most of a turn overlaps nothing. (A whole turn does: its end lies 0.1 above its
        // start, which the projection onto its first triangle's plane, tilted by 1°, shifts
        // sideways over the start.)
        assert_eq!(planar_charts(&spiral_ramp(44, 0.1)).len(), 1);
        assert_eq!(planar_charts(&spiral_ramp(48, 0.1)).len(), 2);
        let ramp = spiral_ramp(3 * 48, 0.1);
        let charts = planar_charts(&ramp);
        // Every triangle is in exactly one chart, no chart overlaps itself, and each turn
        // needs a chart of its own.
        let mut seen = vec![0; ramp.triangles.len()];
        charts
            .iter()
            .flat_map(|c| &c.triangles)
            .for_each(|&t| seen[t as usize] += 1);
        assert!(seen.iter().all(|&n| n == 1), "{seen:?}");
        assert!(
            charts
                .iter()
                .all(|c| !chart_overlap::overlaps_itself(&c.local))
        );
        assert!((3..=4).contains(&charts.len()), "{} charts", charts.len());
        // Nearly flat (a slope of 0.1 over a turn of radius 1 is under 1°): no rescaling.
        let first = &charts[0];
        let t = first.triangles[0] as usize;
        let p = ramp.triangles[t].map(|v| ramp.positions[v as usize]);
        let world = (p[1] - p[0]).cross(p[2] - p[0]).length();
        let l = first.local[0];
        let projected = (l[1] - l[0]).perp_dot(l[2] - l[0]).abs();
        assert!(
            (projected / world - 1.0).abs() < 1e-3,
            "{projected} against {world}"
        );
    }

    #[test]
    fn a_tilted_chart_keeps_its_surface_area() {
        // One turn rising 3 a turn: slopes of up to 25° (at radius 1), one chart, projected
        // onto its first triangle's plane and scaled back to its surface's area.
        let ramp = spiral_ramp(40, 3.0);
        let charts = planar_charts(&ramp);
        let (mut world, mut projected) = (0.0f64, 0.0f64);
        for c in &charts {
            for (&t, l) in c.triangles.iter().zip(&c.local) {
                let p = ramp.triangles[t as usize].map(|v| ramp.positions[v as usize]);
                world += f64::from((p[1] - p[0]).cross(p[2] - p[0]).length());
                projected += f64::from((l[1] - l[0]).perp_dot(l[2] - l[0]).abs());
            }
        }
        assert!(charts.len() < 10, "{} charts", charts.len());
        assert!(
            (projected / world - 1.0).abs() < 1e-4,
            "{projected} against {world}"
        );
    }

    #[test]
    fn the_counting_sort_orders_as_the_comparison_sort() {
        let sizes: Vec<Vec2> = [5.0, 3.0, 5.0, 12.0, 3.0, 0.0, 12.0, 7.0, 16.0]
            .iter()
            .map(|&y| Vec2::new(4.0, y))
            .collect();
        let mut expected: Vec<usize> = (0..sizes.len()).collect();
        expected.sort_by(|&a, &b| sizes[b].y.total_cmp(&sizes[a].y).then(a.cmp(&b)));
        assert_eq!(tallest_first(&sizes, 16.0), Some(expected.clone()));
        assert_eq!(expected[..3], [8, 3, 6]);
        // Fractional heights take the comparison sort, to the same order.
        let mut fractional = sizes.clone();
        fractional[5].y = 0.5;
        assert_eq!(tallest_first(&fractional, 16.0), Some(expected));
        // A chart larger than the atlas fits in no order.
        assert_eq!(tallest_first(&sizes, 15.0), None);
        assert_eq!(tallest_first(&[Vec2::new(17.0, 1.0)], 16.0), None);
    }
}
