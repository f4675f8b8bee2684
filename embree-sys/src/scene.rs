//! Building a triangle scene and committing it into a queryable, shareable [`CommittedScene`].

use std::mem::size_of;
use std::sync::Arc;

use crate::device::{Device, DeviceInner};
use crate::error::{Error, ErrorKind};
use crate::filter::{HitFilter, filter_hits};
use crate::sys;

/// The BVH builder's trade-off between build time and query speed (`RTCBuildQuality`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BuildQuality {
    Low,
    #[default]
    Medium,
    High,
}

/// Scene flags (`RTCSceneFlags`) that matter for static scenes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneFlags {
    /// Avoid optimisations that lower arithmetic accuracy (`RTC_SCENE_FLAG_ROBUST`): fewer
    /// missed hits on shared edges and vertices, at some speed.
    pub robust: bool,
    /// Smaller memory footprint, slower queries (`RTC_SCENE_FLAG_COMPACT`).
    pub compact: bool,
}

/// A scene being assembled. Geometry is copied in; nothing borrowed outlives a call.
pub struct SceneBuilder {
    device: Device,
    handle: sys::RTCScene,
    triangle_count: usize,
    /// The filters of filtered geometries, boxed twice so each has a stable thin address
    /// (Embree's user pointer); moved into the committed scene, which outlives every query.
    #[allow(clippy::vec_box)]
    // the inner box is a fat pointer: the outer one's address is thin
    filters: Vec<Box<Box<dyn HitFilter>>>,
    /// The scenes instanced by [`SceneBuilder::add_instance`], kept alive with the committed
    /// scene, which traverses them.
    instanced: Vec<Arc<CommittedScene>>,
}

impl SceneBuilder {
    pub fn new(device: &Device) -> Result<SceneBuilder, Error> {
        // SAFETY: the device handle is live for as long as `device`.
        let handle = unsafe { sys::rtcNewScene(device.inner.handle) };
        device.check()?;
        if handle.is_null() {
            return Err(Error::new(ErrorKind::Unknown, "rtcNewScene returned null"));
        }
        Ok(SceneBuilder {
            device: device.clone(),
            handle,
            triangle_count: 0,
            filters: Vec::new(),
            instanced: Vec::new(),
        })
    }

    pub fn set_build_quality(&mut self, quality: BuildQuality) {
        let quality = match quality {
            BuildQuality::Low => sys::RTC_BUILD_QUALITY_LOW,
            BuildQuality::Medium => sys::RTC_BUILD_QUALITY_MEDIUM,
            BuildQuality::High => sys::RTC_BUILD_QUALITY_HIGH,
        };
        // SAFETY: the scene handle is live and not yet committed.
        unsafe { sys::rtcSetSceneBuildQuality(self.handle, quality) };
    }

    pub fn set_flags(&mut self, flags: SceneFlags) {
        let mut bits = sys::RTC_SCENE_FLAG_NONE;
        if flags.robust {
            bits |= sys::RTC_SCENE_FLAG_ROBUST;
        }
        if flags.compact {
            bits |= sys::RTC_SCENE_FLAG_COMPACT;
        }
        // SAFETY: the scene handle is live and not yet committed.
        unsafe { sys::rtcSetSceneFlags(self.handle, bits) };
    }

    /// Adds a triangle mesh and returns its geometry id. Primitive ids in hits index `triangles`.
    ///
    /// Every index must be below `positions.len()`: Embree does not check, so this does.
    pub fn add_triangle_mesh(
        &mut self,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
    ) -> Result<u32, Error> {
        self.add_mesh(positions, triangles, None)
    }

    /// [`SceneBuilder::add_triangle_mesh`] with a [`HitFilter`] that decides, hit by hit,
    /// whether a ray is stopped by this geometry (for closest-hit and occlusion queries).
    pub fn add_filtered_triangle_mesh(
        &mut self,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
        filter: Box<dyn HitFilter>,
    ) -> Result<u32, Error> {
        self.add_mesh(positions, triangles, Some(filter))
    }

