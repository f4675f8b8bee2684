//! Occlusion and closest-hit queries on a committed scene, over Embree 3's and Embree 4's
//! different argument APIs.
//!
//! Embree 3 passes an `RTCIntersectContext` before the rays; Embree 4 passes
//! `RTCIntersectArguments` / `RTCOccludedArguments` after them and dropped the stream calls
//! (`rtcOccluded1M`), which are served here by 16-wide packets instead.

#[cfg(embree_v4)]
use crate::ray::PACKET_WIDTH;
use crate::ray::{Hit, Ray, Ray16, RayHit, RayHit16};
use crate::scene::CommittedScene;
use crate::sys;

#[cfg(embree_v3)]
fn context() -> sys::RTCIntersectContext {
    // What `rtcInitIntersectContext` (a header-only inline function) does.
    let mut context = sys::RTCIntersectContext {
        flags: sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
        ..Default::default()
    };
    context.instID = [sys::RTC_INVALID_GEOMETRY_ID; sys::RTC_MAX_INSTANCE_LEVEL_COUNT as usize];
    context
}

#[cfg(embree_v4)]
fn occluded_args() -> sys::RTCOccludedArguments {
    // What `rtcInitOccludedArguments` (a header-only inline function) does.
    sys::RTCOccludedArguments {
        flags: sys::RTC_RAY_QUERY_FLAG_INCOHERENT,
        feature_mask: sys::RTC_FEATURE_FLAG_ALL,
        ..Default::default()
    }
}

#[cfg(embree_v4)]
fn intersect_args() -> sys::RTCIntersectArguments {
    // What `rtcInitIntersectArguments` (a header-only inline function) does.
    sys::RTCIntersectArguments {
        flags: sys::RTC_RAY_QUERY_FLAG_INCOHERENT,
        feature_mask: sys::RTC_FEATURE_FLAG_ALL,
        ..Default::default()
    }
}

impl CommittedScene {
    /// Whether anything blocks the segment (`rtcOccluded1`).
    pub fn occluded1(&self, ray: &Ray) -> bool {
        let mut ray = *ray;
        // SAFETY: the scene is committed and alive for the call; `ray` is a valid,
        // 16-byte-aligned RTCRay that Embree may write; the context/arguments are initialised
        // as the headers' inline init functions do, with no filter or user callbacks.
        #[cfg(embree_v3)]
        unsafe {
            sys::rtcOccluded1(self.handle, &mut context(), &mut ray.0)
        };
        // SAFETY: as above, with Embree 4's argument order.
        #[cfg(embree_v4)]
        unsafe {
            sys::rtcOccluded1(self.handle, &mut ray.0, &mut occluded_args())
        };
        ray.is_occluded()
    }

    /// Occlusion for the active lanes of a packet (`rtcOccluded16`); read the answers with
    /// [`Ray16::is_occluded`].
    pub fn occluded16(&self, packet: &mut Ray16) {
        // SAFETY: committed scene; `valid` and `rays` are 64-byte aligned as Embree
        // requires for 16-wide packets, live and writable for the call.
        #[cfg(embree_v3)]
        unsafe {
            sys::rtcOccluded16(
                packet.valid.0.as_ptr(),
                self.handle,
                &mut context(),
                &mut packet.rays,
            )
        };
        // SAFETY: as above, with Embree 4's argument order.
        #[cfg(embree_v4)]
        unsafe {
            sys::rtcOccluded16(
                packet.valid.0.as_ptr(),
                self.handle,
                &mut packet.rays,
                &mut occluded_args(),
            )
        };
    }

    /// Occlusion for a stream of rays; read the answers with [`Ray::is_occluded`].
    /// Embree 3: `rtcOccluded1M`. Embree 4: 16-wide packets.
    pub fn occluded_stream(&self, rays: &mut [Ray]) {
        #[cfg(embree_v3)]
        {
            let mut context = context();
            for chunk in rays.chunks_mut(u32::MAX as usize) {
                // SAFETY: committed scene; `chunk` is a contiguous, writable array of
                // `chunk.len()` RTCRays (`Ray` is `repr(transparent)`), with the byte stride
                // of one RTCRay.
                unsafe {
                    sys::rtcOccluded1M(
                        self.handle,
                        &mut context,
                        chunk.as_mut_ptr().cast::<sys::RTCRay>(),
                        chunk.len() as u32,
                        std::mem::size_of::<sys::RTCRay>(),
                    )
                };
            }
        }
        #[cfg(embree_v4)]
        {
            let mut packet = Ray16::default();
            for chunk in rays.chunks_mut(PACKET_WIDTH) {
                packet.clear();
                for (i, ray) in chunk.iter().enumerate() {
                    packet.set(i, ray.origin(), ray.dir(), ray.0.tnear, ray.0.tfar);
                }
                self.occluded16(&mut packet);
                for (i, ray) in chunk.iter_mut().enumerate() {
                    ray.0.tfar = packet.rays.tfar[i];
                }
            }
        }
    }

