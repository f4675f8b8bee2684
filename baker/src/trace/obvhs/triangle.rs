//! A watertight ray–triangle test — Embree's robust-mode (Plücker) formulation — for one ray
//! and for four rays at a time.
//!
//! With the vertices taken relative to the ray origin (vᵢ = pᵢ − o), each edge a → b gets the
//! edge function E(a, b) = ((b − a) × (b + a))·d, and
//!
//! ```text
//!     U = E(v0, v2),  V = E(v1, v0),  W = E(v2, v1)
//!     hit  ⇔  min(U, V, W) ≥ 0  or  max(U, V, W) ≤ 0,   n·d ≠ 0,   0 ≤ t ≤ tfar
//! ```
//!
//! with t = ((p0 − o)·n)/(d·n), n = (p1 − p0) × (p2 − p0), and barycentrics u = U/(U+V+W)
//! (the weight of p1), v = V/(U+V+W) (of p2). A shared edge gets, in its two triangles, edge
//! functions computed from the same two floats in swapped order, which are exact negatives of
//! each other: a ray through the edge cannot slip between the triangles, whatever the
//! rounding (and around a vertex, one of the triangles of its fan accepts the ray). Embree's
//! default (Möller–Trumbore) test evaluates each triangle's edges from its own precomputed
//! edge vectors, so rounding can open a crack along a shared edge; at a vertex where a floor
//! meets a wall, the baker's ray origins sit within rounding of the wall's edges and such
//! cracks leak light (`tests/agreement.rs` counts them).
//! Embree's robust mode uses this formulation, tolerance included. (A rigorous bound on each
//! edge function's rounding error, 2⁻¹⁸·‖b − a‖·‖b + a‖·‖d‖, closes vertices for certain
//! but measured far too generous: it accepted thousands of rays in a million that miss by
//! more than rounding.)
//!
//! Both versions here evaluate every product and sum in the same order (the generic [`cross`],
//! [`dot`] and [`edge`]), so four rays tested together get exactly the answers they get one
//! by one.

use std::ops::{Add, Mul, Sub};

use glam::{Vec3A, Vec4};

use super::node::BoxRay;

/// A triangle prepared for the test.
#[derive(Clone, Copy, Debug)]
pub(super) struct Triangle {
    p: [[f32; 3]; 3],
    /// (p1 − p0) × (p2 − p0), unnormalised.
    ng: [f32; 3],
}

/// A hit as edge functions and plane distances: u = `u` / `uvw`, t = `t` / `den`, and so on.
#[derive(Clone, Copy, Debug)]
pub(super) struct ScaledHit {
    pub(super) t: f32,
    pub(super) den: f32,
    pub(super) u: f32,
    pub(super) v: f32,
    pub(super) uvw: f32,
}

