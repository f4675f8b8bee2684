//! Which vertices' rays start near another surface's edge: the only rays Embree's default mode
//! answers wrongly in a bake.
//!
//! Embree's default triangle test is not watertight: a ray that crosses a triangle within
//! rounding of one of its edges may slip through (or, at a shared edge, between two
//! triangles). A ray crosses a surface within rounding ε of an edge with a probability of
//! about ε/D, where D is how far the ray's origin is from that edge. For most vertices D is at
//! least a fraction of an edge length and ε/D is far below one ray in a bake. But where
//! meshes meet edge to edge (a floor against a wall, the boards of a room, a box standing on
//! a table), a vertex of one lies on an edge of the other, and its ray origin
//! ([`super::ray_origins`]) is only the offset δ ≈ 2⁻²⁰ edges away from it: a good share of
//! its rays cross the other surface right beside that edge, and some leak through
//! (`tests/agreement.rs` measured 126 of the Cornell room's 2,944 vertices off by more than
//! 10⁻³).
//!
//! So a vertex is a *seam vertex* when its ray origin lies near an edge of a *foreign*
//! triangle, one that does not use the vertex: within [`SEAM_RADIUS`] × (the longer of its
//! own longest edge and the other triangle's), or [`SEAM_OFFSETS`] × its offset δ, whichever
//! is larger. (Far from the origin, where floats are coarse, δ is 8 ulps of the position and
//! the second term is the larger; rounding there is proportionally worse.) Its own triangles
//! do not count: rays leave them on their open side. The Embree backend traces seam vertices'
//! rays in robust mode and all others in the default mode.
//!
//! The radius is generous (the leaks come from within a few δ, and it is at least 256 δ): on
//! the demo scene seam vertices are 4 % of all, so the margin costs little.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use glam::{Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::{Boundable, BvhBuildParams};
use rayon::prelude::*;

use super::offset::offset_distance;
use crate::scene::Scene;

/// A vertex is a seam vertex if its ray origin is within this fraction of the longer of its
/// own longest edge and a foreign triangle's longest edge from that triangle's edges.
pub const SEAM_RADIUS: f32 = 1.0 / 64.0;
/// ... or within this many times its offset δ ([`super::offset_distance`]).
pub const SEAM_OFFSETS: f32 = 256.0;

/// A triangle's box grown by [`SEAM_RADIUS`] × its longest edge: every origin that may be
/// near one of its edges (for its own edge length) lies inside.
struct Reach {
    aabb: Aabb,
}

impl Boundable for Reach {
    fn aabb(&self) -> Aabb {
        self.aabb
    }
}

/// The longest edge of each triangle (in parallel: a large mesh has millions).
fn triangle_edges(scene: &Scene) -> Vec<f32> {
    scene
        .triangles
        .par_iter()
        .map(|t| {
            let p = t.map(|i| scene.positions[i as usize]);
            p[0].distance(p[1])
                .max(p[1].distance(p[2]))
                .max(p[2].distance(p[0]))
        })
        .collect()
}

/// The longest edge of the triangles around each vertex, from [`triangle_edges`].
fn vertex_edges(scene: &Scene, triangle_edge: &[f32]) -> Vec<f32> {
    let mut per_vertex = vec![0.0f32; scene.vertex_count()];
    for (t, &longest) in scene.triangles.iter().zip(triangle_edge) {
        for &i in t {
            per_vertex[i as usize] = per_vertex[i as usize].max(longest);
        }
    }
    per_vertex
}

