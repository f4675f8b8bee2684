//! A double-precision referee for the rays two backends answer differently.
//!
//! The referee tests every triangle in f64 (Möller–Trumbore, barycentrics ≥ 0 and
//! 0 ≤ t ≤ tfar, no tolerance) for the ray and for copies of it moved by up to
//! [`PERTURBATION`]: the origin along ±x, ±y, ±z and the direction tilted four ways, each by
//! the full amount, an eighth and a sixty-fourth of it (a feature thinner than the largest
//! move could be jumped over). If all 31 rays get the same answer, the answer is *stable* and
//! a backend that gives another one is wrong. If not, the ray passes within rounding of an
//! edge, a vertex or a surface — where no f32 computation has a defined answer — and the
//! disagreement is *ambiguous*.
//!
//! A backend's f32 arithmetic errs by a few ulps of the numbers it combines: the disputed
//! triangles' corners relative to the ray origin, and the direction. So the origin moves by
//! [`PERTURBATION`] times the largest of those distances, not by a fraction of the scene: a
//! ray leaving a surface starts 8 ulps above it, and a move on the scale of the scene would
//! carry it through.

use glam::{DVec3, Vec3};
use prt_baker::Scene;
use prt_baker::trace::Ray;

/// The perturbations, relative to the distances involved (for the origin) and to the
/// direction: 2⁻²⁰, 8 f32 ulps, so any answer that can go either way within the backends'
/// rounding flips within them.
pub const PERTURBATION: f64 = 1.0 / 1_048_576.0;

pub struct Referee {
    triangles: Vec<[DVec3; 3]>,
    size: f64,
}

/// The referee's answer for a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict<T> {
    /// The same for the ray and all its perturbations.
    Stable(T),
    Ambiguous,
}

fn double(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

impl Referee {
    pub fn new(scene: &Scene) -> Referee {
        let (lo, hi) = scene.positions.iter().fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        Referee {
            triangles: scene
                .triangles
                .iter()
                .map(|t| t.map(|i| double(scene.positions[i as usize])))
                .collect(),
            size: f64::from((hi - lo).max_element()),
        }
    }

    /// The closest triangle hit in exact-enough arithmetic, and its distance.
    pub fn closest(&self, origin: DVec3, dir: DVec3, tfar: f64) -> Option<(u32, f64)> {
        let mut best: Option<(u32, f64)> = None;
        for (i, [a, b, c]) in self.triangles.iter().enumerate() {
            let (e1, e2) = (*b - *a, *c - *a);
            let p = dir.cross(e2);
            let det = e1.dot(p);
            if det == 0.0 {
                continue;
            }
            let s = origin - *a;
            let u = s.dot(p) / det;
            let q = s.cross(e1);
            let v = dir.dot(q) / det;
            let t = e2.dot(q) / det;
            let inside = u >= 0.0 && v >= 0.0 && u + v <= 1.0;
            if inside && (0.0..=tfar).contains(&t) && best.is_none_or(|(_, b)| t < b) {
                best = Some((i as u32, t));
            }
        }
        best
    }

    /// The ray and its 30 perturbations, in f64, for a dispute over `triangles`.
    fn perturbations(&self, ray: &Ray, triangles: &[u32]) -> impl Iterator<Item = (DVec3, DVec3)> {
        let (origin, dir) = (double(ray.origin), double(ray.dir));
        let reach = triangles
            .iter()
            .flat_map(|&t| self.triangles[t as usize])
            .map(|v| (v - origin).abs().max_element())
            .fold(0.0, f64::max);
        // With no triangle in dispute (cannot happen for a disagreement), the scene's size.
        let reach = if reach > 0.0 { reach } else { self.size };
        let (a, b) = dir.normalize().any_orthonormal_pair();
        let moves = [1.0, 1.0 / 8.0, 1.0 / 64.0]
            .into_iter()
            .flat_map(move |scale| {
                let shift = PERTURBATION * reach * scale;
                let tilt = PERTURBATION * dir.length() * scale;
                let origins = [
                    DVec3::X,
                    DVec3::Y,
                    DVec3::Z,
                    -DVec3::X,
                    -DVec3::Y,
                    -DVec3::Z,
                ]
                .map(|axis| (origin + axis * shift, dir));
                let dirs = [a, -a, b, -b].map(|t| (origin, dir + t * tilt));
                origins.into_iter().chain(dirs)
            });
        std::iter::once((origin, dir)).chain(moves)
    }

    fn verdict<T: PartialEq>(
        &self,
        ray: &Ray,
        triangles: &[u32],
        answer: impl Fn(DVec3, DVec3) -> T,
    ) -> Verdict<T> {
        let mut answers = self
            .perturbations(ray, triangles)
            .map(|(o, d)| answer(o, d));
        let first = answers.next().expect("the ray itself");
        if answers.all(|a| a == first) {
            Verdict::Stable(first)
        } else {
            Verdict::Ambiguous
        }
    }

    /// Whether the segment is blocked; `triangles` are those the backends reported.
    pub fn occlusion(&self, ray: &Ray, triangles: &[u32]) -> Verdict<bool> {
        let tfar = f64::from(ray.tfar);
        self.verdict(ray, triangles, |o, d| self.closest(o, d, tfar).is_some())
    }

    /// Which triangle the ray hits first, if any; `triangles` are those the backends reported.
    pub fn closest_triangle(&self, ray: &Ray, triangles: &[u32]) -> Verdict<Option<u32>> {
        let tfar = f64::from(ray.tfar);
        self.verdict(ray, triangles, |o, d| {
            self.closest(o, d, tfar).map(|(i, _)| i)
        })
    }
}
