//! The pure-Rust backend: obvhs's compressed 8-wide BVH (CWBVH), traversed with obvhs's
//! `traverse!` loop but with our own box and triangle tests.
//!
//! A bake must not depend on which backend cast its rays, so this backend answers with the
//! Embree backend's semantics rather than obvhs's stock ones:
//!
//! * **Triangles** ([`triangle`]): the watertight formulation of Embree's robust mode — no
//!   culling, a hit needs 0 ≤ t ≤ tfar, Embree's barycentrics and unnormalised normal — so a
//!   ray cannot slip through the edge two triangles share. (obvhs's own test is not watertight
//!   and rejects barycentrics of −0; Embree's default test is not watertight either, see
//!   [`triangle`].)
//! * **Boxes** ([`node`]): no minimum distance (obvhs skips boxes closer than 10⁻⁴), a margin
//!   that covers rounding, and axis-parallel rays handled as Embree handles them.
//!
//! So this backend answers as Embree does in robust mode, up to rounding. Its bake of the demo
//! scene runs at 0.39 × the Embree backend's default bake (docs/explanation/performance.md, "obvhs:
//! per-ray culling in packets").
//!
//! Occlusion rays traverse in packets ([`packet`]) with our own stack, each ray culled on its
//! own, box tests eight rays at a time (AVX2); closest hits one ray at a time with obvhs's
//! `traverse!`. Triangles are stored in the BVH's leaf order, so a leaf's triangles are
//! contiguous in memory and no index is looked up during traversal.

mod node;
mod packet;
mod triangle;

use std::time::Duration;

