//! The Embree backend, through our `embree-sys` bindings.
//!
//! BVH build quality ([`build_quality`]): `High` (spatial splits) only when a bake casts at
//! least [`HIGH_QUALITY_RAYS`] rays per receiver, else `Medium` (binned SAH). Measured on the
//! 720,000-triangle heightfield (2 cores at a load of 7–15, 2 runs each, alternating): the
//! texel bake (`--lightmap 2048 --atlas planar --order 3 --samples 64`) built its tracer in
//! 1.38–1.47 CPU-s with High, 0.26–0.29 with Medium, 0.28–0.51 with Low, and its bake stage
//! took 7.15–7.22 / 6.91–7.29 / 6.89–7.73 CPU-s (the same within the noise); process CPU
//! 19.6–20.4 / 19.3 / 19.2–21.1 s. Its vertex bake: tracer (seam vertices and two scenes)
//! 2.23–2.39 / 1.32–1.55 / 1.22–1.44 CPU-s, the rest 7.0–7.5 / 7.2 / 6.9–7.0, process
//! 9.3–9.9 / 8.6–8.7 / 8.1–8.4 CPU-s. The Cornell box (2,048 samples a vertex; a 512² two-bounce
//! interreflected lightmap): no difference outside the noise. So High saves no measurable
//! ray time at 64 rays per receiver and costs about 1.5 µs CPU per triangle more: it can pay
//! only when rays per triangle are in the thousands (≥ 1,024: a 0.5 % faster ray would then
//! repay it). Low (Morton codes) was as fast on this regular mesh but is known to fall
//! behind on uneven ones; Medium is the safe default. Every quality gives the same closest
//! hit but at exact ties of t, and all the test bakes above were byte-identical across the
//! three. The robust scenes use the same quality: `RTC_SCENE_FLAG_ROBUST` changes the
//! triangle test, not the build. The choice depends only on the command line's sampling, so
//! every process of a staged or sharded bake builds the same BVH. Library callers that do not
//! say (the tests, `tests/agreement.rs` included) get Medium too; `make bench`'s bake benchmark
//! passes its 10,000 rays per vertex, so it and its raw-Embree rate use High, as before.

use std::cell::RefCell;
use std::collections::HashSet;
use std::sync::{Arc, OnceLock};

use embree_sys::{BuildQuality, CommittedScene, Device};

use super::embree_scene::{Alpha, Build, TriangleIds, commit, to_hit, tracer_error};
use super::offset::ray_origins;
use super::seams::{KeptSeamIndex, seam_vertices};
use super::tracer::{Backend, Hit, Ray, Tracer};
use crate::scene::Scene;
use crate::support::error::Result;

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

/// The key of a ray origin in a set of seam origins: its exact bits.
fn origin_key(origin: glam::Vec3) -> [u32; 3] {
    origin.to_array().map(f32::to_bits)
}

pub struct EmbreeTracer {
    /// The scene most rays are traced in: default mode, or robust mode with
    /// [`EmbreeMode::Robust`].
    scene: CommittedScene,
    /// With [`EmbreeMode::Watertight`], where the rays of seam vertices go.
    seams: Option<Seams>,
    /// Kept to build a robust scene for [`Tracer::for_points`] when no vertex needed one.
    device: Device,
    /// That robust scene, built once.
    points_robust: OnceLock<Arc<CommittedScene>>,
    /// The index that finds seam points ([`Tracer::for_points`]).
    seam_index: KeptSeamIndex,
    mode: EmbreeMode,
    /// [`build_quality`]'s choice, for the robust scene built later.
    quality: BuildQuality,
    /// Cut-out triangles, and the map from hits to triangles.
    alpha: Alpha,
}

/// The robust-mode scene over the same geometry, and the ray origins traced in it.
struct Seams {
    robust: Arc<CommittedScene>,
    /// The bit patterns of the seam vertices' ray origins ([`super::seams`]).
    origins: HashSet<[u32; 3]>,
}