    fn add_mesh(
        &mut self,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
        filter: Option<Box<dyn HitFilter>>,
    ) -> Result<u32, Error> {
        if positions.is_empty() || triangles.is_empty() {
            return Err(Error::new(
                ErrorKind::InvalidArgument,
                "triangle mesh is empty",
            ));
        }
        if let Some((t, tri)) = triangles
            .iter()
            .enumerate()
            .find(|(_, tri)| tri.iter().any(|&i| i as usize >= positions.len()))
        {
            return Err(Error::new(
                ErrorKind::InvalidArgument,
                format!(
                    "triangle {t} has index {:?} but the mesh has {} vertices",
                    tri,
                    positions.len()
                ),
            ));
        }
        let too_big = || Error::new(ErrorKind::InvalidArgument, "mesh exceeds 2^32 items");
        let vertex_count = u32::try_from(positions.len()).map_err(|_| too_big())?;
        let triangle_count = u32::try_from(triangles.len()).map_err(|_| too_big())?;

        // SAFETY: the device handle is live.
        let geometry = unsafe {
            sys::rtcNewGeometry(self.device.inner.handle, sys::RTC_GEOMETRY_TYPE_TRIANGLE)
        };
        self.device.check()?;
        // SAFETY: `geometry` is a live triangle geometry. Embree allocates each buffer with the
        // requested item count and stride (and its own padding), returns a pointer to it, and
        // the copies below write exactly `count * stride` bytes into it. `[f32; 3]` and
        // `[u32; 3]` have the FLOAT3 / UINT3 layouts with a 12-byte stride.
        let result = unsafe {
            let vertices = sys::rtcSetNewGeometryBuffer(
                geometry,
                sys::RTC_BUFFER_TYPE_VERTEX,
                0,
                sys::RTC_FORMAT_FLOAT3,
                size_of::<[f32; 3]>(),
                vertex_count as usize,
            ) as *mut [f32; 3];
            let indices = sys::rtcSetNewGeometryBuffer(
                geometry,
                sys::RTC_BUFFER_TYPE_INDEX,
                0,
                sys::RTC_FORMAT_UINT3,
                size_of::<[u32; 3]>(),
                triangle_count as usize,
            ) as *mut [u32; 3];
            match self.device.check() {
                Err(err) => Err(err),
                Ok(()) if vertices.is_null() || indices.is_null() => Err(Error::new(
                    ErrorKind::OutOfMemory,
                    "rtcSetNewGeometryBuffer returned null",
                )),
                Ok(()) => {
                    vertices.copy_from_nonoverlapping(positions.as_ptr(), positions.len());
                    indices.copy_from_nonoverlapping(triangles.as_ptr(), triangles.len());
                    if let Some(filter) = filter {
                        // The pointer stays valid: the outer box's heap slot never moves and
                        // is dropped with the committed scene, after every query.
                        let filter = Box::new(filter);
                        let user = &*filter as *const Box<dyn HitFilter> as *mut std::ffi::c_void;
                        self.filters.push(filter);
                        sys::rtcSetGeometryUserData(geometry, user);
                        sys::rtcSetGeometryIntersectFilterFunction(geometry, Some(filter_hits));
                        sys::rtcSetGeometryOccludedFilterFunction(geometry, Some(filter_hits));
                    }
                    sys::rtcCommitGeometry(geometry);
                    let id = sys::rtcAttachGeometry(self.handle, geometry);
                    self.device.check().map(|()| id)
                }
            }
        };
        // SAFETY: the scene holds its own reference once attached; this drops ours either way.
        unsafe { sys::rtcReleaseGeometry(geometry) };
        self.triangle_count += triangles.len();
        result
    }

