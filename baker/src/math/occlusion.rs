//! The visibility of spheres in SH, in closed form: what a set of spheres (a moving occluder's
//! fitted stand-in) leaves visible of the sphere of directions around a receiver.
//!
//! Seen from a receiver at distance d, a sphere of radius r blocks a cap of half-angle
//! α = asin(r/d) about the direction a to its centre. The cap's indicator is a zonal function
//! about a; its zonal coefficients are c_0 = 2π(1 − cos α)·y_0^0 and, for l ≥ 1,
//! c_l = 2π·K_l·(P_{l−1}(cos α) − P_{l+1}(cos α))/(2l+1) (∫_{cos α}^1 P_l). Turned to a, its
//! coefficients are sqrt(4π/(2l+1))·c_l·y_l^m(a): n² polynomial terms, no rotation matrix.
//! The sphere's visibility is 1 − cap, and several spheres' visibilities multiply (a direction
//! is open only if every sphere leaves it open), by truncated SH triple products.

use glam::DVec3;

use crate::math::sh::triple::Gaunt;
use crate::math::sh::{Basis, coeff_count, index, legendre, normalization};

/// A sphere in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub centre: DVec3,
    pub radius: f64,
}

/// Spheres farther than this many radii from a receiver are left out: the cap they block is
/// at most 2π(1 − cos asin(1/10)) ≈ 0.031 sr, under 1 % of a uniform sky's irradiance.
pub const REACH: f64 = 10.0;

/// The zonal coefficients c_l (l < order) of the indicator of a cap of half-angle α about +z.
pub fn cap_zonal(order: usize, cos_alpha: f64) -> Vec<f64> {
    (0..order)
        .map(|l| {
            let integral = if l == 0 {
                1.0 - cos_alpha
            } else {
                (legendre(l - 1, 0, cos_alpha) - legendre(l + 1, 0, cos_alpha)) / (2 * l + 1) as f64
            };
            std::f64::consts::TAU * normalization(l, 0) * integral
        })
        .collect()
}

/// Computes visibilities of sphere sets at one order: the cap's basis evaluation and the
/// triple product that combines spheres.
#[derive(Clone, Debug)]
pub struct Occlusion {
    basis: Basis,
    gaunt: Gaunt,
}

impl Occlusion {
    pub fn new(order: usize) -> Occlusion {
        Occlusion {
            basis: Basis::new(order),
            gaunt: Gaunt::new(order),
        }
    }

    pub fn order(&self) -> usize {
        self.basis.order()
    }

    pub fn gaunt(&self) -> &Gaunt {
        &self.gaunt
    }

    /// Writes into `out` the SH of the visibility one sphere leaves a receiver at `point`
    /// (1 − the cap it blocks); a receiver inside the sphere sees nothing (all zero).
    pub fn sphere_visibility(&self, point: DVec3, sphere: &Sphere, out: &mut [f64]) {
        let order = self.order();
        let to_centre = sphere.centre - point;
        let d = to_centre.length();
        if d <= sphere.radius {
            out[..coeff_count(order)].fill(0.0);
            return;
        }
        let sin_alpha = sphere.radius / d;
        let cap = cap_zonal(order, (1.0 - sin_alpha * sin_alpha).sqrt());
        self.basis.eval_recurrence(to_centre / d, out);
        for (l, c) in cap.iter().enumerate() {
            let scale = -(4.0 * std::f64::consts::PI / (2 * l + 1) as f64).sqrt() * c;
            for m in -(l as i32)..=l as i32 {
                out[index(l, m)] *= scale;
            }
        }
        out[0] += (4.0 * std::f64::consts::PI).sqrt();
    }

    /// The visibility the `spheres` leave a receiver at `point` with normal `normal`, the
    /// product of each sphere's, into `out`; `false` (and `out` untouched) where none is within
    /// [`REACH`] radii and above the receiver's horizon, so the receiver keeps its transfer.
    pub fn visibility(
        &self,
        point: DVec3,
        normal: DVec3,
        spheres: &[Sphere],
        out: &mut [f64],
    ) -> bool {
        let n = coeff_count(self.order());
        let mut one = vec![0.0; n];
        let mut product = vec![0.0; n];
        let mut any = false;
        for sphere in spheres {
            let offset = sphere.centre - point;
            let distance = offset.length();
            // Far, or wholly below the receiver's plane (where its transfer is zero).
            if distance > REACH * sphere.radius || offset.dot(normal) < -sphere.radius {
                continue;
            }
            self.sphere_visibility(point, sphere, &mut one);
            if any {
                self.gaunt.product(&out[..n], &one, &mut product);
                out[..n].copy_from_slice(&product);
            } else {
                out[..n].copy_from_slice(&one);
                any = true;
            }
        }
        any
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cap_zonal_matches_quadrature_of_the_indicator() {
        let (nodes, weights) = crate::math::sh::gauss_legendre(400);
        let cos_alpha = 0.3f64;
        let cap = cap_zonal(6, cos_alpha);
        for (l, c) in cap.iter().enumerate() {
            // ∫_cap y_l^0 = 2π K_l ∫_{cos α}^1 P_l(t) dt, by quadrature mapped to [cos α, 1].
            let half = (1.0 - cos_alpha) / 2.0;
            let integral: f64 = nodes
                .iter()
                .zip(&weights)
                .map(|(x, w)| w * half * legendre(l, 0, cos_alpha + half * (x + 1.0)))
                .sum();
            let expected = std::f64::consts::TAU * normalization(l, 0) * integral;
            assert!((c - expected).abs() < 1e-12, "l={l}: {c} vs {expected}");
        }
    }

    #[test]
    fn sphere_visibility_integrates_to_the_open_solid_angle() {
        let occlusion = Occlusion::new(4);
        let sphere = Sphere {
            centre: DVec3::new(0.3, -0.2, 2.0),
            radius: 1.0,
        };
        let mut v = vec![0.0; 16];
        occlusion.sphere_visibility(DVec3::ZERO, &sphere, &mut v);
        let d = sphere.centre.length();
        let cos_alpha = (1.0 - 1.0 / (d * d)).sqrt();
        let open = 4.0 * std::f64::consts::PI - std::f64::consts::TAU * (1.0 - cos_alpha);
        // ∫ V = sqrt(4π)·V_0.
        assert!((v[0] * (4.0 * std::f64::consts::PI).sqrt() - open).abs() < 1e-12);
        // Band 1 points away from the sphere: −(its direction).
        let band1 = DVec3::new(-v[3], -v[1], v[2]);
        assert!(band1.normalize().dot(-sphere.centre.normalize()) > 1.0 - 1e-12);
    }
}
