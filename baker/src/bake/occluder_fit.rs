//! Fits a sphere set to an object for `bake --occluder`: the stand-in whose closed-form SH
//! visibility darkens receivers when the object moves through a baked scene.
//!
//! The object's surface is taken as its triangle corners, each weighted by a third of the area
//! of the triangles that use it (so the weights are the surface's area, however the mesh is
//! tessellated). K spheres: weighted k-means (Lloyd's iterations, started from farthest-point
//! picks, so deterministic), and each cluster's sphere is centred on its weighted mean with the
//! weighted RMS distance of its points as radius. One sphere fitted to a tessellated ball is
//! that ball (its corners lie on it); a long or flat object needs several, and the fit then
//! rounds its silhouette, which is what a soft shadow from low-order SH can show anyway.

use glam::{DVec3, Vec3};

use crate::formats::occluder_file::{LocalSphere, MAX_SPHERES, OccluderFile};
use crate::scene::Scene;

/// Lloyd's iterations; the clusters of the small K used here settle well before.
const ITERATIONS: usize = 50;

/// Fits `count` spheres to the scene's triangles (every object), in its coordinates.
pub fn fit_spheres(scene: &Scene, count: usize) -> Result<OccluderFile, String> {
    if count == 0 || count > MAX_SPHERES {
        return Err(format!("--spheres {count}: give 1 to {MAX_SPHERES}"));
    }
    let mut weight = vec![0.0f64; scene.positions.len()];
    for t in &scene.triangles {
        let [a, b, c] = t.map(|i| scene.positions[i as usize].as_dvec3());
        let area = (b - a).cross(c - a).length() / 2.0;
        for i in t {
            weight[*i as usize] += area / 3.0;
        }
    }
    let points: Vec<(DVec3, f64)> = scene
        .positions
        .iter()
        .zip(&weight)
        .filter(|(_, w)| **w > 0.0)
        .map(|(p, w)| (p.as_dvec3(), *w))
        .collect();
    if points.len() < count {
        return Err(format!(
            "{} surface points (corners of triangles of non-zero area) cannot make {count} spheres",
            points.len()
        ));
    }
    let mut centres = farthest_points(&points, count);
    let mut cluster = vec![0usize; points.len()];
    for _ in 0..ITERATIONS {
        for (k, (p, _)) in cluster.iter_mut().zip(&points) {
            *k = nearest(&centres, *p);
        }
        let mut sums = vec![(DVec3::ZERO, 0.0f64); count];
        for (k, (p, w)) in cluster.iter().zip(&points) {
            sums[*k].0 += *p * *w;
            sums[*k].1 += *w;
        }
        for (c, (sum, w)) in centres.iter_mut().zip(&sums) {
            if *w > 0.0 {
                *c = *sum / *w;
            }
        }
    }
    let mut moments = vec![(0.0f64, 0.0f64); count];
    for (k, (p, w)) in cluster.iter().zip(&points) {
        moments[*k].0 += w * p.distance_squared(centres[*k]);
        moments[*k].1 += w;
    }
    let spheres = centres
        .iter()
        .zip(&moments)
        .filter(|(_, (_, w))| *w > 0.0)
        .map(|(c, (m, w))| LocalSphere {
            centre: c.as_vec3(),
            radius: ((m / w).sqrt() as f32).max(f32::MIN_POSITIVE),
        })
        .collect();
    Ok(OccluderFile { spheres })
}

/// `count` starting centres: the weighted centroid's farthest point, then each next point
/// farthest from those picked.
fn farthest_points(points: &[(DVec3, f64)], count: usize) -> Vec<DVec3> {
    let total: f64 = points.iter().map(|(_, w)| w).sum();
    let centroid = points.iter().map(|(p, w)| *p * *w).sum::<DVec3>() / total;
    if count == 1 {
        return vec![centroid];
    }
    let mut picked = vec![farthest(points, |p| p.distance_squared(centroid))];
    while picked.len() < count {
        let next = farthest(points, |p| {
            picked
                .iter()
                .map(|c| p.distance_squared(*c))
                .fold(f64::INFINITY, f64::min)
        });
        picked.push(next);
    }
    picked
}

fn farthest(points: &[(DVec3, f64)], distance: impl Fn(DVec3) -> f64) -> DVec3 {
    points
        .iter()
        .map(|(p, _)| *p)
        .fold((DVec3::ZERO, -1.0), |(best, d), p| {
            let dp = distance(p);
            if dp > d { (p, dp) } else { (best, d) }
        })
        .0
}

fn nearest(centres: &[DVec3], p: DVec3) -> usize {
    centres
        .iter()
        .enumerate()
        .map(|(k, c)| (k, p.distance_squared(*c)))
        .fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a })
        .0
}

/// The summary of a fit for the command's report: per sphere centre and radius.
pub fn describe(file: &OccluderFile) -> String {
    file.spheres
        .iter()
        .map(|s| {
            let Vec3 { x, y, z } = s.centre;
            format!("({x:.4}, {y:.4}, {z:.4}) r {:.4}", s.radius)
        })
        .collect::<Vec<_>>()
        .join("; ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Material, Mesh};

    /// An octahedron of `radius` about `centre` (its corners on the sphere).
    fn octahedron(name: &str, centre: Vec3, radius: f32) -> Mesh {
        let positions: Vec<Vec3> = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
            .iter()
            .map(|d| centre + *d * radius)
            .collect();
        let triangles = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        Mesh {
            name: name.into(),
            normals: None,
            uvs: None,
            positions,
            triangles,
            material: Material::default(),
        }
    }

    #[test]
    fn two_separate_balls_get_a_sphere_each() {
        let scene = Scene::from_meshes(
            std::path::Path::new("two"),
            vec![
                octahedron("a", Vec3::new(-2.0, 0.0, 0.0), 0.5),
                octahedron("b", Vec3::new(3.0, 1.0, 0.0), 0.25),
            ],
            Vec::new(),
        )
        .unwrap();
        let mut fit = fit_spheres(&scene, 2).unwrap().spheres;
        fit.sort_by(|a, b| a.centre.x.total_cmp(&b.centre.x));
        assert!(
            (fit[0].centre - Vec3::new(-2.0, 0.0, 0.0)).length() < 1e-5,
            "{fit:?}"
        );
        assert!((fit[0].radius - 0.5).abs() < 1e-5);
        assert!(
            (fit[1].centre - Vec3::new(3.0, 1.0, 0.0)).length() < 1e-5,
            "{fit:?}"
        );
        assert!((fit[1].radius - 0.25).abs() < 1e-5);
        assert!(fit_spheres(&scene, 0).is_err() && fit_spheres(&scene, 13).is_err());
    }
}