    /// Adds an instance of a committed scene placed by `to_world` (a 3×4 affine matrix,
    /// column-major: the three linear columns, then the translation) and returns its geometry
    /// id, which hits on it report as [`crate::Hit::inst_id`]. One level only: `scene` must
    /// hold triangle meshes, not instances (Embree is built with one instance level).
    pub fn add_instance(
        &mut self,
        scene: &Arc<CommittedScene>,
        to_world: &[f32; 12],
    ) -> Result<u32, Error> {
        if !to_world.iter().all(|x| x.is_finite()) {
            return Err(Error::new(
                ErrorKind::InvalidArgument,
                "instance transform is not finite",
            ));
        }
        if !scene.instanced.is_empty() {
            return Err(Error::new(
                ErrorKind::InvalidArgument,
                "an instanced scene cannot hold instances itself (one instance level)",
            ));
        }
        // SAFETY: the device handle is live.
        let geometry = unsafe {
            sys::rtcNewGeometry(self.device.inner.handle, sys::RTC_GEOMETRY_TYPE_INSTANCE)
        };
        self.device.check()?;
        // SAFETY: `geometry` is a live instance geometry; `scene.handle` a committed scene that
        // `self.instanced` keeps alive for as long as this scene and its committed form exist;
        // `to_world` points at 12 floats, the FLOAT3X4_COLUMN_MAJOR layout, which Embree copies.
        let result = unsafe {
            sys::rtcSetGeometryInstancedScene(geometry, scene.handle);
            sys::rtcSetGeometryTimeStepCount(geometry, 1);
            sys::rtcSetGeometryTransform(
                geometry,
                0,
                sys::RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR,
                to_world.as_ptr().cast(),
            );
            sys::rtcCommitGeometry(geometry);
            let id = sys::rtcAttachGeometry(self.handle, geometry);
            self.device.check().map(|()| id)
        };
        // SAFETY: the scene holds its own reference once attached; this drops ours either way.
        unsafe { sys::rtcReleaseGeometry(geometry) };
        self.instanced.push(Arc::clone(scene));
        self.triangle_count += scene.triangle_count;
        result
    }

    /// Builds the BVH. Only a committed scene answers queries.
    pub fn commit(mut self) -> Result<CommittedScene, Error> {
        // SAFETY: the scene handle is live; commit runs on Embree's thread pool and returns
        // when the BVH is built.
        unsafe { sys::rtcCommitScene(self.handle) };
        self.device.check()?;
        let scene = CommittedScene {
            handle: self.handle,
            device: Arc::clone(&self.device.inner),
            triangle_count: self.triangle_count,
            filters: std::mem::take(&mut self.filters),
            instanced: std::mem::take(&mut self.instanced),
        };
        // The handle moved into `scene`; do not release it in our `Drop`.
        std::mem::forget(self);
        Ok(scene)
    }
}

impl Drop for SceneBuilder {
    fn drop(&mut self) {
        // SAFETY: the handle is live and owned by this builder.
        unsafe { sys::rtcReleaseScene(self.handle) };
    }
}

/// A committed, read-only scene: the only type that answers queries.
pub struct CommittedScene {
    pub(crate) handle: sys::RTCScene,
    /// Keeps the device (and the error slot its callback writes to) alive while queries run.
    #[allow(dead_code)]
    device: Arc<DeviceInner>,
    triangle_count: usize,
    /// The geometries' hit filters, which Embree calls during queries: dropped after the
    /// scene is released (fields drop after `Drop::drop`).
    #[allow(dead_code, clippy::vec_box)]
    filters: Vec<Box<Box<dyn HitFilter>>>,
    /// The scenes its instances place: released after this one (fields drop after `drop`).
    #[allow(dead_code)]
    instanced: Vec<Arc<CommittedScene>>,
}

// SAFETY: after `rtcCommitScene` the scene is never modified again (no method takes `&mut self`
// or touches the geometry), and Embree documents `rtcIntersect*`/`rtcOccluded*` on a committed
// scene as safe to call from any number of threads at once. Release happens once, in `Drop`,
// which Rust runs only when no other reference exists.
unsafe impl Send for CommittedScene {}
// SAFETY: see `Send`: shared references only issue Embree's thread-safe queries.
unsafe impl Sync for CommittedScene {}

impl CommittedScene {
    /// Triangles in the scene, each instance's counted once per instance.
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    /// The axis-aligned bounds of everything in the scene: `(lower, upper)`.
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let mut bounds = sys::RTCBounds::default();
        // SAFETY: committed scene, and `bounds` is a properly aligned RTCBounds to write into.
        unsafe { sys::rtcGetSceneBounds(self.handle, &mut bounds) };
        (
            [bounds.lower_x, bounds.lower_y, bounds.lower_z],
            [bounds.upper_x, bounds.upper_y, bounds.upper_z],
        )
    }
}

impl Drop for CommittedScene {
    fn drop(&mut self) {
        // SAFETY: the handle is live and owned by this value; no query can be running because
        // they all borrow `self`.
        unsafe { sys::rtcReleaseScene(self.handle) };
    }
}
