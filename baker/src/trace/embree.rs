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

use embree_sys::{BuildQuality, CommittedScene, Device, SceneBuilder, SceneFlags};

use super::offset::ray_origins;
use super::seams::{KeptSeamIndex, seam_vertices};
use super::tracer::{Backend, Hit, Ray, Tracer};
use crate::scene::{Cutouts, Scene, world_normal};
use crate::support::error::{Error, Result};

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

/// Where hits point in the scene's triangles. A scene with cut-out triangles is two Embree
/// geometries, the opaque triangles (no filter: Embree's fast path) and the cut-out ones
/// (with an [`AlphaFilter`]); each lists its triangles' indices in the scene. Without cut-out
/// triangles there is one geometry, whose primitive ids are the triangle indices.
#[derive(Clone, Default)]
struct TriangleIds {
    /// Per geometry id, its primitives' triangle indices; empty for the one-geometry case.
    of_geometry: Vec<Arc<Vec<u32>>>,
    /// The scene's instances ([`Scene::instances`]): geometry ids from `first_instance` on,
    /// placement by placement, and each one's transform (hits on them are reported in mesh
    /// space).
    first_instance: u32,
    to_world: Arc<Vec<glam::Affine3A>>,
}

impl TriangleIds {
    #[inline]
    fn triangle(&self, hit: &embree_sys::Hit) -> u32 {
        match self.of_geometry.get(hit.geom_id as usize) {
            Some(ids) => ids[hit.prim_id as usize],
            None => hit.prim_id,
        }
    }
}

/// The alpha test of the cut-out geometry's hits ([`Cutouts::stops`]).
struct AlphaFilter {
    cutouts: Arc<Cutouts>,
    triangles: Arc<Vec<u32>>,
}

impl embree_sys::HitFilter for AlphaFilter {
    fn accept(&self, prim_id: u32, u: f32, v: f32, origin: [f32; 3], dir: [f32; 3]) -> bool {
        let triangle = self.triangles[prim_id as usize];
        let (origin, dir) = (glam::Vec3::from_array(origin), glam::Vec3::from_array(dir));
        self.cutouts.stops(triangle, u, v, origin, dir)
    }
}

