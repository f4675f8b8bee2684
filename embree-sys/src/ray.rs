//! Rays, hits and 16-wide packets in the exact layouts Embree reads and writes.

use crate::sys;

/// Lanes in a [`Ray16`] / [`RayHit16`] packet.
pub const PACKET_WIDTH: usize = 16;

/// A ray segment `origin + t·dir`, `t` in `[tnear, tfar]` (`RTCRay`). After an occlusion query
/// `tfar` is `-inf` for a blocked ray, which [`Ray::is_occluded`] reads.
#[derive(Clone, Copy, Default)]
#[repr(transparent)]
pub struct Ray(pub(crate) sys::RTCRay);

impl Ray {
    /// The mask is all ones: Embree 4 enables ray masks by default, and a zero mask hits nothing.
    #[inline]
    pub fn new(origin: [f32; 3], dir: [f32; 3], tnear: f32, tfar: f32) -> Ray {
        Ray(sys::RTCRay {
            org_x: origin[0],
            org_y: origin[1],
            org_z: origin[2],
            tnear,
            dir_x: dir[0],
            dir_y: dir[1],
            dir_z: dir[2],
            time: 0.0,
            tfar,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        })
    }

    #[inline]
    pub fn origin(&self) -> [f32; 3] {
        [self.0.org_x, self.0.org_y, self.0.org_z]
    }

    #[inline]
    pub fn dir(&self) -> [f32; 3] {
        [self.0.dir_x, self.0.dir_y, self.0.dir_z]
    }

    #[inline]
    pub fn tfar(&self) -> f32 {
        self.0.tfar
    }

    /// Whether an occlusion query found the segment blocked.
    #[inline]
    pub fn is_occluded(&self) -> bool {
        self.0.tfar == f32::NEG_INFINITY
    }
}

/// The closest hit of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Index of the triangle within its mesh.
    pub prim_id: u32,
    /// The mesh, as returned by `SceneBuilder::add_triangle_mesh` (of the instanced scene,
    /// for a hit on an instance).
    pub geom_id: u32,
    /// The instance hit, as returned by `SceneBuilder::add_instance`; `None` for a hit on
    /// the scene's own meshes. Embree reports `u`, `v` and `ng` of an instance's hit in the
    /// instanced scene's space.
    pub inst_id: Option<u32>,
    /// Barycentrics: the hit point is `(1 − u − v)·v0 + u·v1 + v·v2`.
    pub u: f32,
    pub v: f32,
    /// Distance along the ray, in units of the direction's length.
    pub t: f32,
    /// Unnormalised geometric normal as Embree reports it: `(v1 − v0) × (v2 − v0)` for the
    /// triangle's vertex order (checked by this crate's tests).
    pub ng: [f32; 3],
}

/// A ray with room for its closest hit (`RTCRayHit`).
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct RayHit(pub(crate) sys::RTCRayHit);

impl RayHit {
    #[inline]
    pub fn new(ray: Ray) -> RayHit {
        let hit = sys::RTCHit {
            geomID: sys::RTC_INVALID_GEOMETRY_ID,
            primID: sys::RTC_INVALID_GEOMETRY_ID,
            instID: [sys::RTC_INVALID_GEOMETRY_ID; sys::RTC_MAX_INSTANCE_LEVEL_COUNT as usize],
            ..Default::default()
        };
        RayHit(sys::RTCRayHit { ray: ray.0, hit })
    }

    /// The hit found by an intersection query, if the ray hit anything.
    #[inline]
    pub fn hit(&self) -> Option<Hit> {
        let h = &self.0.hit;
        (h.geomID != sys::RTC_INVALID_GEOMETRY_ID).then_some(Hit {
            prim_id: h.primID,
            geom_id: h.geomID,
            inst_id: Some(h.instID[0]).filter(|&i| i != sys::RTC_INVALID_GEOMETRY_ID),
            u: h.u,
            v: h.v,
            t: self.0.ray.tfar,
            ng: [h.Ng_x, h.Ng_y, h.Ng_z],
        })
    }
}

/// Embree reads packet validity from a 64-byte-aligned array of ints (−1 active, 0 inactive).
#[derive(Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct Valid16(pub(crate) [i32; PACKET_WIDTH]);