/// Which rays Embree traces in its robust mode.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EmbreeMode {
    /// Robust mode for the rays that leave a seam vertex (a vertex near another triangle's
    /// edge, [`super::seams`]), or a seam texel through [`Tracer::for_points`], the default
    /// mode for all others. The default: watertight answers at nearly the default mode's
    /// speed, because only the seam origins' rays can leak through the default mode's cracks.
    #[default]
    Watertight,
    /// Robust mode (`RTC_SCENE_FLAG_ROBUST`: no accuracy-reducing optimisations) for every
    /// ray: `--robust`. About 30 % slower on the demo scene.
    Robust,
    /// Embree's default mode for every ray: the fastest, but it leaks light through the
    /// seams where meshes meet (the baker's default before it was made watertight). For benchmarks and the
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
    /// [`crate::trace::TracerOptions::points_only`]: no seam vertices.
    pub points_only: bool,
    /// [`crate::trace::TracerOptions::rays_per_receiver`]: picks the BVH quality.
    pub rays_per_receiver: u32,
}

/// Rays per receiver from which [`build_quality`] picks `High`: see the module doc.
pub const HIGH_QUALITY_RAYS: u32 = 1024;

/// The BVH quality for a bake casting `rays_per_receiver` rays from each receiver (0 when
/// unknown: the library's callers, the tests and benchmarks, which then build what an ordinary
/// bake builds): see the module doc for the figures.
fn build_quality(rays_per_receiver: u32) -> BuildQuality {
    match rays_per_receiver >= HIGH_QUALITY_RAYS {
        true => BuildQuality::High,
        false => BuildQuality::Medium,
    }
}

impl EmbreeTracer {
    /// Builds a BVH of [`build_quality`] for `options.rays_per_receiver`. With [`EmbreeMode::Watertight`], a second, robust one where the scene has seam
    /// vertices.
    pub fn new(scene: &Scene, options: EmbreeOptions) -> Result<EmbreeTracer> {
        let config = options
            .threads
            .map(|t| format!("threads={t}"))
            .unwrap_or_default();
        let device = Device::with_config(&config).map_err(tracer_error)?;
        let alpha = Alpha::of(scene);
        let quality = build_quality(options.rays_per_receiver);
        let build = |robust| Build { robust, quality };
        let seams = match options.mode {
            EmbreeMode::Watertight if !options.points_only => {
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
                        robust: Arc::new(commit(&device, scene, &alpha, build(true))?),
                        origins,
                    })
                }
            }
            EmbreeMode::Watertight | EmbreeMode::Robust | EmbreeMode::Fast => None,
        };
        Ok(EmbreeTracer {
            scene: commit(
                &device,
                scene,
                &alpha,
                build(options.mode == EmbreeMode::Robust),
            )?,
            seams,
            device,
            points_robust: OnceLock::new(),
            seam_index: KeptSeamIndex::default(),
            mode: options.mode,
            quality,
            alpha,
        })
    }

    /// How many distinct ray origins are traced in robust mode by [`EmbreeMode::Watertight`]
    /// (0 in the other modes).
    pub fn seam_origin_count(&self) -> usize {
        self.seams.as_ref().map_or(0, |s| s.origins.len())
    }

    fn routing(&self) -> Routing<'_> {
        Routing {
            ids: &self.alpha.ids,
            fast: &self.scene,
            robust: self.seams.as_ref().map(|s| (&*s.robust, &s.origins)),
        }
    }

    /// The committed Embree scene, for benchmarks that call Embree directly.
    pub fn embree_scene(&self) -> &CommittedScene {
        &self.scene
    }

    /// [`Tracer::for_points`] for Embree, typed: with [`EmbreeMode::Watertight`], a tracer
    /// that also traces the rays of the seam points among `origins` in robust mode.
    pub fn watertight_for(
        &self,
        scene: &Scene,
        origins: &[glam::Vec3],
        own: &[u32],
    ) -> Result<Option<EmbreePoints<'_>>> {
        if self.mode != EmbreeMode::Watertight {
            return Ok(None);
        }
        let seam = self.seam_index.seam_points(scene, origins, own);
        self.watertight_for_seams(scene, origins, &seam)
    }

    /// [`EmbreeTracer::watertight_for`] with the seam points among `origins` known
    /// (`seam[i]`, [`Tracer::seam_points`]).
    pub fn watertight_for_seams(
        &self,
        scene: &Scene,
        origins: &[glam::Vec3],
        seam: &[bool],
    ) -> Result<Option<EmbreePoints<'_>>> {
        if self.mode != EmbreeMode::Watertight {
            return Ok(None);
        }
        let mut keys: HashSet<[u32; 3]> = origins
            .iter()
            .zip(seam)
            .filter(|&(_, &seam)| seam)
            .map(|(o, _)| origin_key(*o))
            .collect();
        let robust = match &self.seams {
            Some(seams) => {
                keys.extend(seams.origins.iter().copied());
                seams.robust.clone()
            }
            None if keys.is_empty() => return Ok(None),
            None => match self.points_robust.get() {
                Some(robust) => robust.clone(),
                None => {
                    let robust = Arc::new(commit(
                        &self.device,
                        scene,
                        &self.alpha,
                        Build {
                            robust: true,
                            quality: self.quality,
                        },
                    )?);
                    self.points_robust.get_or_init(|| robust).clone()
                }
            },
        };
        Ok(Some(EmbreePoints {
            base: self,
            robust,
            origins: keys,
        }))
    }
}