impl ScaledHit {
    /// Embree's barycentrics (u, v) of the hit.
    #[inline]
    pub(super) fn barycentrics(&self) -> (f32, f32) {
        let scaled = |x: f32| if self.uvw == 0.0 { 0.0 } else { x / self.uvw };
        (scaled(self.u), scaled(self.v))
    }
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

/// What the test needs of a number type: `f32` for one ray, `Vec4` for four, `f64` for the
/// exact recheck.
trait Lanes: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> {
    fn abs(self) -> Self;
    fn max(self, other: Self) -> Self;
}

macro_rules! lanes {
    ($t:ty) => {
        impl Lanes for $t {
            fn abs(self) -> $t {
                <$t>::abs(self)
            }
            fn max(self, other: $t) -> $t {
                <$t>::max(self, other)
            }
        }
    };
}
lanes!(f32);
lanes!(f64);
lanes!(Vec4);

fn cross<T: Lanes>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot<T: Lanes>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub<T: Lanes>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn add<T: Lanes>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn max_norm<T: Lanes>(a: [T; 3]) -> T {
    a[0].abs().max(a[1].abs()).max(a[2].abs())
}

/// The edge tests accept values down to −ε, ε = 2⁻²³·|U + V + W|, as Embree's robust mode
/// does. Exact negation makes shared edges watertight without it; at a vertex, though, all
/// the edge functions of its fan are near 0 for a ray through it.
const EDGE_TOLERANCE: f32 = f32::EPSILON;

/// Rounding bounds that send a test to the exact recheck: an f32 edge function E(a, b) is off
/// by at most 42u·‖b − a‖∞·‖b + a‖∞·‖d‖∞ (u = 2⁻²⁴), so [`NEAR_EDGE`] = 2⁻¹⁶ ≈ 4 × 42u. The
/// plane distances n·(p0 − o) and n·d, three-term dot products (the first of rounded
/// differences), are off by at most 12u·‖p0 − o‖∞·‖n‖∞ and 9u·‖n‖∞·‖d‖∞; [`NEAR_PLANE`] =
/// 2⁻¹⁹ ≈ 2.7 × 12u. The edge bound is per edge: the cruder 168u·R²·‖d‖∞ (R the largest
/// ‖pᵢ − o‖∞) sent every ray within about a degree of a small triangle's edge to f64.
const NEAR_EDGE: f32 = 1.0 / 65_536.0;
const NEAR_PLANE: f32 = 1.0 / 524_288.0;

/// What the test computes for a triangle with corners `p` and normal `ng` and rays from `o`
/// along `d`: the edge functions [U, V, W], the plane distances n·(p0 − o) and n·d, and
/// whether any of them is within rounding of deciding the other way.
struct Evaluation<T> {
    edges: [T; 3],
    t: T,
    den: T,
    /// The edge functions' rounding bounds, without the constant factor [`NEAR_EDGE`].
    near: [T; 3],
    /// The plane distances' (t's and den's), without [`NEAR_PLANE`].
    near_t: T,
    near_den: T,
}

/// The part of [`Evaluation`] that depends on the origin only: per edge, the cross product
/// (b − a) × (b + a) and ‖b − a‖∞·‖b + a‖∞; the plane distance n·(p0 − o) and its bound. Rays
/// from one origin share it, so a packet from one vertex computes it once per triangle
/// ([`Triangle::seen_from`]); the per-ray part ([`along`]) then does the rest with the
/// same operations in the same order as [`evaluate`], so the answers are identical.
#[derive(Clone, Copy, Debug)]
pub(super) struct FromOrigin<T> {
    edges: [([T; 3], T); 3],
    ng: [T; 3],
    ng_norm: T,
    t: T,
    near_t: T,
}

#[inline(always)]
fn from_origin<T: Lanes>(p: [[T; 3]; 3], ng: [T; 3], o: [T; 3]) -> FromOrigin<T> {
    let v = p.map(|p| sub(p, o));
    let edge = |a: [T; 3], b: [T; 3]| {
        let (diff, sum) = (sub(b, a), add(b, a));
        (cross(diff, sum), max_norm(diff) * max_norm(sum))
    };
    let ng_norm = max_norm(ng);
    FromOrigin {
        edges: [edge(v[0], v[2]), edge(v[1], v[0]), edge(v[2], v[1])],
        ng,
        ng_norm,
        t: dot(v[0], ng),
        near_t: max_norm(v[0]) * ng_norm,
    }
}

#[inline(always)]
fn along<T: Lanes>(f: &FromOrigin<T>, d: [T; 3]) -> Evaluation<T> {
    let d_norm = max_norm(d);
    let [(cu, nu), (cv, nv), (cw, nw)] = f.edges;
    Evaluation {
        edges: [dot(cu, d), dot(cv, d), dot(cw, d)],
        t: f.t,
        den: dot(f.ng, d),
        near: [nu * d_norm, nv * d_norm, nw * d_norm],
        near_t: f.near_t,
        near_den: f.ng_norm * d_norm,
    }
}

#[inline(always)]
fn evaluate<T: Lanes>(p: [[T; 3]; 3], ng: [T; 3], o: [T; 3], d: [T; 3]) -> Evaluation<T> {
    along(&from_origin(p, ng, o), d)
}

/// The decision for one ray, in f32 or f64: edges within tolerance, and t/den in [0, tfar]
/// (t is 0 or has den's sign, and |t| ≤ |den|·tfar), without dividing.
macro_rules! decide {
    ($e:expr, $tfar:expr, $tolerance:expr) => {{
        let e = $e;
        let [u, v, w] = e.edges;
        let eps = $tolerance * (u + v + w).abs();
        let inside = (u.min(v).min(w) >= -eps) || (u.max(v).max(w) <= eps);
        let ahead = e.den != 0.0
            && (e.t == 0.0 || (e.t > 0.0) == (e.den > 0.0))
            && e.t.abs() <= e.den.abs() * $tfar;
        (inside && ahead).then(|| (e.t, e.den, u, v, u + v + w))
    }};
}

impl Triangle {
    pub(super) fn new(p0: Vec3A, p1: Vec3A, p2: Vec3A) -> Triangle {
        // The normal in double precision, rounded once: in f32 the cross product of a thin
        // triangle's two long edges cancels to a few correct bits, and the sign of the
        // distance n·(p0 − o) from a nearby origin to the plane comes out wrong.
        let [a, b, c] = [p0, p1, p2].map(|p| p.as_dvec3());
        Triangle {
            p: [p0.to_array(), p1.to_array(), p2.to_array()],
            ng: (b - a).cross(c - a).as_vec3().to_array(),
        }
    }

    /// The unnormalised geometric normal (p1 − p0) × (p2 − p0).
    pub(super) fn normal(&self) -> Vec3A {
        Vec3A::from_array(self.ng)
    }