use glam::{UVec2, Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::traverse;

use self::node::{BoxRay, ChildBoxes, traversal_mask};
use self::triangle::{ScaledHit, Triangle};
use super::instances::TopLevel;
use super::tracer::{Backend, Hit, Ray, Tracer};
use crate::scene::{Cutouts, Scene};

/// How the obvhs BVH is built.
#[derive(Clone, Copy, Debug)]
pub struct ObvhsOptions {
    /// obvhs's build parameters; [`ObvhsOptions::default`] picks the preset that traced the
    /// demo scene's rays fastest (docs/explanation/performance.md).
    pub build: BvhBuildParams,
}

impl Default for ObvhsOptions {
    fn default() -> ObvhsOptions {
        ObvhsOptions {
            build: BvhBuildParams::medium_build(),
        }
    }
}

pub struct ObvhsTracer {
    bvh: CwBvh,
    /// `triangles[i]` is the scene triangle `bvh.primitive_indices[i]`.
    triangles: Vec<Triangle>,
    /// The scene's cut-out triangles, whose hits pass the alpha test or are ignored.
    cutouts: Option<Cutouts>,
    /// The scene's instances ([`Scene::instances`]), traced after its own triangles.
    instances: Option<TopLevel<ObvhsTracer>>,
}

impl ObvhsTracer {
    /// Builds the BVH. Never fails: obvhs needs no device and accepts any triangle soup.
    pub fn new(scene: &Scene, options: ObvhsOptions) -> ObvhsTracer {
        let mut tracer = ObvhsTracer::of_triangles(
            &scene.positions,
            scene.traced_triangles(),
            scene.cutouts(),
            options,
        );
        if !scene.instances.is_empty() {
            tracer.instances = Some(TopLevel::new(&scene.instances, |mesh| {
                ObvhsTracer::of_triangles(&mesh.positions, &mesh.triangles, None, options)
            }));
        }
        tracer
    }

    /// A tracer of a triangle list (a scene's, or an instance mesh's).
    fn of_triangles(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        cutouts: Option<Cutouts>,
        options: ObvhsOptions,
    ) -> ObvhsTracer {
        let corners = |t: &[u32; 3]| t.map(|i| Vec3A::from(positions[i as usize]));
        let soup: Vec<obvhs::triangle::Triangle> = triangles
            .iter()
            .map(|t| {
                let [v0, v1, v2] = corners(t);
                obvhs::triangle::Triangle { v0, v1, v2 }
            })
            .collect();
        let bvh = build_cwbvh_from_tris(&soup, options.build, &mut Duration::default());
        let triangles = bvh
            .primitive_indices
            .iter()
            .map(|&i| {
                let [v0, v1, v2] = corners(&triangles[i as usize]);
                Triangle::new(v0, v1, v2)
            })
            .collect();
        ObvhsTracer {
            bvh,
            triangles,
            cutouts,
            instances: None,
        }
    }

    /// Whether `hit` of `ray` on the triangle in BVH slot `slot` stops the ray: the alpha test
    /// of cut-out triangles ([`Cutouts::stops`]), true for all others.
    #[inline(always)]
    fn stops(&self, slot: u32, hit: &ScaledHit, ray: &BoxRay) -> bool {
        let Some(cutouts) = &self.cutouts else {
            return true;
        };
        let triangle = self.bvh.primitive_indices[slot as usize];
        if !cutouts.is_cut(triangle) {
            return true;
        }
        let (u, v) = hit.barycentrics();
        cutouts.stops(triangle, u, v, ray.origin.into(), ray.dir.into())
    }

    /// The number of nodes of the BVH (for benchmarks comparing build presets).
    pub fn node_count(&self) -> usize {
        self.bvh.nodes.len()
    }

    fn closest_hit(&self, mut ray: BoxRay) -> Option<Hit> {
        let mut state = self.bvh.new_traversal(ray.dir);
        let mut node;
        let mut closest: Option<(u32, ScaledHit)> = None;
        traverse!(
            self.bvh,
            node,
            state,
            traversal_mask(node, state.oct_inv4, ChildBoxes::new(node).entered_by(&ray)),
            {
                let slot = state.primitive_id;
                if let Some(hit) = self.triangles[slot as usize].intersect(&ray)
                    && self.stops(slot, &hit, &ray)
                {
                    // Later candidates must come nearer (the test keeps t ≤ tfar), as in
                    // Embree, which shortens the ray to each hit.
                    ray.tfar = hit.t / hit.den;
                    closest = Some((slot, hit));
                }
            }
        );
        closest.map(|(slot, hit)| {
            // A hit with U + V + W = 0 is a degenerate triangle seen edge-on; Embree reports
            // u = v = 0 for it.
            let barycentric = |x: f32| if hit.uvw == 0.0 { 0.0 } else { x / hit.uvw };
            Hit {
                triangle: self.bvh.primitive_indices[slot as usize],
                instance: None,
                u: barycentric(hit.u),
                v: barycentric(hit.v),
                t: hit.t / hit.den,
                ng: self.triangles[slot as usize].normal().into(),
            }
        })
    }
}

impl Tracer for ObvhsTracer {
    fn backend(&self) -> Backend {
        Backend::Obvhs
    }

    fn occluded(&self, rays: &[Ray], occluded: &mut [bool]) {
        let boxed = rays
            .iter()
            .map(|r| BoxRay::new(r.origin.into(), r.dir.into(), r.tfar));
        self.blocked_in_packets(boxed, None, occluded);
        if let Some(top) = &self.instances {
            for (o, r) in occluded.iter_mut().zip(rays) {
                *o = *o || top.occluded(r);
            }
        }
    }

    fn occluded_from(&self, origin: Vec3, dirs: &[Vec3], occluded: &mut [bool]) {
        let rays = dirs
            .iter()
            .map(|&d| BoxRay::new(origin.into(), d.into(), f32::INFINITY));
        self.blocked_in_packets(rays, Some(origin.into()), occluded);
        if let Some(top) = &self.instances {
            for (o, &dir) in occluded.iter_mut().zip(dirs) {
                *o = *o
                    || top.occluded(&Ray {
                        origin,
                        dir,
                        tfar: f32::INFINITY,
                    });
            }
        }
    }

    fn intersect(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len());
        for (h, r) in hits.iter_mut().zip(rays) {
            *h = self.closest_hit(BoxRay::new(r.origin.into(), r.dir.into(), r.tfar));
            if let Some(top) = &self.instances {
                let tfar = h.map_or(r.tfar, |h| h.t);
                *h = top.closest_hit(&Ray { tfar, ..*r }).or(*h);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::math::sampling::{Pcg32, uniform_sphere};
    use crate::scene::{Material, Mesh};

    fn scene(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Scene {
        let mesh = Mesh {
            name: "test".into(),
            positions,
            normals: None,
            uvs: None,
            triangles,
            material: Material::default(),
        };
        Scene::from_meshes(Path::new("test"), vec![mesh], Vec::new()).expect("valid scene")
    }

    /// `count` random triangles of edge up to `size` in the unit cube.
    fn soup(count: u32, size: f32, rng: &mut Pcg32) -> Scene {
        let mut point = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let mut positions = Vec::new();
        for _ in 0..count {
            let corner = point();
            positions.extend([corner, corner + point() * size, corner + point() * size]);
        }
        let triangles = (0..count).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        scene(positions, triangles)
    }

    fn tracer(scene: &Scene) -> ObvhsTracer {
        ObvhsTracer::new(scene, ObvhsOptions::default())
    }

    fn ray(origin: Vec3, dir: Vec3, tfar: f32) -> Ray {
        Ray { origin, dir, tfar }
    }

    /// The closest hit by testing every triangle with the same test the traversal uses.
    fn brute_force(scene: &Scene, r: &Ray) -> Option<(u32, f32)> {
        let mut best: Option<(u32, f32)> = None;
        for (i, t) in scene.triangles.iter().enumerate() {
            let [v0, v1, v2] = t.map(|k| scene.positions[k as usize].into());
            let ray = BoxRay::new(r.origin.into(), r.dir.into(), r.tfar);
            if let Some(hit) = Triangle::new(v0, v1, v2).intersect(&ray) {
                let t = hit.t / hit.den;
                if best.is_none_or(|(_, b)| t < b) {
                    best = Some((i as u32, t));
                }
            }
        }
        best
    }

    #[test]
    fn traversal_finds_what_testing_every_triangle_finds() {
        let mut rng = Pcg32::new(11, 0);
        let scene = soup(2_000, 0.1, &mut rng);
        let tracer = tracer(&scene);
        let rays: Vec<Ray> = (0..20_000)
            .map(|i| {
                let origin = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.2 - 0.1;
                let dir = uniform_sphere(rng.next_f32(), rng.next_f32());
                // Every fourth ray is a short segment, so tfar is exercised too.
                let tfar = if i % 4 == 0 { 0.05 } else { f32::INFINITY };
                ray(origin, dir, tfar)
            })
            .collect();
        let mut hits = vec![None; rays.len()];
        let mut occluded = vec![false; rays.len()];
        tracer.intersect(&rays, &mut hits);
        tracer.occluded(&rays, &mut occluded);
        let mut hit_count = 0;
        for ((r, hit), &blocked) in rays.iter().zip(&hits).zip(&occluded) {
            let expected = brute_force(&scene, r);
            assert_eq!(hit.map(|h| (h.triangle, h.t)), expected, "ray {r:?}");
            assert_eq!(blocked, expected.is_some(), "occlusion of ray {r:?}");
            hit_count += usize::from(blocked);
        }
        // Both answers occur often enough for the comparison to mean something.
        assert!(hit_count > rays.len() / 10 && hit_count < rays.len() * 9 / 10);
    }

    #[test]
    fn packets_of_rays_from_one_origin_answer_as_single_rays() {
        // Rays from a few points, in a coherent order (as the bake casts them) and shuffled;
        // 1,000 rays per point, so the last packet is partial.
        let mut rng = Pcg32::new(12, 0);
        let scene = soup(2_000, 0.1, &mut rng);
        let tracer = tracer(&scene);
        for _ in 0..8 {
            let origin = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let mut dirs: Vec<Vec3> = (0..1_000)
                .map(|_| uniform_sphere(rng.next_f32(), rng.next_f32()))
                .collect();
            for ordered in [false, true] {
                if ordered {
                    dirs.sort_by_key(|d| {
                        crate::math::sampling::hilbert_index(d.x * 0.5 + 0.5, d.y * 0.5 + 0.5)
                    });
                }
                let mut occluded = vec![false; dirs.len()];
                tracer.occluded_from(origin, &dirs, &mut occluded);
                for (d, blocked) in dirs.iter().zip(&occluded) {
                    let expected = brute_force(&scene, &ray(origin, *d, f32::INFINITY));
                    assert_eq!(
                        *blocked,
                        expected.is_some(),
                        "ray from {origin} towards {d}"
                    );
                }
            }
        }
    }

    /// The packet loop compiled for AVX2 (box tests of eight rays at a time) and for the
    /// baseline (one ray against four children at a time) answer alike. (On a CPU without AVX2 both calls take the baseline path.)
    #[test]
    fn packets_answer_alike_with_and_without_avx() {
        let mut rng = Pcg32::new(13, 0);
        let scene = soup(2_000, 0.1, &mut rng);
        let tracer = tracer(&scene);
        let rays: Vec<BoxRay> = (0..20_000)
            .map(|i| {
                let origin = Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let dir = uniform_sphere(rng.next_f32(), rng.next_f32()).into();
                BoxRay::new(origin, dir, if i % 4 == 0 { 0.05 } else { f32::INFINITY })
            })
            .collect();
        let (mut dispatched, mut baseline) = (vec![false; rays.len()], vec![false; rays.len()]);
        tracer.blocked_in_packets(rays.iter().copied(), None, &mut dispatched);
        tracer.blocked_in_packets_baseline(rays.iter().copied(), None, &mut baseline);
        assert_eq!(dispatched, baseline);
        let blocked = dispatched.iter().filter(|&&b| b).count();
        assert!(blocked > rays.len() / 10 && blocked < rays.len() * 9 / 10);
    }

    /// Rays from one origin answer alike whether the packet shares the origin's terms of the
    /// triangle test or computes them per ray, with and without AVX.
    #[test]
    fn packets_answer_alike_with_and_without_a_shared_origin() {
        let mut rng = Pcg32::new(14, 0);
        let scene = soup(2_000, 0.1, &mut rng);
        let tracer = tracer(&scene);
        for _ in 0..8 {
            let origin = Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let rays: Vec<BoxRay> = (0..2_000)
                .map(|_| {
                    let dir = uniform_sphere(rng.next_f32(), rng.next_f32()).into();
                    BoxRay::new(origin, dir, f32::INFINITY)
                })
                .collect();
            let answers = |shared: Option<Vec3A>, avx: bool| {
                let mut occluded = vec![false; rays.len()];
                if avx {
                    tracer.blocked_in_packets(rays.iter().copied(), shared, &mut occluded);
                } else {
                    tracer.blocked_in_packets_baseline(rays.iter().copied(), shared, &mut occluded);
                }
                occluded
            };
            let per_ray = answers(None, false);
            assert_eq!(answers(Some(origin), false), per_ray);
            assert_eq!(answers(Some(origin), true), per_ray);
            assert_eq!(answers(None, true), per_ray);
            assert!(per_ray.contains(&true) && per_ray.contains(&false));
        }
    }

    #[test]
    fn hit_reports_embree_barycentrics_distance_and_normal() {
        let (v0, v1, v2) = (
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(3.0, 0.5, 0.0),
            Vec3::new(1.5, 2.0, 0.25),
        );
        let scene = scene(vec![v0, v1, v2], vec![[0, 1, 2]]);
        let tracer = tracer(&scene);
        let target = 0.2 * v0 + 0.5 * v1 + 0.3 * v2;
        let origin = Vec3::new(0.0, 0.0, 4.0);
        for dir in [target - origin, (target - origin).normalize()] {
            let mut hits = [None];
            // From either side: no culling, same normal.
            for (o, d) in [(origin, dir), (2.0 * target - origin, -dir)] {
                tracer.intersect(&[ray(o, d, f32::INFINITY)], &mut hits);
                let hit = hits[0].expect("the ray hits");
                assert_eq!(hit.triangle, 0);
                assert!(
                    (hit.u - 0.5).abs() < 1e-6 && (hit.v - 0.3).abs() < 1e-6,
                    "{hit:?}"
                );
                assert!((o + hit.t * d).distance(target) < 1e-5, "{hit:?}");
                assert_eq!(hit.ng, (v1 - v0).cross(v2 - v0));
            }
        }
    }

    #[test]
    fn segments_include_both_ends() {
        let scene = scene(
            vec![
                Vec3::new(-1.0, -1.0, 1.0),
                Vec3::new(1.0, -1.0, 1.0),
                Vec3::new(0.0, 1.0, 1.0),
            ],
            vec![[0, 1, 2]],
        );
        let tracer = tracer(&scene);
        let blocked = |origin: Vec3, tfar: f32| {
            let mut out = [false];
            tracer.occluded(&[ray(origin, Vec3::Z, tfar)], &mut out);
            out[0]
        };
        assert!(blocked(Vec3::ZERO, 1.0), "a hit at exactly t = tfar counts");
        assert!(!blocked(Vec3::ZERO, 0.999_999));
        assert!(blocked(Vec3::Z, f32::INFINITY), "a hit at t = 0 counts");
        assert!(blocked(Vec3::new(0.0, 0.0, 1.0 - 1e-6), f32::INFINITY));
        assert!(!blocked(Vec3::new(0.0, 0.0, 1.0 + 1e-6), f32::INFINITY));
    }

    /// Regression: obvhs's stock box test skips every box that ends within 10⁻⁴ of the ray
    /// origin, so in a scene a tenth of a millimetre across nothing was ever hit.
    #[test]
    fn occluders_closer_than_obvhs_box_epsilon_are_found() {
        for scale in [1e-6f32, 1e-4, 1.0] {
            let mut rng = Pcg32::new(5, 0);
            let mut unit = soup(200, 0.2, &mut rng);
            for p in &mut unit.positions {
                *p *= scale;
            }
            let tracer = tracer(&unit);
            let mut misses = 0;
            for _ in 0..2_000 {
                let origin = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * scale;
                let r = ray(
                    origin,
                    uniform_sphere(rng.next_f32(), rng.next_f32()),
                    f32::INFINITY,
                );
                let mut out = [false];
                tracer.occluded(&[r], &mut out);
                misses += usize::from(out[0] != brute_force(&unit, &r).is_some());
            }
            assert_eq!(misses, 0, "scale {scale}");
        }
    }

    #[test]
    fn a_ray_through_a_shared_edge_or_vertex_hits() {
        // A unit square of two triangles sharing the diagonal, and a fan of six around a vertex.
        let square = scene(
            vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            vec![[0, 1, 2], [0, 2, 3]],
        );
        let mut fan_positions = vec![Vec3::ZERO];
        let mut fan_triangles = Vec::new();
        for k in 0..6u32 {
            let phi = std::f32::consts::TAU * k as f32 / 6.0;
            fan_positions.push(Vec3::new(phi.cos(), phi.sin(), 0.0));
            fan_triangles.push([0, 1 + k, 1 + (k + 1) % 6]);
        }
        let fan = scene(fan_positions, fan_triangles);
        for (scene, target) in [(&square, Vec3::new(0.25, 0.25, 0.0)), (&fan, Vec3::ZERO)] {
            let tracer = tracer(scene);
            let mut out = [false];
            for origin in [target + Vec3::Z, target - Vec3::Z] {
                tracer.occluded(&[ray(origin, target - origin, f32::INFINITY)], &mut out);
                assert!(out[0], "ray from {origin} to {target} slipped through");
            }
        }
    }

    /// Regression: a direction component of −0 (a ray straight down is (−0, −0, −1) from
    /// `-Vec3::Z`) took the box's near and far planes the wrong way round, so the ray missed
    /// a floor that Embree hits. Every sign of zero, one ray at a time, as packets, and with
    /// and without AVX.
    #[test]
    fn rays_with_zero_direction_components_of_either_sign_hit() {
        let floor = scene(
            vec![
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(-1.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        );
        let tracer = tracer(&floor);
        let origin = Vec3::new(0.1, 0.2, 0.3);
        let dirs: Vec<Vec3> = [(0.0, 0.0), (-0.0, 0.0), (0.0, -0.0), (-0.0, -0.0)]
            .into_iter()
            .map(|(x, y)| Vec3::new(x, y, -1.0))
            .collect();
        let rays: Vec<Ray> = dirs
            .iter()
            .map(|&d| ray(origin, d, f32::INFINITY))
            .collect();
        let mut occluded = vec![false; dirs.len()];
        tracer.occluded(&rays, &mut occluded);
        assert_eq!(occluded, [true; 4], "single rays");
        let mut hits = vec![None; dirs.len()];
        tracer.intersect(&rays, &mut hits);
        assert!(
            hits.iter()
                .all(|h| h.is_some_and(|h| (h.t - 0.3).abs() < 1e-6))
        );
        let box_rays = || {
            dirs.iter()
                .map(|&d| BoxRay::new(origin.into(), d.into(), f32::INFINITY))
        };
        let (mut dispatched, mut baseline) = (vec![false; 4], vec![false; 4]);
        tracer.blocked_in_packets(box_rays(), Some(origin.into()), &mut dispatched);
        tracer.blocked_in_packets_baseline(box_rays(), Some(origin.into()), &mut baseline);
        assert_eq!(dispatched, [true; 4], "packets (AVX where the CPU has it)");
        assert_eq!(baseline, [true; 4], "packets without AVX");
    }

    #[test]
    fn a_ray_in_the_plane_of_a_triangle_misses_it() {
        let scene = scene(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
        let tracer = tracer(&scene);
        let mut hits = [None];
        tracer.intersect(
            &[ray(Vec3::new(-1.0, 0.25, 0.0), Vec3::X, f32::INFINITY)],
            &mut hits,
        );
        assert_eq!(hits[0], None);
    }
}