/// An [`EmbreeTracer`] in [`EmbreeMode::Watertight`] that also knows the seam points of a
/// set of receivers that are not vertices (texels): [`EmbreeTracer::watertight_for`].
pub struct EmbreePoints<'a> {
    /// The tracer it extends: its default-mode scene traces all other rays.
    base: &'a EmbreeTracer,
    robust: Arc<CommittedScene>,
    /// The seam points' and the seam vertices' ray origins.
    origins: HashSet<[u32; 3]>,
}

impl EmbreePoints<'_> {
    /// How many distinct ray origins are traced in robust mode.
    pub fn seam_origin_count(&self) -> usize {
        self.origins.len()
    }

    fn routing(&self) -> Routing<'_> {
        Routing {
            ids: &self.base.alpha.ids,
            fast: &self.base.scene,
            robust: Some((&*self.robust, &self.origins)),
        }
    }
}

/// Which scene traces a ray: the robust one for the listed origins, the fast one otherwise.
struct Routing<'a> {
    ids: &'a TriangleIds,
    fast: &'a CommittedScene,
    robust: Option<(&'a CommittedScene, &'a HashSet<[u32; 3]>)>,
}

impl<'a> Routing<'a> {
    /// The scene that traces rays from `origin`.
    fn scene_for(&self, origin: [f32; 3]) -> &'a CommittedScene {
        match self.robust {
            Some((robust, origins)) if origins.contains(&origin.map(f32::to_bits)) => robust,
            _ => self.fast,
        }
    }

    /// `rays` split into runs of consecutive rays traced in the same scene.
    fn runs<'r>(
        &'r self,
        rays: &'r [Ray],
    ) -> impl Iterator<Item = (std::ops::Range<usize>, &'a CommittedScene)> + 'r {
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
            intersect_in(scene, self.ids, &rays[run.clone()], &mut hits[run]);
        }
    }

    /// Closest hits of rays from one origin, each ending at `tfar`.
    fn intersect_within(
        &self,
        origin: glam::Vec3,
        dirs: &[glam::Vec3],
        tfar: f32,
        hits: &mut [Option<Hit>],
    ) {
        assert_eq!(dirs.len(), hits.len());
        let origin = origin.to_array();
        let scene = self.scene_for(origin);
        INTERSECTION_STREAM.with_borrow_mut(|stream| {
            for (dirs, hits) in dirs.chunks(STREAM).zip(hits.chunks_mut(STREAM)) {
                let stream = &mut stream[..dirs.len()];
                for (slot, d) in stream.iter_mut().zip(dirs) {
                    let ray = embree_sys::Ray::new(origin, d.to_array(), 0.0, tfar);
                    *slot = embree_sys::RayHit::new(ray);
                }
                scene.intersect_stream(stream);
                for (h, rh) in hits.iter_mut().zip(stream.iter()) {
                    *h = rh.hit().map(|hit| to_hit(self.ids, hit));
                }
            }
        });
    }
}

impl Tracer for EmbreeTracer {
    fn backend(&self) -> Backend {
        Backend::Embree
    }

    fn occluded(&self, rays: &[Ray], occluded: &mut [bool]) {
        self.routing().occluded(rays, occluded);
    }

