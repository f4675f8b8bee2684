//! Embree's Möller–Trumbore ray–triangle test (its default, non-robust intersector), for one
//! ray and for four rays at a time.
//!
//! Embree precomputes e1 = v0 − v1, e2 = v2 − v0 and n = e2 × e1 = (v1 − v0) × (v2 − v0), and
//! for a ray (o, d) with c = v0 − o, r = c × d, den = n·d evaluates
//!
//! ```text
//!     U = ±(r·e2),  V = ±(r·e1),  T = ±(n·c)     (± the sign of den)
//!     hit  ⇔  den ≠ 0,  U ≥ 0,  V ≥ 0,  U + V ≤ |den|,  0 < T ≤ |den|·tfar
//! ```
//!
//! with barycentrics u = U/|den| (the weight of v1), v = V/|den| (of v2) and t = T/|den|.
//! Edges count, so a ray through a shared edge hits one of its two triangles unless rounding
//! tips both tests the other way; hits at t = 0 do not. (Embree flips signs by xor-ing den's
//! sign bit; multiplying by ±1 gives the same numbers.) obvhs's own test differs: it rejects
//! barycentrics of −0, so rays through edges slip between triangles more often.
//!
//! Both versions evaluate every product and sum in the same order (the generic [`cross`] and
//! [`dot`]), so four rays tested together get exactly the answers they get one by one.

use std::ops::{Add, Mul, Sub};

use glam::{Vec3A, Vec4};

use super::node::BoxRay;

/// A triangle prepared for the test.
#[derive(Clone, Copy, Debug)]
pub(super) struct Triangle {
    v0: [f32; 3],
    /// v0 − v1.
    e1: [f32; 3],
    /// v2 − v0.
    e2: [f32; 3],
    /// e2 × e1 = (v1 − v0) × (v2 − v0), unnormalised.
    ng: [f32; 3],
}

/// A hit before the division by |den|: t = `t` / `det`, and so on.
#[derive(Clone, Copy, Debug)]
pub(super) struct ScaledHit {
    pub(super) t: f32,
    pub(super) u: f32,
    pub(super) v: f32,
    pub(super) det: f32,
}

/// Four rays, one per lane (a lane may repeat another ray).
#[derive(Clone, Copy, Debug)]
pub(super) struct RayGroup {
    origin: [Vec4; 3],
    dir: [Vec4; 3],
    tfar: Vec4,
}

impl RayGroup {
    /// `rays` (one to four of them) in lanes 0, 1, …; missing lanes repeat the last ray.
    pub(super) fn new(rays: &[BoxRay]) -> RayGroup {
        let lane = |i: usize| &rays[i.min(rays.len() - 1)];
        let lanes =
            |f: &dyn Fn(&BoxRay) -> f32| Vec4::new(f(lane(0)), f(lane(1)), f(lane(2)), f(lane(3)));
        RayGroup {
            origin: [
                lanes(&|r| r.origin.x),
                lanes(&|r| r.origin.y),
                lanes(&|r| r.origin.z),
            ],
            dir: [
                lanes(&|r| r.dir.x),
                lanes(&|r| r.dir.y),
                lanes(&|r| r.dir.z),
            ],
            tfar: lanes(&|r| r.tfar),
        }
    }
}

fn cross<T: Copy + Mul<Output = T> + Sub<Output = T>>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot<T: Copy + Mul<Output = T> + Add<Output = T>>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub<T: Copy + Sub<Output = T>>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

impl Triangle {
    pub(super) fn new(v0: Vec3A, v1: Vec3A, v2: Vec3A) -> Triangle {
        let (v0, v1, v2) = (v0.to_array(), v1.to_array(), v2.to_array());
        let e1 = sub(v0, v1);
        let e2 = sub(v2, v0);
        Triangle {
            v0,
            e1,
            e2,
            ng: cross(e2, e1),
        }
    }

    /// The unnormalised geometric normal (v1 − v0) × (v2 − v0).
    pub(super) fn normal(&self) -> Vec3A {
        Vec3A::from_array(self.ng)
    }

    /// The test for one ray.
    #[inline(always)]
    pub(super) fn intersect(&self, ray: &BoxRay) -> Option<ScaledHit> {
        let dir = ray.dir.to_array();
        let c = sub(self.v0, ray.origin.to_array());
        let r = cross(c, dir);
        let den = dot(self.ng, dir);
        let (det, sign) = (den.abs(), den.signum());
        let u = dot(r, self.e2) * sign;
        let v = dot(r, self.e1) * sign;
        if !(den != 0.0 && u >= 0.0 && v >= 0.0 && u + v <= det) {
            return None;
        }
        let t = dot(self.ng, c) * sign;
        (0.0 < t && t <= det * ray.tfar).then_some(ScaledHit { t, u, v, det })
    }

    /// The test for four rays: bit i is set if the ray in lane i hits.
    #[inline(always)]
    pub(super) fn hits(&self, rays: &RayGroup) -> u32 {
        let splat = |v: [f32; 3]| v.map(Vec4::splat);
        let ng = splat(self.ng);
        let c = sub(splat(self.v0), rays.origin);
        let r = cross(c, rays.dir);
        let den = dot(ng, rays.dir);
        let (det, sign) = (den.abs(), den.signum());
        let u = dot(r, splat(self.e2)) * sign;
        let v = dot(r, splat(self.e1)) * sign;
        let inside =
            den.cmpne(Vec4::ZERO) & u.cmpge(Vec4::ZERO) & v.cmpge(Vec4::ZERO) & (u + v).cmple(det);
        if !inside.any() {
            return 0;
        }
        let t = dot(ng, c) * sign;
        (inside & Vec4::ZERO.cmplt(t) & t.cmple(det * rays.tfar)).bitmask()
    }
}
