//! The Embree backend, through our `embree-sys` bindings.

use std::cell::RefCell;
use std::collections::HashSet;

use embree_sys::{BuildQuality, CommittedScene, Device, SceneBuilder, SceneFlags};

use super::seams::seam_vertices;
use super::{Backend, Hit, Ray, Tracer, ray_origins};
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

/// The key of a ray origin in [`Seams::origins`]: its exact bits.
fn origin_key(origin: glam::Vec3) -> [u32; 3] {
    origin.to_array().map(f32::to_bits)
}

pub struct EmbreeTracer {
    /// The scene most rays are traced in: default mode, or robust mode with
    /// [`EmbreeMode::Robust`].
    scene: CommittedScene,
    /// With [`EmbreeMode::Watertight`], where the rays of seam vertices go.
    seams: Option<Seams>,
}

/// The robust-mode scene over the same geometry, and the ray origins traced in it.
struct Seams {
    robust: CommittedScene,
    /// The bit patterns of the seam vertices' ray origins ([`super::seams`]).
    origins: HashSet<[u32; 3]>,
}

/// Which rays Embree traces in its robust mode.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EmbreeMode {
    /// Robust mode for the rays that leave a seam vertex (a vertex near another triangle's
    /// edge, [`super::seams`]), the default mode for all others. The default: watertight
    /// answers at nearly the default mode's speed, because only the seam vertices' rays can
    /// leak through the default mode's cracks.
    #[default]
    Watertight,
    /// Robust mode (`RTC_SCENE_FLAG_ROBUST`: no accuracy-reducing optimisations) for every
    /// ray: `--robust`. About 30 % slower on the demo scene.
    Robust,
    /// Embree's default mode for every ray: the fastest, but it leaks light through the
    /// seams where meshes meet (the baker's default before issue 12). For benchmarks and the
    /// agreement tests.
    Fast,
}

/// How the Embree scene is built.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EmbreeOptions {
    /// Embree worker threads for the BVH build (default: all cores).
    pub threads: Option<usize>,
    /// Which rays are traced in robust mode.
    pub mode: EmbreeMode,
}

fn tracer_error(err: embree_sys::Error) -> Error {
    Error::Tracer {
        backend: "embree",
        message: err.to_string(),
    }
}

impl EmbreeTracer {
    /// Builds a high-quality BVH: a bake casts millions of rays per second of build time.
    /// With [`EmbreeMode::Watertight`], a second, robust one where the scene has seam
    /// vertices.
    pub fn new(scene: &Scene, options: EmbreeOptions) -> Result<EmbreeTracer> {
        let config = options
            .threads
            .map(|t| format!("threads={t}"))
            .unwrap_or_default();
        let device = Device::with_config(&config).map_err(tracer_error)?;
        let positions: Vec<[f32; 3]> = scene.positions.iter().map(|p| p.to_array()).collect();
        let commit = |robust: bool| -> Result<CommittedScene> {
            let mut builder = SceneBuilder::new(&device).map_err(tracer_error)?;
            builder.set_build_quality(BuildQuality::High);
            builder.set_flags(SceneFlags {
                robust,
                compact: false,
            });
            builder
                .add_triangle_mesh(&positions, &scene.triangles)
                .map_err(tracer_error)?;
            builder.commit().map_err(tracer_error)
        };
        let seams = match options.mode {
            EmbreeMode::Watertight => {
                let origins = ray_origins(scene);
                let seam = seam_vertices(scene, &origins);
                let origins: HashSet<[u32; 3]> = origins
                    .iter()
                    .zip(&seam)
                    .filter(|&(_, &seam)| seam)
                    .map(|(o, _)| origin_key(*o))
                    .collect();
                if origins.is_empty() {
                    None
                } else {
                    Some(Seams {
                        robust: commit(true)?,
                        origins,
                    })
                }
            }
            EmbreeMode::Robust | EmbreeMode::Fast => None,
        };
        Ok(EmbreeTracer {
            scene: commit(options.mode == EmbreeMode::Robust)?,
            seams,
        })
    }

    /// How many distinct ray origins are traced in robust mode by [`EmbreeMode::Watertight`]
    /// (0 in the other modes).
    pub fn seam_origin_count(&self) -> usize {
        self.seams.as_ref().map_or(0, |s| s.origins.len())
    }

    /// The scene that traces rays from `origin`.
    fn scene_for(&self, origin: [f32; 3]) -> &CommittedScene {
        match &self.seams {
            Some(seams) if seams.origins.contains(&origin.map(f32::to_bits)) => &seams.robust,
            _ => &self.scene,
        }
    }

