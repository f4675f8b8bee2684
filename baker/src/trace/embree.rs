//! The Embree backend, through our `embree-sys` bindings.

use std::cell::RefCell;

use embree_sys::{BuildQuality, CommittedScene, Device, SceneBuilder, SceneFlags};

use super::{Backend, Hit, Ray, Tracer};
use crate::error::{Error, Result};
use crate::scene::Scene;

/// Rays handed to Embree per stream call: large enough for Embree to form full packets and
/// amortise the call, small enough to stay in L1 (48 bytes each).
const STREAM: usize = 256;

thread_local! {
    /// Each thread's ray stream, allocated once: initialising a fresh buffer per call would
    /// cost as much memory traffic as writing the rays.
    static OCCLUSION_STREAM: RefCell<Vec<embree_sys::Ray>> =
        RefCell::new(vec![embree_sys::Ray::default(); STREAM]);
    static INTERSECTION_STREAM: RefCell<Vec<embree_sys::RayHit>> =
        RefCell::new(vec![embree_sys::RayHit::new(embree_sys::Ray::default()); STREAM]);
}

fn to_hit(hit: embree_sys::Hit) -> Hit {
    Hit {
        triangle: hit.prim_id,
        u: hit.u,
        v: hit.v,
        t: hit.t,
        ng: glam::Vec3::from_array(hit.ng),
    }
}

pub struct EmbreeTracer {
    scene: CommittedScene,
}

/// How the Embree scene is built.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EmbreeOptions {
    /// Embree worker threads for the BVH build (default: all cores).
    pub threads: Option<usize>,
    /// Embree's robust mode (`RTC_SCENE_FLAG_ROBUST`): no accuracy-reducing optimisations.
    /// Off by default: on the demo scene it costs about 30 % of the ray rate, and the
    /// agreement tests against an independent tracer pass without it.
    pub robust: bool,
}

fn tracer_error(err: embree_sys::Error) -> Error {
    Error::Tracer {
        backend: "embree",
        message: err.to_string(),
    }
}

impl EmbreeTracer {
    /// Builds a high-quality BVH: a bake casts millions of rays per second of build time.
    pub fn new(scene: &Scene, options: EmbreeOptions) -> Result<EmbreeTracer> {
        let config = options
            .threads
            .map(|t| format!("threads={t}"))
            .unwrap_or_default();
        let device = Device::with_config(&config).map_err(tracer_error)?;
        let mut builder = SceneBuilder::new(&device).map_err(tracer_error)?;
        builder.set_build_quality(BuildQuality::High);
        builder.set_flags(SceneFlags {
            robust: options.robust,
            compact: false,
        });
        let positions: Vec<[f32; 3]> = scene.positions.iter().map(|p| p.to_array()).collect();
        builder
            .add_triangle_mesh(&positions, &scene.triangles)
            .map_err(tracer_error)?;
        Ok(EmbreeTracer {
            scene: builder.commit().map_err(tracer_error)?,
        })
    }

    /// The committed Embree scene, for benchmarks that call Embree directly.
    pub fn embree_scene(&self) -> &CommittedScene {
        &self.scene
    }
}

impl Tracer for EmbreeTracer {
    fn backend(&self) -> Backend {
        Backend::Embree
    }

    fn occluded(&self, rays: &[Ray], occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len());
        OCCLUSION_STREAM.with_borrow_mut(|stream| {
            for (rays, occluded) in rays.chunks(STREAM).zip(occluded.chunks_mut(STREAM)) {
                let stream = &mut stream[..rays.len()];
                for (slot, r) in stream.iter_mut().zip(rays) {
                    *slot =
                        embree_sys::Ray::new(r.origin.to_array(), r.dir.to_array(), 0.0, r.tfar);
                }
                self.scene.occluded_stream(stream);
                for (o, r) in occluded.iter_mut().zip(stream.iter()) {
                    *o = r.is_occluded();
                }
            }
        });
    }

    fn occluded_from(&self, origin: glam::Vec3, dirs: &[glam::Vec3], occluded: &mut [bool]) {
        assert_eq!(dirs.len(), occluded.len());
        let origin = origin.to_array();
        OCCLUSION_STREAM.with_borrow_mut(|stream| {
            for (dirs, occluded) in dirs.chunks(STREAM).zip(occluded.chunks_mut(STREAM)) {
                let stream = &mut stream[..dirs.len()];
                for (slot, d) in stream.iter_mut().zip(dirs) {
                    *slot = embree_sys::Ray::new(origin, d.to_array(), 0.0, f32::INFINITY);
                }
                self.scene.occluded_stream(stream);
                for (o, r) in occluded.iter_mut().zip(stream.iter()) {
                    *o = r.is_occluded();
                }
            }
        });
    }

    fn intersect(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len());
        INTERSECTION_STREAM.with_borrow_mut(|stream| {
            for (rays, hits) in rays.chunks(STREAM).zip(hits.chunks_mut(STREAM)) {
                let stream = &mut stream[..rays.len()];
                for (slot, r) in stream.iter_mut().zip(rays) {
                    let ray =
                        embree_sys::Ray::new(r.origin.to_array(), r.dir.to_array(), 0.0, r.tfar);
                    *slot = embree_sys::RayHit::new(ray);
                }
                self.scene.intersect_stream(stream);
                for (h, rh) in hits.iter_mut().zip(stream.iter()) {
                    *h = rh.hit().map(to_hit);
                }
            }
        });
    }

    fn intersect_from(&self, origin: glam::Vec3, dirs: &[glam::Vec3], hits: &mut [Option<Hit>]) {
        assert_eq!(dirs.len(), hits.len());
        let origin = origin.to_array();
        INTERSECTION_STREAM.with_borrow_mut(|stream| {
            for (dirs, hits) in dirs.chunks(STREAM).zip(hits.chunks_mut(STREAM)) {
                let stream = &mut stream[..dirs.len()];
                for (slot, d) in stream.iter_mut().zip(dirs) {
                    let ray = embree_sys::Ray::new(origin, d.to_array(), 0.0, f32::INFINITY);
                    *slot = embree_sys::RayHit::new(ray);
                }
                self.scene.intersect_stream(stream);
                for (h, rh) in hits.iter_mut().zip(stream.iter()) {
                    *h = rh.hit().map(to_hit);
                }
            }
        });
    }
}
