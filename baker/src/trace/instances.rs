//! Instances for a backend without its own (obvhs): one tracer per distinct mesh, in its
//! own space, and a top-level binary BVH over the placements' world boxes. A ray that enters a placement's box
//! is taken into the mesh's space (origin and direction by the inverse transform, so the ray
//! parameter t, and `tfar`, mean the same distance) and traced in the mesh's BVH.

use glam::{Affine3A, Vec3};

use crate::scene::{InstanceMesh, Instances, world_normal};
use crate::trace::tracer::{Hit, Ray, Tracer};

/// Placements per leaf of the top-level BVH.
const LEAF: usize = 4;

/// A node of the top-level BVH: its box, and either two children or a run of placements.
struct Node {
    lo: Vec3,
    hi: Vec3,
    /// Leaf: `placements[start..start + count]` of [`TopLevel::order`]; inner: children
    /// `start` and `start + 1` (`count` = 0).
    start: u32,
    count: u32,
}

/// One placement, ready to take rays into its mesh's space.
struct Placed {
    mesh: u32,
    to_world: Affine3A,
    to_mesh: Affine3A,
}

pub(crate) struct TopLevel<T> {
    /// A tracer per distinct mesh, over the mesh in its own space.
    meshes: Vec<T>,
    placed: Vec<Placed>,
    nodes: Vec<Node>,
    /// Placement indices in leaf order.
    order: Vec<u32>,
}

impl<T: Tracer> TopLevel<T> {
    /// The top level over `instances`, `tracer` building each mesh's tracer.
    pub(crate) fn new(instances: &Instances, tracer: impl Fn(&InstanceMesh) -> T) -> TopLevel<T> {
        let meshes = instances.meshes.iter().map(tracer).collect();
        let placed = instances
            .placements
            .iter()
            .map(|p| Placed {
                mesh: p.mesh,
                to_world: p.to_world,
                to_mesh: p.to_world.inverse(),
            })
            .collect();
        let boxes: Vec<(Vec3, Vec3)> = (0..instances.placements.len())
            .map(|p| {
                let (lo, hi) = instances.bounds(p);
                // A margin for the rounding of the transforms: a box must never cut off a
                // triangle the mesh's own traversal would hit.
                let margin =
                    (hi - lo).max_element() * 1e-5 + 1e-6 * hi.abs().max(lo.abs()).max_element();
                (lo - margin, hi + margin)
            })
            .collect();
        let mut top = TopLevel {
            meshes,
            placed,
            nodes: Vec::new(),
            order: (0..boxes.len() as u32).collect(),
        };
        top.nodes.push(Node {
            lo: Vec3::ZERO,
            hi: Vec3::ZERO,
            start: 0,
            count: 0,
        });
        top.build(0, 0, boxes.len(), &boxes);
        top
    }

    /// Fills node `at` over `order[start..end]`: a leaf of up to [`LEAF`] placements, else
    /// split at the median of the box centres along their widest axis.
    fn build(&mut self, at: usize, start: usize, end: usize, boxes: &[(Vec3, Vec3)]) {
        let (lo, hi) = self.order[start..end]
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(boxes[p as usize].0), hi.max(boxes[p as usize].1))
            });
        let centre = |p: u32| boxes[p as usize].0 + boxes[p as usize].1;
        if end - start <= LEAF {
            self.nodes[at] = Node {
                lo,
                hi,
                start: start as u32,
                count: (end - start) as u32,
            };
            return;
        }
        let (clo, chi) = self.order[start..end]
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(centre(p)), hi.max(centre(p)))
            });
        let axis = (chi - clo).max_position();
        let mid = (start + end) / 2;
        self.order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
            centre(a)[axis].total_cmp(&centre(b)[axis])
        });
        let first = self.nodes.len();
        for _ in 0..2 {
            self.nodes.push(Node {
                lo: Vec3::ZERO,
                hi: Vec3::ZERO,
                start: 0,
                count: 0,
            });
        }
        self.nodes[at] = Node {
            lo,
            hi,
            start: first as u32,
            count: 0,
        };
        self.build(first, start, mid, boxes);
        self.build(first + 1, mid, end, boxes);
    }

    /// Calls `visit` with every placement whose box `ray` enters within `[0, tfar()]`, until
    /// it returns true; `tfar` is read at each box, so a closest-hit search can shrink it.
    fn visit(&self, ray: &Ray, tfar: impl Fn() -> f32, mut visit: impl FnMut(u32) -> bool) {
        let inverse = ray.dir.recip();
        let enters = |node: &Node| {
            let a = (node.lo - ray.origin) * inverse;
            let b = (node.hi - ray.origin) * inverse;
            // NaN (0 × ∞, a ray in a box's plane) counts as entering: boxes are a filter,
            // the mesh's own traversal decides.
            let near = a.min(b).max_element();
            let far = a.max(b).min_element();
            !(near > far || far < 0.0 || near > tfar())
        };
        // Median splits make the tree at most log2(placements) + 1 deep, and the stack holds
        // at most one node per level and one more: 64 levels is more than any count of
        // placements that fits in memory. No allocation per ray.
        let mut stack = [0u32; 64];
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let node = &self.nodes[stack[depth] as usize];
            if !enters(node) {
                continue;
            }
            if node.count == 0 {
                stack[depth] = node.start;
                stack[depth + 1] = node.start + 1;
                depth += 2;
                continue;
            }
            for &p in &self.order[node.start as usize..(node.start + node.count) as usize] {
                if visit(p) {
                    return;
                }
            }
        }
    }

    fn local(&self, p: u32, ray: &Ray, tfar: f32) -> Ray {
        let placed = &self.placed[p as usize];
        Ray {
            origin: placed.to_mesh.transform_point3(ray.origin),
            dir: placed.to_mesh.transform_vector3(ray.dir),
            tfar,
        }
    }

    /// Whether any instance blocks `ray`.
    pub(crate) fn occluded(&self, ray: &Ray) -> bool {
        let mut blocked = false;
        self.visit(
            ray,
            || ray.tfar,
            |p| {
                let mut one = [false];
                let mesh = &self.meshes[self.placed[p as usize].mesh as usize];
                mesh.occluded(&[self.local(p, ray, ray.tfar)], &mut one);
                blocked = one[0];
                blocked
            },
        );
        blocked
    }

    /// The closest instance hit of `ray` within its `tfar`.
    pub(crate) fn closest_hit(&self, ray: &Ray) -> Option<Hit> {
        let best = std::cell::Cell::new(None::<Hit>);
        let tfar = || best.get().map_or(ray.tfar, |h| h.t);
        self.visit(ray, tfar, |p| {
            let placed = &self.placed[p as usize];
            let mut one = [None];
            let mesh = &self.meshes[placed.mesh as usize];
            mesh.intersect(&[self.local(p, ray, tfar())], &mut one);
            if let Some(hit) = one[0] {
                best.set(Some(Hit {
                    instance: Some(p),
                    ng: world_normal(&placed.to_world, hit.ng),
                    ..hit
                }));
            }
            false
        });
        best.get()
    }
}
