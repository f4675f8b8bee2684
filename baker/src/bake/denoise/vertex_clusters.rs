//! The vertices' clusters ([`super::vertices`]): like vertices gathered around seeds in world
//! space. A mesh's spacing changes from one object to the next (the torus's floor has a
//! vertex every 0.13 units, the torus one every 0.04), so the texels' clusters, one grid
//! cell each ([`Clusters::build`]), would leave a sparse object's vertices one to a cell:
//! here each seed takes in its neighbours within its own spacings.

use super::clusters::{Clusters, add_scaled};
use super::grid::Grid;
use super::guides::Guides;

/// How far apart two vertices' raw signals may be to share a cluster: their squared
/// difference at most this many times what noise alone gives it on average. Measured on the
/// torus at 64 rays (`STEP` 2.5): 0.6 keeps every kind's error (transfer matrices 2.25 %
/// against 2.20 % one by one); at 1 (the texels' test at d² ≤ 1) clusters grow from 1.9 to
/// 2.2 vertices and the matrices' error to 2.35 %: a vertex at a shadow's edge then shares
/// the range term of a neighbour on its other side.
const SIMILAR: f32 = 0.6;

/// Clusters of vertices within `step` / 2 of a seed's spacings: in the fine grid's fixed
/// order (cells by key, vertices by index within a cell), each vertex no cluster holds yet
/// seeds one, and takes in every neighbour no cluster holds that may share its kernel (within
/// reach, the same group, normals within 25°, on its plane, and raw signals apart by less
/// than their noise, [`SIMILAR`]). Members weigh the same. A function of the guides and the
/// signal (`width` floats per vertex) alone, in a fixed order: the same on any thread.
///
/// Returns the clusters and their means of `signal`, as [`Clusters::build`] does.
pub fn build(
    guides: &Guides,
    grid: &Grid,
    step: f32,
    noise: &[f32],
    (signal, width): (&[f32], usize),
) -> (Clusters, Vec<f32>) {
    let g = guides;
    let similar = |seed: usize, m: usize| {
        let (a, b) = (&signal[m * width..][..width], &signal[seed * width..][..width]);
        let squared: f32 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
        squared <= SIMILAR * (noise[m] + noise[seed]) * width as f32
    };
    let joins = |seed: usize, m: usize| {
        let d = g.points[m] - g.points[seed];
        let reach = 0.5 * step * g.spacing[seed];
        d.length_squared() <= reach * reach
            && g.groups[seed] == g.groups[m]
            && g.normals[seed].dot(g.normals[m]) > 0.9
            && g.surfaces[seed].dot(g.surfaces[m]) > 0.9
            && g.surfaces[seed].dot(d).abs() < 0.5 * g.spacing[seed]
            && similar(seed, m)
    };
    let count = g.points.len();
    let mut clusters = Clusters {
        reps: Vec::new(),
        starts: vec![0],
        members: Vec::with_capacity(count),
        mass: Vec::new(),
        noise: Vec::new(),
        points: Vec::new(),
    };
    let mut means = Vec::new();
    let mut taken = vec![false; count];
    let mut mine = Vec::new();
    for cell in grid.cells() {
        for &seed in cell {
            let seed = seed as usize;
            if taken[seed] {
                continue;
            }
            mine.clear();
            mine.push(seed);
            taken[seed] = true;
            grid.visit(g.points[seed], 0.5 * step * g.spacing[seed], |m| {
                let m = m as usize;
                if !taken[m] && joins(seed, m) {
                    taken[m] = true;
                    mine.push(m);
                }
            });
            let n = mine.len() as f32;
            let w = 1.0 / n;
            let centre = mine.iter().fold(glam::Vec3::ZERO, |s, &m| s + w * g.points[m]);
            let (mut rep, mut best, mut var) = (seed, f32::INFINITY, 0.0f32);
            let mean = means.len();
            means.resize(mean + width, 0.0);
            for &m in &mine {
                add_scaled(&mut means[mean..], w, &signal[m * width..][..width]);
                let d = g.points[m].distance_squared(centre);
                if d < best {
                    (best, rep) = (d, m);
                }
                var += w * w * noise[m];
                clusters.members.push((m as u32, w));
            }
            clusters.points.push(centre);
            clusters.reps.push(rep as u32);
            clusters.starts.push(clusters.members.len() as u32);
            clusters.mass.push(n);
            clusters.noise.push(var);
        }
    }
    (clusters, means)
}