    /// The closest hit along the segment, if any (`rtcIntersect1`).
    pub fn intersect1(&self, ray: &Ray) -> Option<Hit> {
        let mut rayhit = RayHit::new(*ray);
        // SAFETY: committed scene; `rayhit` is a valid, aligned RTCRayHit with its
        // hit cleared to the invalid id, writable for the call.
        #[cfg(embree_v3)]
        unsafe {
            sys::rtcIntersect1(self.handle, &mut context(), &mut rayhit.0)
        };
        // SAFETY: as above, with Embree 4's argument order.
        #[cfg(embree_v4)]
        unsafe {
            sys::rtcIntersect1(self.handle, &mut rayhit.0, &mut intersect_args())
        };
        rayhit.hit()
    }

    /// Closest hits for the active lanes of a packet (`rtcIntersect16`); read them with
    /// [`RayHit16::hit`].
    pub fn intersect16(&self, packet: &mut RayHit16) {
        // SAFETY: committed scene; `valid` and `rayhits` are 64-byte aligned,
        // live and writable for the call.
        #[cfg(embree_v3)]
        unsafe {
            sys::rtcIntersect16(
                packet.valid.0.as_ptr(),
                self.handle,
                &mut context(),
                &mut packet.rayhits,
            )
        };
        // SAFETY: as above, with Embree 4's argument order.
        #[cfg(embree_v4)]
        unsafe {
            sys::rtcIntersect16(
                packet.valid.0.as_ptr(),
                self.handle,
                &mut packet.rayhits,
                &mut intersect_args(),
            )
        };
    }

    /// Closest hits for a stream of rays; read them with [`RayHit::hit`].
    /// Embree 3: `rtcIntersect1M`. Embree 4: 16-wide packets.
    pub fn intersect_stream(&self, rays: &mut [RayHit]) {
        #[cfg(embree_v3)]
        {
            let mut context = context();
            for chunk in rays.chunks_mut(u32::MAX as usize) {
                // SAFETY: committed scene; `chunk` is a contiguous, writable array of
                // RTCRayHits (`RayHit` is `repr(transparent)`) with their hits cleared.
                unsafe {
                    sys::rtcIntersect1M(
                        self.handle,
                        &mut context,
                        chunk.as_mut_ptr().cast::<sys::RTCRayHit>(),
                        chunk.len() as u32,
                        std::mem::size_of::<sys::RTCRayHit>(),
                    )
                };
            }
        }
        #[cfg(embree_v4)]
        {
            let mut packet = RayHit16::default();
            for chunk in rays.chunks_mut(PACKET_WIDTH) {
                packet.clear();
                for (i, rh) in chunk.iter().enumerate() {
                    let r = &rh.0.ray;
                    packet.set(
                        i,
                        [r.org_x, r.org_y, r.org_z],
                        [r.dir_x, r.dir_y, r.dir_z],
                        r.tnear,
                        r.tfar,
                    );
                }
                self.intersect16(&mut packet);
                for (i, rh) in chunk.iter_mut().enumerate() {
                    let (ray, hit) = (&packet.rayhits.ray, &packet.rayhits.hit);
                    rh.0.ray.tfar = ray.tfar[i];
                    rh.0.hit.geomID = hit.geomID[i];
                    rh.0.hit.primID = hit.primID[i];
                    rh.0.hit.u = hit.u[i];
                    rh.0.hit.v = hit.v[i];
                    rh.0.hit.Ng_x = hit.Ng_x[i];
                    rh.0.hit.Ng_y = hit.Ng_y[i];
                    rh.0.hit.Ng_z = hit.Ng_z[i];
                }
            }
        }
    }
}