/// The distance from `p` to the segment `a`–`b`, in double precision (the distances that
/// matter are a millionth of the segment's length).
fn distance_to_segment(p: Vec3, a: Vec3, b: Vec3) -> f64 {
    let (p, a, b) = (p.as_dvec3(), a.as_dvec3(), b.as_dvec3());
    let ab = b - a;
    let length2 = ab.length_squared();
    let s = if length2 > 0.0 {
        ((p - a).dot(ab) / length2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + ab * s)
}

/// A BVH over every triangle's [`Reach`], to find the triangles whose edges a ray origin may
/// lie near. It depends only on the scene: a tracer keeps the one it built for its texels
/// ([`crate::trace::Tracer::for_points`] may be asked three times in a texel bake), and may
/// build it beside other work ([`crate::trace::Tracer::prepare_points`]).
pub struct SeamIndex {
    bvh: Option<obvhs::bvh2::Bvh2>,
    /// The longest edge of each triangle.
    triangle_edge: Vec<f32>,
}

impl SeamIndex {
    /// The index of `scene`'s triangles: a sequential BVH build (0.2 s at 720,000 triangles),
    /// the rest in parallel.
    pub fn new(scene: &Scene) -> SeamIndex {
        let triangle_edge = triangle_edges(scene);
        let reaches: Vec<Reach> = scene
            .triangles
            .par_iter()
            .zip(&triangle_edge)
            .map(|(t, &longest)| {
                let mut aabb = Aabb::empty();
                for &i in t {
                    aabb.extend(Vec3A::from(scene.positions[i as usize]));
                }
                let margin = Vec3A::splat(SEAM_RADIUS * longest);
                Aabb::new(aabb.min - margin, aabb.max + margin)
            })
            .map(|aabb| Reach { aabb })
            .collect();
        let bvh = (!reaches.is_empty()).then(|| {
            build_bvh2(
                &reaches,
                BvhBuildParams::fast_build(),
                &mut Duration::default(),
            )
        });
        SeamIndex { bvh, triangle_edge }
    }

    /// Whether the index was built for `scene` (as many triangles).
    pub fn fits(&self, scene: &Scene) -> bool {
        self.triangle_edge.len() == scene.triangles.len()
    }

    /// Whether `origin` lies near an edge of a triangle that `own` does not exclude.
    /// `own_edge` is the longest edge of the triangles the origin belongs to, `offset` its
    /// offset δ.
    fn near_foreign_edge(
        &self,
        scene: &Scene,
        origin: Vec3,
        own_edge: f32,
        offset: f32,
        own: impl Fn(u32, [u32; 3]) -> bool,
    ) -> bool {
        let Some(bvh) = &self.bvh else {
            return false;
        };
        let offsets = SEAM_OFFSETS * offset;
        let query = query_box(origin, own_edge, offsets);
        let mut seam = false;
        bvh.aabb_traverse(query, |bvh, node| {
            let node = &bvh.nodes[node as usize];
            let first = node.first_index as usize;
            for &t in &bvh.primitive_indices[first..first + node.prim_count as usize] {
                let triangle = scene.triangles[t as usize];
                if own(t, triangle) {
                    continue;
                }
                if self.within_reach(scene, origin, own_edge, offsets, t) {
                    seam = true;
                }
            }
            !seam
        });
        seam
    }

    /// Whether `origin` lies within the seam radius of an edge of triangle `t` (the test
    /// [`SeamIndex::near_foreign_edge`] makes of each triangle its traversal meets).
    fn within_reach(
        &self,
        scene: &Scene,
        origin: Vec3,
        own_edge: f32,
        offsets: f32,
        t: u32,
    ) -> bool {
        let longest = self.triangle_edge[t as usize].max(own_edge);
        let radius = f64::from((SEAM_RADIUS * longest).max(offsets));
        let p = scene.triangles[t as usize].map(|i| scene.positions[i as usize]);
        (0..3).any(|k| distance_to_segment(origin, p[k], p[(k + 1) % 3]) <= radius)
    }
}

/// The box around `origin` whose overlap with a BVH leaf's box sends that leaf's triangles to
/// the distance test: `origin` ± the larger of [`SEAM_RADIUS`] × `own_edge` and `offsets`.
fn query_box(origin: Vec3, own_edge: f32, offsets: f32) -> Aabb {
    let reach = (SEAM_RADIUS * own_edge).max(offsets);
    Aabb::new(
        Vec3A::from(origin) - Vec3A::splat(reach),
        Vec3A::from(origin) + Vec3A::splat(reach),
    )
}

/// A [`SeamIndex`] built on first use and kept until released: a tracer's, for the points
/// it is asked about ([`crate::trace::Tracer::for_points`]; 50 MB at 720,000 triangles).
#[derive(Default)]
pub struct KeptSeamIndex {
    kept: Mutex<Option<Arc<SeamIndex>>>,
}

impl KeptSeamIndex {
    /// The index of `scene`, built now if not yet; `None` for another scene than it was built
    /// for (as many triangles).
    fn get(&self, scene: &Scene) -> Option<Arc<SeamIndex>> {
        let kept = || self.kept.lock().unwrap_or_else(|e| e.into_inner());
        let existing = kept().clone(); // the guard goes here, not at the match's end
        let index = match existing {
            Some(index) => index,
            // Built without the lock held: its parallel parts may run other work on this
            // thread, which may ask for the index too.
            None => {
                let built = Arc::new(SeamIndex::new(scene));
                kept().get_or_insert(built).clone()
            }
        };
        index.fits(scene).then_some(index)
    }

    /// Builds the index of `scene` now (beside other work).
    pub fn prepare(&self, scene: &Scene) {
        let _ = self.get(scene);
    }

    /// Forgets the index.
    pub fn release(&self) {
        *self.kept.lock().unwrap_or_else(|e| e.into_inner()) = None;
    }

    /// [`seam_points`], with the kept index.
    pub fn seam_points(&self, scene: &Scene, origins: &[Vec3], own: &[u32]) -> Vec<bool> {
        match self.get(scene) {
            Some(index) => index.seam_points(scene, origins, own),
            None => seam_points(scene, origins, own),
        }
    }
}

/// `seam[v]`: whether vertex `v`'s ray origin (`origins[v]`, from [`super::ray_origins`]) lies
/// near an edge of a triangle that does not use `v`.
pub fn seam_vertices(scene: &Scene, origins: &[Vec3]) -> Vec<bool> {
    let index = SeamIndex::new(scene);
    let vertex_edge = vertex_edges(scene, &index.triangle_edge);
    origins
        .par_iter()
        .enumerate()
        .map(|(v, &origin)| {
            let offset = offset_distance(scene.positions[v], vertex_edge[v]);
            index.near_foreign_edge(scene, origin, vertex_edge[v], offset, |_, triangle| {
                triangle.contains(&(v as u32))
            })
        })
        .collect()
}

/// `seam[i]`: whether the ray origin `origins[i]` of a point on triangle `own[i]` (a texel,
/// [`crate::bake::lightmap::texels`]) lies near an edge of any other triangle. The same test as
/// [`seam_vertices`] with the triangles that touch the point's triangle (share a vertex with
/// it) as its own, just as a vertex's own triangles are those that touch it: what lies near a
/// point of a mesh's interior is its own mesh, whose triangles its rays leave on their open
/// side; what lies near a point where meshes meet (a floor's edge against a wall) is foreign.
/// Its offset δ is taken as [`offset_distance`] at the origin for its triangle's edges.
pub fn seam_points(scene: &Scene, origins: &[Vec3], own: &[u32]) -> Vec<bool> {
    SeamIndex::new(scene).seam_points(scene, origins, own)
}

impl SeamIndex {
    /// [`seam_points`] with this index (built for `scene`). The points are taken a triangle at
    /// a time (a texel bake has several per triangle): the BVH is traversed once per triangle,
    /// with the union of its points' query boxes, and keeps each foreign triangle of a leaf it
    /// reaches with that leaf; a point then tests the triangles of the leaves whose box meets
    /// its own query box. Those are exactly the triangles its own traversal would have tested
    /// (a leaf's box lies in its ancestors' boxes, so a leaf meeting the point's box is reached
    /// by both), so the answers are the same, for a sixth of the traversals on a heightfield.
    pub fn seam_points(&self, scene: &Scene, origins: &[Vec3], own: &[u32]) -> Vec<bool> {
        let Some(bvh) = &self.bvh else {
            return vec![false; origins.len()];
        };
        let triangles = self.triangle_edge.len();
        // The points grouped by their triangle (a counting sort, stable); points of a
        // triangle the index does not know are not seam points.
        let mut starts = vec![0u32; triangles + 1];
        for &t in own {
            if let Some(count) = starts.get_mut(t as usize + 1) {
                *count += 1;
            }
        }
        for t in 0..triangles {
            starts[t + 1] += starts[t];
        }
        let mut next = starts.clone();
        let mut order = vec![0u32; starts[triangles] as usize];
        for (k, &t) in own.iter().enumerate() {
            if (t as usize) < triangles {
                order[next[t as usize] as usize] = k as u32;
                next[t as usize] += 1;
            }
        }
        drop(next);
        // Each group's answers, in `order`.
        let grouped: Vec<bool> = (0..triangles)
            .into_par_iter()
            .flat_map_iter(|t| {
                let group = &order[starts[t] as usize..starts[t + 1] as usize];
                self.group_seam_points(scene, bvh, origins, t as u32, group)
            })
            .collect();
        let mut seam = vec![false; origins.len()];
        for (&k, s) in order.iter().zip(grouped) {
            seam[k as usize] = s;
        }
        seam
    }

    /// [`SeamIndex::seam_points`] of the points `group` (indices into `origins`), all on
    /// triangle `t`.
    fn group_seam_points(
        &self,
        scene: &Scene,
        bvh: &obvhs::bvh2::Bvh2,
        origins: &[Vec3],
        t: u32,
        group: &[u32],
    ) -> Vec<bool> {
        if group.is_empty() {
            return Vec::new();
        }
        let own_edge = self.triangle_edge[t as usize];
        let queries: Vec<(Aabb, f32)> = group
            .iter()
            .map(|&k| {
                let origin = origins[k as usize];
                let offsets = SEAM_OFFSETS * offset_distance(origin, own_edge);
                (query_box(origin, own_edge, offsets), offsets)
            })
            .collect();
        let mut union = Aabb::empty();
        for (query, _) in &queries {
            union = union.union(query);
        }
        // (foreign triangle, the leaf it was found in)
        let mine = scene.triangles[t as usize];
        let mut candidates: Vec<(u32, u32)> = Vec::new();
        bvh.aabb_traverse(union, |bvh, index| {
            let node = &bvh.nodes[index as usize];
            let first = node.first_index as usize;
            for &c in &bvh.primitive_indices[first..first + node.prim_count as usize] {
                let other = scene.triangles[c as usize];
                if !other.iter().any(|v| mine.contains(v)) {
                    candidates.push((c, index));
                }
            }
            true
        });
        group
            .iter()
            .zip(&queries)
            .map(|(&k, (query, offsets))| {
                candidates.iter().any(|&(c, leaf)| {
                    bvh.nodes[leaf as usize].aabb().intersect_aabb(query)
                        && self.within_reach(scene, origins[k as usize], own_edge, *offsets, c)
                })
            })
            .collect()
    }

    /// [`seam_points`] one point at a time, each with its own traversal: what
    /// [`SeamIndex::seam_points`] must equal (unit test).
    #[cfg(test)]
    fn seam_points_one_by_one(&self, scene: &Scene, origins: &[Vec3], own: &[u32]) -> Vec<bool> {
        origins
            .iter()
            .zip(own)
            .map(|(&origin, &t)| {
                let Some(&own_edge) = self.triangle_edge.get(t as usize) else {
                    return false;
                };
                let offset = offset_distance(origin, own_edge);
                let mine = scene.triangles[t as usize];
                self.near_foreign_edge(scene, origin, own_edge, offset, |_, other| {
                    other.iter().any(|v| mine.contains(v))
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::scene::{Material, Mesh};
    use crate::trace::ray_origins;

    /// A square grid of `cells` × `cells` cells from `origin` along `u` and `v`.
    fn grid(origin: Vec3, u: Vec3, v: Vec3, cells: u32) -> Mesh {
        let mut positions = Vec::new();
        for j in 0..=cells {
            for i in 0..=cells {
                positions
                    .push(origin + u * (i as f32 / cells as f32) + v * (j as f32 / cells as f32));
            }
        }
        let at = |i: u32, j: u32| j * (cells + 1) + i;
        let mut triangles = Vec::new();
        for j in 0..cells {
            for i in 0..cells {
                triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        Mesh {
            name: "grid".into(),
            positions,
            normals: None,
            uvs: None,
            triangles,
            material: Material::default(),
        }
    }

    #[test]
    fn seam_vertices_are_those_where_a_floor_meets_a_wall() {
        // A floor and a wall, separate meshes meeting along the y axis, and a free-standing
        // board far from both.
        let cells = 8;
        let meshes = vec![
            grid(Vec3::ZERO, Vec3::X, Vec3::Y, cells),
            grid(Vec3::ZERO, Vec3::Y, Vec3::Z, cells),
            grid(Vec3::new(5.0, 0.0, 1.0), Vec3::X, Vec3::Y, cells),
        ];
        let scene = Scene::from_meshes(Path::new("test"), meshes, Vec::new()).expect("valid");
        let seam = seam_vertices(&scene, &ray_origins(&scene));
        for (v, (&seam, p)) in seam.iter().zip(&scene.positions).enumerate() {
            let on_the_corner = v < 2 * 81 && p.x == 0.0 && p.z == 0.0;
            assert_eq!(seam, on_the_corner, "vertex {v} at {p}");
        }
        assert_eq!(
            seam.iter().filter(|&&s| s).count(),
            2 * (cells as usize + 1)
        );
    }

    #[test]
    fn a_kept_index_answers_as_a_fresh_one_and_only_for_its_scene() {
        let room = |cells| {
            let meshes = vec![
                grid(Vec3::ZERO, Vec3::X, Vec3::Y, cells),
                grid(Vec3::ZERO, Vec3::Y, Vec3::Z, cells),
            ];
            Scene::from_meshes(Path::new("test"), meshes, Vec::new()).expect("valid")
        };
        // Each triangle's centroid, and a point near its first edge, as texel origins.
        let points = |scene: &Scene| -> (Vec<Vec3>, Vec<u32>) {
            let mut out = (Vec::new(), Vec::new());
            for (t, tri) in scene.triangles.iter().enumerate() {
                let p = tri.map(|i| scene.positions[i as usize]);
                let centroid = (p[0] + p[1] + p[2]) / 3.0;
                for origin in [centroid, p[0].lerp(p[1], 0.5).lerp(centroid, 1e-4)] {
                    out.0.push(origin);
                    out.1.push(t as u32);
                }
            }
            out
        };
        let kept = KeptSeamIndex::default();
        let check = |scene: &Scene| {
            let (origins, own) = points(scene);
            let fresh = seam_points(scene, &origins, &own);
            assert!(fresh.iter().any(|&s| s) && !fresh.iter().all(|&s| s));
            // Built by the first call (or another scene's, not used), kept for the second.
            assert_eq!(kept.seam_points(scene, &origins, &own), fresh);
            assert_eq!(kept.seam_points(scene, &origins, &own), fresh);
        };
        let (large, small) = (room(8), room(5));
        check(&large);
        check(&small); // the large room's index is kept: not for this one
        kept.release();
        kept.prepare(&small);
        check(&small);
    }

    #[test]
    fn points_taken_a_triangle_at_a_time_answer_as_one_at_a_time() {
        // A floor, a wall meeting it, and a box standing on the floor: many seam points.
        let meshes = vec![
            grid(Vec3::ZERO, Vec3::X, Vec3::Y, 12),
            grid(Vec3::ZERO, Vec3::Y, Vec3::Z, 12),
            grid(Vec3::new(0.3, 0.3, 0.0), Vec3::Y * 0.4, Vec3::Z * 0.4, 5),
            grid(Vec3::new(0.3, 0.3, 0.0), Vec3::X * 0.4, Vec3::Z * 0.4, 5),
        ];
        let scene = Scene::from_meshes(Path::new("test"), meshes, Vec::new()).expect("valid");
        // Points over every triangle (anywhere, and every other round near its first edge),
        // eight rounds over the triangles, so that a triangle's points are not together; and
        // one on a triangle the index does not know.
        let (mut origins, mut own) = (Vec::new(), Vec::new());
        let mut rng = crate::math::sampling::Pcg32::new(7, 1);
        for round in 0..8 {
            for (t, tri) in scene.triangles.iter().enumerate().rev() {
                let p = tri.map(|i| scene.positions[i as usize]);
                let (a, mut b) = (rng.next_f32(), rng.next_f32());
                if round % 2 == 1 {
                    b *= 0.01; // near the first edge
                }
                let (a, b) = if a + b > 1.0 {
                    (1.0 - a, 1.0 - b)
                } else {
                    (a, b)
                };
                let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
                let q = p[0] + (p[1] - p[0]) * a + (p[2] - p[0]) * b;
                origins.push(q + normal * offset_distance(q, 1.0));
                own.push(t as u32);
            }
        }
        origins.push(Vec3::ZERO);
        own.push(u32::MAX);
        let index = SeamIndex::new(&scene);
        let one_by_one = index.seam_points_one_by_one(&scene, &origins, &own);
        let seam = one_by_one.iter().filter(|&&s| s).count();
        assert!(seam > 30 && seam < origins.len() / 2, "{seam} seam points");
        assert_eq!(index.seam_points(&scene, &origins, &own), one_by_one);
    }
}
