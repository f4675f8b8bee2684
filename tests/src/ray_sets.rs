//! Ray sets for comparing tracers (`agreement.rs`): the bake's own rays, random rays, and
//! hard cases — rays aimed exactly at edges and vertices, grazing a surface, leaving
//! surfaces, aimed at thin slivers.

use glam::Vec3;
use prt_baker::bake::transfer::Estimator;
use prt_baker::math::sampling::{Pcg32, uniform_sphere};
use prt_baker::trace::{Ray, offset_distance, ray_origins};
use prt_baker::{BakeOptions, Scene};

pub fn random_point(rng: &mut Pcg32) -> Vec3 {
    Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())
}

pub fn random_dir(rng: &mut Pcg32) -> Vec3 {
    uniform_sphere(rng.next_f32(), rng.next_f32())
}

/// The rays a bake with `samples` rays per vertex casts (every vertex's, in the bake's order).
pub fn bake_rays(scene: &Scene, samples: u32) -> Vec<Ray> {
    let options = BakeOptions {
        samples,
        ..BakeOptions::default()
    };
    let estimator = Estimator::new(scene, &options).expect("valid options");
    (0..scene.vertex_count())
        .flat_map(|v| vertex_rays(&estimator, v, samples as usize))
        .collect()
}

/// The `samples` rays that vertex `v` casts in the bake `estimator` is for.
pub fn vertex_rays(estimator: &Estimator, v: usize, samples: usize) -> Vec<Ray> {
    let (mut dirs, mut weights) = (Vec::new(), Vec::new());
    estimator.directions(
        v,
        &estimator.vertex_frame(v),
        0..samples,
        &mut dirs,
        &mut weights,
    );
    Ray::fan(estimator.origin(v), &dirs)
}

/// Random rays through the unit cube scaled by `scale` and moved by `offset`; one in four is
/// a segment ending inside it.
pub fn random_rays(count: usize, scale: f32, offset: Vec3, rng: &mut Pcg32) -> Vec<Ray> {
    (0..count)
        .map(|i| Ray {
            origin: (random_point(rng) * 1.2 - 0.1) * scale + offset,
            dir: random_dir(rng),
            tfar: if i % 4 == 0 {
                rng.next_f32() * scale
            } else {
                f32::INFINITY
            },
        })
        .collect()
}

pub fn corners(scene: &Scene, t: usize) -> [Vec3; 3] {
    scene.triangles[t].map(|i| scene.positions[i as usize])
}

pub fn longest_edge([a, b, c]: [Vec3; 3]) -> f32 {
    a.distance(b).max(b.distance(c)).max(c.distance(a))
}

/// Rays aimed exactly (to within rounding of the aim point) at vertices and at points on edges
/// of random triangles, from random directions at distances of 0.05 to 2 × `scale`.
pub fn edge_and_vertex_rays(scene: &Scene, count: usize, scale: f32, rng: &mut Pcg32) -> Vec<Ray> {
    (0..count)
        .map(|_| {
            let t = rng.next_u32() as usize % scene.triangles.len();
            let p = corners(scene, t);
            let k = rng.next_u32() as usize % 3;
            let target = if rng.next_u32() % 3 == 0 {
                p[k]
            } else {
                p[k] + (p[(k + 1) % 3] - p[k]) * rng.next_f32()
            };
            let origin = target + random_dir(rng) * scale * (0.05 + 2.0 * rng.next_f32());
            Ray {
                origin,
                dir: (target - origin).normalize(),
                tfar: f32::INFINITY,
            }
        })
        .collect()
}

/// Rays nearly parallel to a grid of side `side` in the plane z = 0 moved by `offset`: from
/// heights of ±10⁻⁷ to ±10⁻² × side (and 0), with slopes of ±10⁻⁶ to ±10⁻³ (and 0).
pub fn grazing_rays(count: usize, side: f32, offset: Vec3, rng: &mut Pcg32) -> Vec<Ray> {
    (0..count)
        .map(|_| {
            let signed_power = |rng: &mut Pcg32, lo: f32, hi: f32| {
                let magnitude = if rng.next_u32() % 8 == 0 {
                    0.0
                } else {
                    10f32.powf(lo + (hi - lo) * rng.next_f32())
                };
                if rng.next_u32() % 2 == 0 {
                    magnitude
                } else {
                    -magnitude
                }
            };
            let height = signed_power(rng, -7.0, -2.0) * side;
            let slope = signed_power(rng, -6.0, -3.0);
            let phi = std::f32::consts::TAU * rng.next_f32();
            let start = Vec3::new(rng.next_f32() * side, rng.next_f32() * side, height);
            Ray {
                origin: start + offset,
                dir: Vec3::new(phi.cos(), phi.sin(), slope).normalize(),
                tfar: f32::INFINITY,
            }
        })
        .collect()
}

/// Rays leaving the scene's surfaces in every direction: from every vertex's ray origin (the
/// baker's rule) and from random points of random triangles moved off the surface by the
/// same rule's distance, to either side.
pub fn surface_rays(scene: &Scene, count: usize, rng: &mut Pcg32) -> Vec<Ray> {
    let origins = ray_origins(scene);
    let mut rays: Vec<Ray> = origins
        .iter()
        .cycle()
        .take(count / 2)
        .map(|&origin| Ray {
            origin,
            dir: random_dir(rng),
            tfar: f32::INFINITY,
        })
        .collect();
    while rays.len() < count {
        let ([a, b, c], point) = random_surface_point(scene, rng);
        let longest = longest_edge([a, b, c]);
        let side = if rng.next_u32() % 2 == 0 { 1.0 } else { -1.0 };
        let normal = (b - a).cross(c - a).normalize_or_zero() * side;
        rays.push(Ray {
            origin: point + normal * offset_distance(point, longest),
            dir: random_dir(rng),
            tfar: f32::INFINITY,
        });
    }
    rays
}

/// Rays aimed at random points of random triangles (from random points of the unit cube
/// scaled by `scale`), and as many random rays.
pub fn aimed_rays(scene: &Scene, count: usize, scale: f32, rng: &mut Pcg32) -> Vec<Ray> {
    let mut rays = random_rays(count / 2, scale, Vec3::ZERO, rng);
    while rays.len() < count {
        let (_, target) = random_surface_point(scene, rng);
        let origin = random_point(rng) * scale;
        rays.push(Ray {
            origin,
            dir: (target - origin).normalize(),
            tfar: f32::INFINITY,
        });
    }
    rays
}

/// A uniformly random point of a random triangle, and that triangle's corners.
fn random_surface_point(scene: &Scene, rng: &mut Pcg32) -> ([Vec3; 3], Vec3) {
    let t = rng.next_u32() as usize % scene.triangles.len();
    let [a, b, c] = corners(scene, t);
    let (u, v) = (rng.next_f32(), rng.next_f32());
    let (u, v) = if u + v > 1.0 {
        (1.0 - u, 1.0 - v)
    } else {
        (u, v)
    };
    ([a, b, c], a + (b - a) * u + (c - a) * v)
}