    /// `rays` split into runs of consecutive rays traced in the same scene.
    fn runs<'a>(
        &'a self,
        rays: &'a [Ray],
    ) -> impl Iterator<Item = (std::ops::Range<usize>, &'a CommittedScene)> + 'a {
        let mut start = 0;
        std::iter::from_fn(move || {
            let first = rays.get(start)?;
            let scene = self.scene_for(first.origin.to_array());
            let len = rays[start..]
                .iter()
                .take_while(|r| std::ptr::eq(self.scene_for(r.origin.to_array()), scene))
                .count();
            let range = start..start + len;
            start = range.end;
            Some((range, scene))
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
        for (run, scene) in self.runs(rays) {
            occluded_in(scene, &rays[run.clone()], &mut occluded[run]);
        }
    }

    fn occluded_from(&self, origin: glam::Vec3, dirs: &[glam::Vec3], occluded: &mut [bool]) {
        assert_eq!(dirs.len(), occluded.len());
        let origin = origin.to_array();
        let scene = self.scene_for(origin);
        OCCLUSION_STREAM.with_borrow_mut(|stream| {
            for (dirs, occluded) in dirs.chunks(STREAM).zip(occluded.chunks_mut(STREAM)) {
                let stream = &mut stream[..dirs.len()];
                for (slot, d) in stream.iter_mut().zip(dirs) {
                    *slot = embree_sys::Ray::new(origin, d.to_array(), 0.0, f32::INFINITY);
                }
                scene.occluded_stream(stream);
                for (o, r) in occluded.iter_mut().zip(stream.iter()) {
                    *o = r.is_occluded();
                }
            }
        });
    }

    fn intersect(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len());
        for (run, scene) in self.runs(rays) {
            intersect_in(scene, &rays[run.clone()], &mut hits[run]);
        }
    }

    fn intersect_from(&self, origin: glam::Vec3, dirs: &[glam::Vec3], hits: &mut [Option<Hit>]) {
        assert_eq!(dirs.len(), hits.len());
        let origin = origin.to_array();
        let scene = self.scene_for(origin);
        INTERSECTION_STREAM.with_borrow_mut(|stream| {
            for (dirs, hits) in dirs.chunks(STREAM).zip(hits.chunks_mut(STREAM)) {
                let stream = &mut stream[..dirs.len()];
                for (slot, d) in stream.iter_mut().zip(dirs) {
                    let ray = embree_sys::Ray::new(origin, d.to_array(), 0.0, f32::INFINITY);
                    *slot = embree_sys::RayHit::new(ray);
                }
                scene.intersect_stream(stream);
                for (h, rh) in hits.iter_mut().zip(stream.iter()) {
                    *h = rh.hit().map(to_hit);
                }
            }
        });
    }
}

/// Occlusion of general rays in `scene`, in streams.
fn occluded_in(scene: &CommittedScene, rays: &[Ray], occluded: &mut [bool]) {
    OCCLUSION_STREAM.with_borrow_mut(|stream| {
        for (rays, occluded) in rays.chunks(STREAM).zip(occluded.chunks_mut(STREAM)) {
            let stream = &mut stream[..rays.len()];
            for (slot, r) in stream.iter_mut().zip(rays) {
                *slot = embree_sys::Ray::new(r.origin.to_array(), r.dir.to_array(), 0.0, r.tfar);
            }
            scene.occluded_stream(stream);
            for (o, r) in occluded.iter_mut().zip(stream.iter()) {
                *o = r.is_occluded();
            }
        }
    });
}

/// Closest hits of general rays in `scene`, in streams.
fn intersect_in(scene: &CommittedScene, rays: &[Ray], hits: &mut [Option<Hit>]) {
    INTERSECTION_STREAM.with_borrow_mut(|stream| {
        for (rays, hits) in rays.chunks(STREAM).zip(hits.chunks_mut(STREAM)) {
            let stream = &mut stream[..rays.len()];
            for (slot, r) in stream.iter_mut().zip(rays) {
                let ray = embree_sys::Ray::new(r.origin.to_array(), r.dir.to_array(), 0.0, r.tfar);
                *slot = embree_sys::RayHit::new(ray);
            }
            scene.intersect_stream(stream);
            for (h, rh) in hits.iter_mut().zip(stream.iter()) {
                *h = rh.hit().map(to_hit);
            }
        }
    });
}