    /// The test for one ray.
    #[inline(always)]
    pub(super) fn intersect(&self, ray: &BoxRay) -> Option<ScaledHit> {
        let (o, d) = (ray.origin.to_array(), ray.dir.to_array());
        let e = evaluate(self.p, self.ng, o, d);
        // A triangle certainly behind the origin (t and den certainly non-zero and of
        // opposite signs) is missed whatever its edges say: the common case of a ray leaving
        // a vertex, tested against that vertex's own triangles, whose edges it starts on.
        let certain = e.t.abs() > NEAR_PLANE * e.near_t && e.den.abs() > NEAR_PLANE * e.near_den;
        if certain && (e.t > 0.0) != (e.den > 0.0) {
            return None;
        }
        let near_edge = (0..3).any(|i| e.edges[i].abs() <= NEAR_EDGE * e.near[i]);
        if near_edge || !certain {
            return self.intersect_exact(o, d, ray.tfar);
        }
        decide!(e, ray.tfar, EDGE_TOLERANCE).map(|(t, den, u, v, uvw)| ScaledHit {
            t,
            den,
            u,
            v,
            uvw,
        })
    }

    /// The test in double precision, for rays within f32 rounding of an edge, a vertex or the
    /// plane: exact negation still makes shared edges watertight, and the answers are those of
    /// the geometry up to 2⁻⁵³ rather than 2⁻²⁴.
    #[cold]
    fn intersect_exact(&self, o: [f32; 3], d: [f32; 3], tfar: f32) -> Option<ScaledHit> {
        let double = |v: [f32; 3]| v.map(f64::from);
        let p = self.p.map(double);
        let ng = cross(sub(p[1], p[0]), sub(p[2], p[0]));
        let e = evaluate(p, ng, double(o), double(d));
        let tolerance = f64::from(EDGE_TOLERANCE);
        decide!(e, f64::from(tfar), tolerance).map(|(t, den, u, v, uvw)| ScaledHit {
            t: t as f32,
            den: den as f32,
            u: u as f32,
            v: v as f32,
            uvw: uvw as f32,
        })
    }

    /// The test for four rays: bit i is set if the ray in lane i hits.
    #[inline(always)]
    pub(super) fn hits(&self, rays: &RayGroup) -> u32 {
        let splat = |v: [f32; 3]| v.map(Vec4::splat);
        let shared = from_origin(self.p.map(splat), splat(self.ng), rays.origin);
        self.hits_from(&shared, rays)
    }

    /// The origin's part of the test, for rays that all leave `o`; four-wide, for
    /// [`Triangle::hits_from`].
    #[inline(always)]
    pub(super) fn seen_from(&self, o: Vec3A) -> FromOrigin<Vec4> {
        let f = from_origin(self.p, self.ng, o.to_array());
        let splat = |v: [f32; 3]| v.map(Vec4::splat);
        FromOrigin {
            edges: f.edges.map(|(c, n)| (splat(c), Vec4::splat(n))),
            ng: splat(f.ng),
            ng_norm: Vec4::splat(f.ng_norm),
            t: Vec4::splat(f.t),
            near_t: Vec4::splat(f.near_t),
        }
    }

    /// [`Triangle::hits`] for four rays whose origins' part is `shared` (every lane's origin
    /// gave it).
    #[inline(always)]
    pub(super) fn hits_from(&self, shared: &FromOrigin<Vec4>, rays: &RayGroup) -> u32 {
        let e = along(shared, rays.dir);
        let [u, v, w] = e.edges;
        let eps = (u + v + w).abs() * EDGE_TOLERANCE;
        let inside = u.min(v).min(w).cmpge(-eps) | u.max(v).max(w).cmple(eps);
        let [near_u, near_v, near_w] = e.near.map(|n| n * NEAR_EDGE);
        let certain =
            e.t.abs().cmpgt(e.near_t * NEAR_PLANE) & e.den.abs().cmpgt(e.near_den * NEAR_PLANE);
        let behind = certain & (e.t.cmpgt(Vec4::ZERO) ^ e.den.cmpgt(Vec4::ZERO));
        // As in the one-ray test: no recheck for a triangle certainly behind the origin.
        let near =
            (u.abs().cmple(near_u) | v.abs().cmple(near_v) | w.abs().cmple(near_w) | !certain)
                & !behind;
        if !(inside | near).any() {
            return 0;
        }
        let (zero, t, den) = (Vec4::ZERO, e.t, e.den);
        let signed =
            t.cmpeq(zero) | (t.cmpgt(zero) & den.cmpgt(zero)) | (t.cmplt(zero) & den.cmplt(zero));
        let ahead = signed & den.cmpne(zero) & t.abs().cmple(den.abs() * rays.tfar);
        let mut hits = (inside & ahead).bitmask();
        // Lanes within rounding of the decision: recheck exactly.
        let near = near.bitmask();
        if near != 0 {
            for lane in (0..4).filter(|lane| near & (1 << lane) != 0) {
                let o = rays.origin.map(|c| c[lane]);
                let d = rays.dir.map(|c| c[lane]);
                let hit = self.intersect_exact(o, d, rays.tfar[lane]).is_some();
                hits = (hits & !(1 << lane)) | (u32::from(hit) << lane);
            }
        }
        hits
    }
}