/// Sixteen rays in Embree's structure-of-arrays packet layout (`RTCRay16`), with a lane mask.
/// All lanes start inactive; [`Ray16::set`] activates one.
#[derive(Clone, Copy)]
pub struct Ray16 {
    pub(crate) valid: Valid16,
    pub(crate) rays: sys::RTCRay16,
}

impl Default for Ray16 {
    fn default() -> Ray16 {
        Ray16 {
            valid: Valid16([0; PACKET_WIDTH]),
            rays: sys::RTCRay16::default(),
        }
    }
}

impl Ray16 {
    /// Writes lane `i` and marks it active.
    #[inline]
    pub fn set(&mut self, i: usize, origin: [f32; 3], dir: [f32; 3], tnear: f32, tfar: f32) {
        let r = &mut self.rays;
        r.org_x[i] = origin[0];
        r.org_y[i] = origin[1];
        r.org_z[i] = origin[2];
        r.tnear[i] = tnear;
        r.dir_x[i] = dir[0];
        r.dir_y[i] = dir[1];
        r.dir_z[i] = dir[2];
        r.time[i] = 0.0;
        r.tfar[i] = tfar;
        r.mask[i] = u32::MAX;
        r.id[i] = i as u32;
        r.flags[i] = 0;
        self.valid.0[i] = -1;
    }

    /// Marks every lane inactive (the ray data is left as is).
    #[inline]
    pub fn clear(&mut self) {
        self.valid.0 = [0; PACKET_WIDTH];
    }

    #[inline]
    pub fn is_active(&self, i: usize) -> bool {
        self.valid.0[i] != 0
    }

    /// Whether lane `i` was found blocked by the last occlusion query.
    #[inline]
    pub fn is_occluded(&self, i: usize) -> bool {
        self.rays.tfar[i] == f32::NEG_INFINITY
    }
}

/// Sixteen rays with room for their closest hits (`RTCRayHit16`).
#[derive(Clone, Copy)]
pub struct RayHit16 {
    pub(crate) valid: Valid16,
    pub(crate) rayhits: sys::RTCRayHit16,
}

impl Default for RayHit16 {
    fn default() -> RayHit16 {
        RayHit16 {
            valid: Valid16([0; PACKET_WIDTH]),
            rayhits: sys::RTCRayHit16::default(),
        }
    }
}

impl RayHit16 {
    /// Writes lane `i`, clears its hit and marks it active.
    #[inline]
    pub fn set(&mut self, i: usize, origin: [f32; 3], dir: [f32; 3], tnear: f32, tfar: f32) {
        let r = &mut self.rayhits.ray;
        r.org_x[i] = origin[0];
        r.org_y[i] = origin[1];
        r.org_z[i] = origin[2];
        r.tnear[i] = tnear;
        r.dir_x[i] = dir[0];
        r.dir_y[i] = dir[1];
        r.dir_z[i] = dir[2];
        r.time[i] = 0.0;
        r.tfar[i] = tfar;
        r.mask[i] = u32::MAX;
        r.id[i] = i as u32;
        r.flags[i] = 0;
        self.rayhits.hit.geomID[i] = sys::RTC_INVALID_GEOMETRY_ID;
        self.rayhits.hit.primID[i] = sys::RTC_INVALID_GEOMETRY_ID;
        self.rayhits.hit.instID[0][i] = sys::RTC_INVALID_GEOMETRY_ID;
        self.valid.0[i] = -1;
    }

    #[inline]
    pub fn clear(&mut self) {
        self.valid.0 = [0; PACKET_WIDTH];
    }

    /// The closest hit of lane `i` after an intersection query.
    #[inline]
    pub fn hit(&self, i: usize) -> Option<Hit> {
        let h = &self.rayhits.hit;
        (self.valid.0[i] != 0 && h.geomID[i] != sys::RTC_INVALID_GEOMETRY_ID).then(|| Hit {
            prim_id: h.primID[i],
            geom_id: h.geomID[i],
            inst_id: Some(h.instID[0][i]).filter(|&i| i != sys::RTC_INVALID_GEOMETRY_ID),
            u: h.u[i],
            v: h.v[i],
            t: self.rayhits.ray.tfar[i],
            ng: [h.Ng_x[i], h.Ng_y[i], h.Ng_z[i]],
        })
    }
}
