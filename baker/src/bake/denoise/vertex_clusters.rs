//! The vertices' clusters ([`super::vertices`]): like vertices gathered around seeds in world
//! space. A mesh's spacing changes from one object to the next (the torus's floor has a
//! vertex every 0.13 units, the torus one every 0.04), so the texels' clusters, one grid
//! cell each ([`Clusters::build`]), would leave a sparse object's vertices one to a cell:
//! here each seed takes in its neighbours within its own spacings.

use super::clusters::{Clusters, add_scaled, on_one_surface};
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
/// order (cells by their first vertex, vertices by index within a cell), each vertex no
/// cluster holds yet seeds one, and takes in every neighbour no cluster holds that may share
/// its kernel ([`super::clusters::on_one_surface`], and raw signals apart by less than their
/// noise, [`SIMILAR`]). Members weigh the same. A function of the guides and the
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
        let (a, b) = (
            &signal[m * width..][..width],
            &signal[seed * width..][..width],
        );
        let squared: f32 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
        squared <= SIMILAR * (noise[m] + noise[seed]) * width as f32
    };
    let joins = |seed: usize, m: usize| {
        on_one_surface(g, seed, m, 0.5 * step * g.spacing[seed]) && similar(seed, m)
    };
    let count = g.points.len();
    let mut clusters = Clusters::empty(count);
    let mut means = Vec::new();
    let mut taken = vec![false; count];
    let mut mine = Vec::new();
    for cell in grid.cells_by_first() {
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
            let centre = mine
                .iter()
                .fold(glam::Vec3::ZERO, |s, &m| s + w * g.points[m]);
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A sheet of 16 × 16 vertices, one spacing apart, lit on its left half and in shadow on
    /// its right (many noise deviations apart): the clusters gather several vertices each,
    /// and none holds vertices of both halves.
    #[test]
    fn no_cluster_takes_in_both_sides_of_a_shadow_edge() {
        let mut g = Guides::default();
        for a in 0..16 {
            for b in 0..16 {
                g.points.push(Vec3::new(a as f32, b as f32, 0.0));
                g.normals.push(Vec3::Z);
                g.surfaces.push(Vec3::Z);
                g.groups.push(0);
                g.spacing.push(1.0);
                g.noise.push(1e-4);
            }
        }
        let lit = |p: Vec3| p.x < 7.5;
        let signal: Vec<f32> = g
            .points
            .iter()
            .map(|&p| if lit(p) { 0.8 } else { 0.2 })
            .collect();
        let grid = Grid::new(&g.points, 2.5);
        let (clusters, means) = build(&g, &grid, 2.5, &g.noise, (&signal, 1));
        let joined = (0..clusters.reps.len())
            .filter(|&k| clusters.mass[k] > 1.0)
            .count();
        assert!(joined > 20, "{joined} clusters of more than one vertex");
        let members: usize = clusters.mass.iter().map(|&m| m as usize).sum();
        assert_eq!(members, g.points.len());
        for k in 0..clusters.reps.len() {
            let sides: Vec<bool> = (clusters.row(k).iter())
                .map(|&(m, _)| lit(g.points[m as usize]))
                .collect();
            assert!(
                sides.iter().all(|&s| s == sides[0]),
                "cluster {k}: {sides:?}"
            );
            assert!((means[k] - signal[clusters.reps[k] as usize]).abs() < 1e-6);
        }
    }
}