fn to_hit(ids: &TriangleIds, hit: embree_sys::Hit) -> Hit {
    if let Some(geometry) = hit.inst_id {
        let instance = geometry - ids.first_instance;
        let to_world = &ids.to_world[instance as usize];
        return Hit {
            triangle: hit.prim_id,
            instance: Some(instance),
            u: hit.u,
            v: hit.v,
            t: hit.t,
            ng: world_normal(to_world, glam::Vec3::from_array(hit.ng)),
        };
    }
    Hit {
        triangle: ids.triangle(&hit),
        instance: None,
        u: hit.u,
        v: hit.v,
        t: hit.t,
        ng: glam::Vec3::from_array(hit.ng),
    }
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

fn tracer_error(err: embree_sys::Error) -> Error {
    Error::Tracer {
        backend: "embree",
        message: err.to_string(),
    }
}

/// The scene's cut-out triangles and how hits map back to triangles ([`TriangleIds`]).
#[derive(Clone, Default)]
struct Alpha {
    cutouts: Option<Arc<Cutouts>>,
    ids: TriangleIds,
}

impl Alpha {
    fn of(scene: &Scene) -> Alpha {
        let mut alpha = Alpha::cutouts_of(scene);
        alpha.ids.first_instance = alpha.ids.of_geometry.len().max(1) as u32;
        alpha.ids.to_world = Arc::new(
            scene
                .instances
                .placements
                .iter()
                .map(|p| p.to_world)
                .collect(),
        );
        alpha
    }

    fn cutouts_of(scene: &Scene) -> Alpha {
        let Some(cutouts) = scene.cutouts() else {
            return Alpha::default();
        };
        let (cut, opaque): (Vec<u32>, Vec<u32>) =
            (0..scene.traced_triangles().len() as u32).partition(|&t| cutouts.is_cut(t));
        let of_geometry = [opaque, cut]
            .into_iter()
            .filter(|ids| !ids.is_empty())
            .map(Arc::new)
            .collect();
        Alpha {
            cutouts: Some(Arc::new(cutouts)),
            ids: TriangleIds {
                of_geometry,
                ..TriangleIds::default()
            },
        }
    }
}

/// How an Embree scene is built: robust mode or not, and the BVH quality.
#[derive(Clone, Copy)]
struct Build {
    robust: bool,
    quality: BuildQuality,
}

/// Builds an Embree scene over `scene`'s triangles, robust or not: one geometry, or with
/// cut-out triangles, the geometries `alpha.ids` lists (the cut-out one filtered).
fn commit(device: &Device, scene: &Scene, alpha: &Alpha, build: Build) -> Result<CommittedScene> {
    let Build { robust, quality } = build;
    let positions: Vec<[f32; 3]> = scene.positions.iter().map(|p| p.to_array()).collect();
    let mut builder = SceneBuilder::new(device).map_err(tracer_error)?;
    builder.set_build_quality(quality);
    builder.set_flags(SceneFlags {
        robust,
        compact: false,
    });
    match &alpha.cutouts {
        None => {
            builder
                .add_triangle_mesh(&positions, scene.traced_triangles())
                .map_err(tracer_error)?;
        }
        Some(cutouts) => {
            for (geometry, ids) in alpha.ids.of_geometry.iter().enumerate() {
                let triangles: Vec<[u32; 3]> =
                    ids.iter().map(|&t| scene.triangles[t as usize]).collect();
                let added = if cutouts.is_cut(ids[0]) {
                    let filter = AlphaFilter {
                        cutouts: cutouts.clone(),
                        triangles: ids.clone(),
                    };
                    builder.add_filtered_triangle_mesh(&positions, &triangles, Box::new(filter))
                } else {
                    builder.add_triangle_mesh(&positions, &triangles)
                };
                let id = added.map_err(tracer_error)?;
                debug_assert_eq!(id as usize, geometry, "Embree numbers geometries from 0");
            }
        }
    }
    add_instances(device, scene, &mut builder, build)?;
    builder.commit().map_err(tracer_error)
}

/// Builds one Embree scene per distinct instance mesh and places it at each of its
/// placements, as geometries numbered after the flat ones (`TriangleIds::first_instance`).
fn add_instances(
    device: &Device,
    scene: &Scene,
    builder: &mut SceneBuilder,
    Build { robust, quality }: Build,
) -> Result<()> {
    let meshes = scene
        .instances
        .meshes
        .iter()
        .map(|mesh| {
            let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
            let mut one = SceneBuilder::new(device)?;
            one.set_build_quality(quality);
            one.set_flags(SceneFlags {
                robust,
                compact: false,
            });
            one.add_triangle_mesh(&positions, &mesh.triangles)?;
            one.commit().map(Arc::new)
        })
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(tracer_error)?;
    for placement in &scene.instances.placements {
        let m = placement.to_world;
        let columns = [
            m.matrix3.x_axis,
            m.matrix3.y_axis,
            m.matrix3.z_axis,
            m.translation,
        ];
        let matrix: [f32; 12] = std::array::from_fn(|i| columns[i / 3][i % 3]);
        builder
            .add_instance(&meshes[placement.mesh as usize], &matrix)
            .map_err(tracer_error)?;
    }
    Ok(())
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
        let mut keys: HashSet<[u32; 3]> = origins
            .iter()
            .zip(&seam)
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

    fn for_points<'s>(
        &'s self,
        scene: &Scene,
        origins: &[glam::Vec3],
        own: &[u32],
    ) -> Result<Option<Box<dyn Tracer + 's>>> {
        Ok(self
            .watertight_for(scene, origins, own)?
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
    fn for_points<'s>(
        &'s self,
        scene: &Scene,
        origins: &[glam::Vec3],
        own: &[u32],
    ) -> Result<Option<Box<dyn Tracer + 's>>> {
        self.base.for_points(scene, origins, own)
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
