//! Ray casting behind one trait, so the baker does not care which BVH answers.
//!
//! Backends: [`EmbreeTracer`] (default, needs the `embree` feature). Every backend answers the
//! same two questions for batches of rays: is the segment blocked, and what does it hit first.
//! Batches let a backend use its fast paths (Embree's ray streams).

#[cfg(feature = "embree")]
mod embree;
mod offset;

#[cfg(feature = "embree")]
pub use embree::{EmbreeOptions, EmbreeTracer};
pub use offset::{offset_distance, ray_origins};

use glam::Vec3;

#[cfg(not(feature = "embree"))]
use crate::error::Error;
use crate::error::Result;
use crate::scene::Scene;

/// A ray segment `origin + t·dir`, t in `[0, tfar]`. Self-intersection is avoided by where the
/// origin is put ([`ray_origins`]), not by a minimum t.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tfar: f32,
}

/// The closest hit of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Index into `Scene::triangles`.
    pub triangle: u32,
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
}

impl Backend {
    pub fn name(self) -> &'static str {
        match self {
            Backend::None => "none",
            Backend::Embree => "embree",
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
        let rays: Vec<Ray> = dirs
            .iter()
            .map(|&dir| Ray {
                origin,
                dir,
                tfar: f32::INFINITY,
            })
            .collect();
        self.occluded(&rays, occluded);
    }

    /// `hits[i]` = the closest hit of `rays[i]`, if any. The slices have equal lengths.
    fn intersect(&self, rays: &[Ray], hits: &mut [Option<Hit>]);

    /// Closest hits of unbounded rays that share one origin. Same answers as
    /// [`Tracer::intersect`].
    fn intersect_from(&self, origin: Vec3, dirs: &[Vec3], hits: &mut [Option<Hit>]) {
        let rays: Vec<Ray> = dirs
            .iter()
            .map(|&dir| Ray {
                origin,
                dir,
                tfar: f32::INFINITY,
            })
            .collect();
        self.intersect(&rays, hits);
    }
}

/// The default tracer this build offers for `scene`; `threads` limits the backend's own
/// worker threads (BVH build) where it has any, `robust` asks for its most careful mode.
pub fn default_tracer(
    scene: &Scene,
    threads: Option<usize>,
    robust: bool,
) -> Result<Box<dyn Tracer>> {
    #[cfg(feature = "embree")]
    {
        Ok(Box::new(EmbreeTracer::new(
            scene,
            EmbreeOptions { threads, robust },
        )?))
    }
    #[cfg(not(feature = "embree"))]
    {
        let _ = (scene, threads, robust);
        Err(Error::Tracer {
            backend: "none",
            message: "this build has no ray-tracing backend (rebuild with the `embree` feature)"
                .into(),
        })
    }
}