    fn occluded_from(&self, origin: glam::Vec3, dirs: &[glam::Vec3], occluded: &mut [bool]) {
        self.routing().occluded_from(origin, dirs, occluded);
    }

    fn intersect(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.routing().intersect(rays, hits);
    }

    fn intersect_within(
        &self,
        origin: glam::Vec3,
        dirs: &[glam::Vec3],
        tfar: f32,
        hits: &mut [Option<Hit>],
    ) {
        self.routing().intersect_within(origin, dirs, tfar, hits);
    }

    fn prepare_points(&self, scene: &Scene) {
        if self.mode == EmbreeMode::Watertight {
            self.seam_index.prepare(scene);
        }
    }

    fn release_points(&self) {
        self.seam_index.release();
    }

    fn seam_points(&self, scene: &Scene, origins: &[glam::Vec3], own: &[u32]) -> Option<Vec<bool>> {
        (self.mode == EmbreeMode::Watertight)
            .then(|| self.seam_index.seam_points(scene, origins, own))
    }

    fn for_seam_points<'s>(
        &'s self,
        scene: &Scene,
        origins: &[glam::Vec3],
        seam: &[bool],
    ) -> Result<Option<Box<dyn Tracer + 's>>> {
        Ok(self
            .watertight_for_seams(scene, origins, seam)?
            .map(|t| Box::new(t) as Box<dyn Tracer + 's>))
    }
}

impl Tracer for EmbreePoints<'_> {
    fn backend(&self) -> Backend {
        Backend::Embree
    }

    fn prepare_points(&self, scene: &Scene) {
        self.base.prepare_points(scene);
    }

    fn release_points(&self) {
        self.base.release_points();
    }

    /// For yet other points (texels moved out of a wall): as the tracer it extends.
    fn seam_points(&self, scene: &Scene, origins: &[glam::Vec3], own: &[u32]) -> Option<Vec<bool>> {
        self.base.seam_points(scene, origins, own)
    }

    fn for_seam_points<'s>(
        &'s self,
        scene: &Scene,
        origins: &[glam::Vec3],
        seam: &[bool],
    ) -> Result<Option<Box<dyn Tracer + 's>>> {
        self.base.for_seam_points(scene, origins, seam)
    }

    fn occluded(&self, rays: &[Ray], occluded: &mut [bool]) {
        self.routing().occluded(rays, occluded);
    }

    fn occluded_from(&self, origin: glam::Vec3, dirs: &[glam::Vec3], occluded: &mut [bool]) {
        self.routing().occluded_from(origin, dirs, occluded);
    }

    fn intersect(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        self.routing().intersect(rays, hits);
    }

    fn intersect_within(
        &self,
        origin: glam::Vec3,
        dirs: &[glam::Vec3],
        tfar: f32,
        hits: &mut [Option<Hit>],
    ) {
        self.routing().intersect_within(origin, dirs, tfar, hits);
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
fn intersect_in(scene: &CommittedScene, ids: &TriangleIds, rays: &[Ray], hits: &mut [Option<Hit>]) {
    INTERSECTION_STREAM.with_borrow_mut(|stream| {
        for (rays, hits) in rays.chunks(STREAM).zip(hits.chunks_mut(STREAM)) {
            let stream = &mut stream[..rays.len()];
            for (slot, r) in stream.iter_mut().zip(rays) {
                let ray = embree_sys::Ray::new(r.origin.to_array(), r.dir.to_array(), 0.0, r.tfar);
                *slot = embree_sys::RayHit::new(ray);
            }
            scene.intersect_stream(stream);
            for (h, rh) in hits.iter_mut().zip(stream.iter()) {
                *h = rh.hit().map(|hit| to_hit(ids, hit));
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rule the module doc measures: Medium at ordinary sampling, High when rays per
    /// receiver are many enough to repay spatial splits; unknown (0) counts as few.
    #[test]
    fn build_quality_follows_rays_per_receiver() {
        assert_eq!(build_quality(64), BuildQuality::Medium);
        assert_eq!(build_quality(HIGH_QUALITY_RAYS - 1), BuildQuality::Medium);
        assert_eq!(build_quality(HIGH_QUALITY_RAYS), BuildQuality::High);
        assert_eq!(build_quality(0), BuildQuality::Medium);
    }
}
