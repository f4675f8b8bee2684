//! What every backend implements: the [`Tracer`] trait, its rays and hits, and the names of
//! the backends. Kept apart from the backends themselves so that they import it, not the
//! module that builds them.

use glam::Vec3;

use crate::scene::Scene;

use crate::support::error::Result;

/// A ray segment `origin + t·dir`, t in `[0, tfar]`. (A hit at exactly t = 0 — an origin on a
/// surface — counts for obvhs and Embree's robust mode, not for Embree's default mode.)
/// Self-intersection is avoided by where the origin is put ([`super::ray_origins`]), not by a
/// minimum t.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tfar: f32,
}

impl Ray {
    /// Unbounded rays from `origin` along each of `dirs`: a vertex's rays.
    pub fn fan(origin: Vec3, dirs: &[Vec3]) -> Vec<Ray> {
        dirs.iter()
            .map(|&dir| Ray {
                origin,
                dir,
                tfar: f32::INFINITY,
            })
            .collect()
    }
}

/// The closest hit of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Index into `Scene::triangles`, or for a hit on an instance, into its mesh's triangles.
    pub triangle: u32,
    /// The placement hit (`Scene::instances`), or `None` for the scene's own triangles. Only
    /// occluders are instanced, so passes that read a hit's material never meet one; `u`,
    /// `v` are then in the instance mesh's triangle, `t` and `ng` in world space.
    pub instance: Option<u32>,
    /// Barycentrics: hit = (1 − u − v)·v0 + u·v1 + v·v2.
    pub u: f32,
    pub v: f32,
    /// Distance along the ray in units of `dir`'s length.
    pub t: f32,
    /// Unnormalised geometric normal (v1 − v0) × (v2 − v0): it tells front from back faces.
    pub ng: Vec3,
}

/// Which tracer produced a bake (recorded in the coefficient file).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// No rays were cast (unshadowed transfer).
    None,
    Embree,
    Obvhs,
}

impl Backend {
    /// The backend a bake uses unless told otherwise: Embree where this build has it (it is
    /// about three times faster), obvhs otherwise.
    pub const DEFAULT: Backend = if cfg!(feature = "embree") {
        Backend::Embree
    } else {
        Backend::Obvhs
    };

    pub fn name(self) -> &'static str {
        match self {
            Backend::None => "none",
            Backend::Embree => "embree",
            Backend::Obvhs => "obvhs",
        }
    }
}

/// A ray caster over one static scene. Implementations are shared by all bake threads.
pub trait Tracer: Send + Sync {
    fn backend(&self) -> Backend;

    /// `occluded[i]` = whether anything blocks `rays[i]`. The slices have equal lengths.
    fn occluded(&self, rays: &[Ray], occluded: &mut [bool]);

    /// Occlusion of unbounded rays that share one origin (all of a vertex's rays do), so a
    /// backend can skip building general rays. Same answers as [`Tracer::occluded`].
    fn occluded_from(&self, origin: Vec3, dirs: &[Vec3], occluded: &mut [bool]) {
        self.occluded(&Ray::fan(origin, dirs), occluded);
    }

    /// `hits[i]` = the closest hit of `rays[i]`, if any. The slices have equal lengths.
    fn intersect(&self, rays: &[Ray], hits: &mut [Option<Hit>]);

    /// Closest hits of unbounded rays that share one origin. Same answers as
    /// [`Tracer::intersect`].
    fn intersect_from(&self, origin: Vec3, dirs: &[Vec3], hits: &mut [Option<Hit>]) {
        self.intersect_within(origin, dirs, f32::INFINITY, hits);
    }

    /// Closest hits of rays that share one origin and end at `tfar` (a hit beyond it is
    /// none): where the answer only matters near the origin (the leak test's screen), a
    /// short ray costs a fraction of an unbounded one. Same answers as [`Tracer::intersect`].
    fn intersect_within(&self, origin: Vec3, dirs: &[Vec3], tfar: f32, hits: &mut [Option<Hit>]) {
        let rays: Vec<Ray> = dirs.iter().map(|&dir| Ray { origin, dir, tfar }).collect();
        self.intersect(&rays, hits);
    }

    /// Builds now, on the calling thread, what [`Tracer::for_points`] will need for `scene`
    /// and keep (Embree's seam index), so a caller can build it beside other work. A hint:
    /// `for_points` builds it when not done.
    fn prepare_points(&self, scene: &Scene) {
        let _ = scene;
    }

    /// Frees what [`Tracer::prepare_points`] or [`Tracer::for_points`] kept, once no more
    /// points will be asked about (the texel bake's peak of memory comes later).
    fn release_points(&self) {}

    /// A tracer for rays from receivers that are not `scene`'s vertices (texels):
    /// `origins[i]`, the ray origin of a point on triangle `own[i]`. Embree's watertight mode
    /// picks robust mode by ray origin ([`seams`]), so it needs to know which of these are
    /// seam points; backends whose answers do not depend on the origin answer `None` (trace
    /// with `self`).
    fn for_points<'s>(
        &'s self,
        scene: &Scene,
        origins: &[Vec3],
        own: &[u32],
    ) -> Result<Option<Box<dyn Tracer + 's>>> {
        match self.seam_points(scene, origins, own) {
            Some(seam) => self.for_seam_points(scene, origins, &seam),
            None => Ok(None),
        }
    }

    /// Which of `origins` (as [`Tracer::for_points`] takes them) are seam points, for a
    /// backend that routes rays by origin; `None` for the others. A pure function of the
    /// scene and the points, so a texel bake's shards read it from the prepared lightmap
    /// instead of each building the seam index again.
    fn seam_points(&self, scene: &Scene, origins: &[Vec3], own: &[u32]) -> Option<Vec<bool>> {
        let _ = (scene, origins, own);
        None
    }

    /// [`Tracer::for_points`] where [`Tracer::seam_points`] is known already (`seam[i]` for
    /// `origins[i]`).
    fn for_seam_points<'s>(
        &'s self,
        scene: &Scene,
        origins: &[Vec3],
        seam: &[bool],
    ) -> Result<Option<Box<dyn Tracer + 's>>> {
        let _ = (scene, origins, seam);
        Ok(None)
    }
}

/// Settings a backend may honour when it builds its acceleration structure.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TracerOptions {
    /// Limits the backend's own worker threads (Embree's BVH build); obvhs builds on the
    /// calling thread.
    pub threads: Option<usize>,
    /// Embree's robust mode for every ray (by default only the rays of seam vertices, where
    /// the default mode leaks, use it: [`EmbreeMode::Watertight`]). Only Embree has one:
    /// asking another backend for it is an error rather than a silent no-op.
    pub robust: bool,
    /// No ray leaves a scene vertex (texel bakes: every ray starts at a texel, whose seam
    /// points [`Tracer::for_points`] finds). Embree's watertight mode then skips finding the
    /// seam vertices (a third of its build time on a large mesh) and builds its robust scene
    /// only when some point needs it.
    pub points_only: bool,
    /// Rays the bake casts per receiver (0: unknown, counted as few): Embree builds its BVH at high quality
    /// (spatial splits) only when they are many enough to repay it (`embree.rs`'s module doc).
    /// The output does not depend on it but at exact ties of t.
    pub rays_per_receiver: u32,
}
