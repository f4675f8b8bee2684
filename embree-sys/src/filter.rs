//! Per-geometry hit filters: Embree calls them for every candidate hit on a geometry that has
//! one (closest-hit and occlusion queries alike), and a rejected hit is as if the ray had
//! missed that triangle. Alpha-tested (cut-out) surfaces are built on them; geometries
//! without a filter keep Embree's fast path.

use crate::sys;

/// Decides whether a candidate hit counts. Called from Embree's threads, concurrently: it
/// must not panic (a panic cannot unwind through Embree and aborts).
pub trait HitFilter: Send + Sync {
    /// Whether the ray `origin + t·dir` hitting triangle `prim_id` of the filtered geometry
    /// at barycentrics (u, v) counts.
    fn accept(&self, prim_id: u32, u: f32, v: f32, origin: [f32; 3], dir: [f32; 3]) -> bool;
}

/// The `RTCFilterFunctionN` installed as both the intersection and the occlusion filter of a
/// filtered geometry; its user pointer is a `*const Box<dyn HitFilter>` owned by the scene.
///
/// # Safety
/// Called by Embree only, with `args` as Embree documents: `N` lanes, `valid` writable, ray
/// and hit in the `RTCRayN` / `RTCHitN` structure-of-arrays layouts (`rtcore_ray.h`'s
/// `RTCRayN_org_x` … `RTCHitN_primID` accessors), and the user pointer set by
/// [`crate::SceneBuilder::add_filtered_triangle_mesh`], alive as long as the scene.
pub(crate) unsafe extern "C" fn filter_hits(args: *const sys::RTCFilterFunctionNArguments) {
    // SAFETY: see the function's contract.
    let args = unsafe { &*args };
    // SAFETY: the user pointer is the scene's boxed filter (see the contract).
    let filter = unsafe { &*(args.geometryUserPtr as *const Box<dyn HitFilter>) };
    let n = args.N as usize;
    let ray = args.ray as *const f32;
    let hit = args.hit as *const f32;
    for i in 0..n {
        // SAFETY: `valid` has N entries; the ray and hit arrays have N lanes per field, at the
        // offsets of Embree's accessors (org 0–2, dir 4–6; u 3, v 4, primID 5).
        unsafe {
            let valid = args.valid.add(i);
            if *valid == 0 {
                continue;
            }
            let at = |base: *const f32, field: usize| *base.add(field * n + i);
            let origin = [at(ray, 0), at(ray, 1), at(ray, 2)];
            let dir = [at(ray, 4), at(ray, 5), at(ray, 6)];
            let prim_id = *(hit as *const u32).add(5 * n + i);
            if !filter.accept(prim_id, at(hit, 3), at(hit, 4), origin, dir) {
                *valid = 0;
            }
        }
    }
}
