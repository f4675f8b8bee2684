//! Which vertices are embedded in other geometry ([`Embedded`]), for the bounce rows of a
//! vertex bake ([`crate::bake::bounce_rows`]).

use std::sync::atomic::{AtomicU8, Ordering};

use glam::Vec3;

use crate::bake::lightmap::leaks::{LEAK_FRACTION, LEAK_RAYS, SCREEN_RAYS, leaks_at};
use crate::bake::receivers::BounceTargets;
use crate::math::sampling::{Pcg32, vertex_seed};
use crate::scene::Scene;
use crate::trace::Tracer;

/// Closest-hit rays of a vertex's embedding test (cosine-weighted over its hemisphere), as
/// many as a texel's leak test casts (`lightmap::leaks`).
pub const EMBEDDING_RAYS: usize = LEAK_RAYS;
/// A vertex is embedded when more than this fraction of its test rays hit back faces.
pub const EMBEDDING_FRACTION: f32 = LEAK_FRACTION;
/// The first rays of the test, traced alone: a vertex none of whose first 16 rays hits a
/// back face is taken to be open without the other 48 (most vertices).
pub const EMBEDDING_SCREEN_RAYS: usize = SCREEN_RAYS;

/// Vertex bakes: which vertices are **embedded** — inside or behind other geometry (a floor
/// vertex under a box, a wall board's corner beyond the wall it meets), so that their own
/// transfer is not the light at the surface a bounce hit near them lands on. Like a leaking
/// texel (`lightmap::leaks`), a vertex is embedded when more than [`EMBEDDING_FRACTION`] of
/// [`EMBEDDING_RAYS`] cosine-weighted closest-hit rays from its ray origin hit back faces.
///
/// A bounce hit on a triangle reads the previous bounce at the triangle's corners; an
/// embedded corner's value (0 inside a box, the sky's light outside a room) is left out and
/// the open corners' barycentric weights are renormalised to sum to 1 (where all three are
/// embedded, the hit reads them as before: nothing better is known). Without this, a floor
/// triangle running under a box read the box's inside (zero) along the lit strip in front of
/// it, and overlapping boards read the sky from outside the room.
///
/// Each vertex is tested the first time a hit needs it (most vertices never are: only the
/// corners of hit triangles), from its own random stream, so the answer is a pure function of
/// (seed, vertex) and the bake stays bit-identical for any thread count, shard split or
/// re-trace; racing threads compute the same answer.
pub struct Embedded {
    /// Per slot: 0 untested, 1 open, 2 embedded. Empty for texel targets.
    state: Vec<AtomicU8>,
    /// Per triangle: 0 untested, 1 every corner open (most: a hit then costs one load), 2 some
    /// corner embedded. Empty for texel targets.
    triangles: Vec<AtomicU8>,
}

impl Embedded {
    /// Untested state for every vertex of `scene` if `targets` are its vertices; nothing
    /// otherwise (texels have their own leak test, before the bake).
    pub(crate) fn new(scene: &Scene, targets: &BounceTargets) -> Embedded {
        let (vertices, triangles) = match targets {
            BounceTargets::Vertices => (scene.vertex_count(), scene.triangles.len()),
            BounceTargets::Texels(_) => (0, 0),
        };
        let untested = |count| (0..count).map(|_| AtomicU8::new(0)).collect();
        Embedded {
            state: untested(vertices),
            triangles: untested(triangles),
        }
    }

    /// Whether a corner of `triangle` (with corners `corners`) is embedded.
    pub(crate) fn has_embedded_corner(
        &self,
        triangle: u32,
        corners: [u32; 3],
        probe: &CornerProbe,
    ) -> bool {
        let state = &self.triangles[triangle as usize];
        match state.load(Ordering::Relaxed) {
            1 => false,
            2 => true,
            _ => {
                let any = corners.iter().any(|&v| self.is_embedded(v, probe));
                state.store(if any { 2 } else { 1 }, Ordering::Relaxed);
                any
            }
        }
    }

    /// A vertex hit's corner weights with the embedded corners left out and the others
    /// renormalised to sum to 1 (equal, if the hit lies on the embedded corners' edge);
    /// unchanged where no corner or every corner is embedded.
    pub(crate) fn skip_embedded(&self, slots: &mut [(u32, f32)], probe: &CornerProbe) {
        let mut open = [true; 4];
        for (open, &(vertex, _)) in open.iter_mut().zip(slots.iter()) {
            *open = !self.is_embedded(vertex, probe);
        }
        let open = &open[..slots.len()];
        let count = open.iter().filter(|&&o| o).count();
        if count == 0 || count == slots.len() {
            return;
        }
        let sum: f32 = slots
            .iter()
            .zip(open)
            .filter(|(_, o)| **o)
            .map(|(s, _)| s.1)
            .sum();
        for (slot, &o) in slots.iter_mut().zip(open) {
            slot.1 = match (o, sum > 0.0) {
                (false, _) => 0.0,
                (true, true) => slot.1 / sum,
                (true, false) => 1.0 / count as f32,
            };
        }
    }

    /// Whether vertex `v` is embedded, testing it with `probe` on first use.
    fn is_embedded(&self, v: u32, probe: &CornerProbe) -> bool {
        let state = &self.state[v as usize];
        match state.load(Ordering::Relaxed) {
            1 => false,
            2 => true,
            _ => {
                let embedded = probe.embedded(v as usize);
                state.store(if embedded { 2 } else { 1 }, Ordering::Relaxed);
                embedded
            }
        }
    }
}

/// What the embedding test of a vertex needs: the tracer, and the vertices' ray origins and
/// normals (the estimator's receivers, in a vertex bake).
pub(crate) struct CornerProbe<'t> {
    pub tracer: &'t dyn Tracer,
    pub origins: &'t [Vec3],
    pub normals: &'t [Vec3],
    pub seed: u64,
}

impl CornerProbe<'_> {
    /// Whether more than [`EMBEDDING_FRACTION`] of [`EMBEDDING_RAYS`] cosine-distributed rays
    /// from vertex `v`'s origin hit back faces (by the geometric normal, as the texel leak
    /// test decides). Directions come from the vertex's own stream, apart from its samples.
    fn embedded(&self, v: usize) -> bool {
        let mut rng = Pcg32::new(vertex_seed(self.seed, v as u64), 0xc0_1eaf);
        leaks_at(self.origins[v], self.normals[v], self.tracer, &mut rng)
    }
}
