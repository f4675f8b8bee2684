//! The SH conventions against closed forms: the oracle table itself, and the clamped-cosine
//! lobe through the real baker (Embree, shadowed mode) on a single unoccluded triangle, for
//! the +z normal and for random normals (which exercises the local-to-world rotation).

use glam::{DVec3, Vec3};
use prt_baker::math::sampling::{Pcg32, uniform_sphere};
use prt_baker::math::sh;
use prt_tests::*;

/// oracles.md, "Unoccluded point": zonal l = 0..6 (×π of the transfer).
const CLAMPED_COSINE: [f64; 7] = [0.886227, 1.023327, 0.495416, 0.0, -0.110778, 0.0, 0.049927];
/// oracles.md, bottom of a hemispherical bowl (visible cone of 45°), l = 0..4.
const BOWL_BOTTOM: [f64; 5] = [0.443113, 0.661526, 0.619270, 0.414495, 0.152320];
/// oracles.md, point under a coaxial disk with r = h (an occluded cone of 45°): the visible
/// region's zonal coefficients, l = 0..4.
const UNDER_DISK: [f64; 5] = [0.443113, 0.361801, -0.123854, -0.414495, -0.263099];
/// The tables are printed to 6 decimals.
const TABLE_PRECISION: f64 = 1e-6;

#[test]
fn oracle_helpers_reproduce_the_oracle_tables() {
    let cos45 = std::f64::consts::FRAC_1_SQRT_2;
    for (l, &z) in CLAMPED_COSINE.iter().enumerate() {
        assert!(
            (clamped_cosine_zonal(l) - z).abs() < TABLE_PRECISION,
            "l={l}: {}",
            clamped_cosine_zonal(l)
        );
    }
    for (l, &z) in BOWL_BOTTOM.iter().enumerate() {
        assert!(
            (visible_cone_zonal(l, cos45) - z).abs() < TABLE_PRECISION,
            "bowl l={l}"
        );
    }
    for (l, &z) in UNDER_DISK.iter().enumerate() {
        // The visible region is the hemisphere minus the occluded 45° cone.
        let visible = clamped_cosine_zonal(l) - visible_cone_zonal(l, cos45);
        assert!(
            (visible - z).abs() < TABLE_PRECISION,
            "disk l={l}: {visible}"
        );
        assert!((BOWL_BOTTOM[l] + z - CLAMPED_COSINE[l]).abs() < 2.0 * TABLE_PRECISION);
    }
    // The quadrature moments agree with the closed form (l ≤ 6, normal +z).
    let moments = band_moments(7, DVec3::Z, 0.0, 1.0);
    for l in 0..7 {
        let j = sh::index(l, 0);
        assert!((moments.mean[j] * std::f64::consts::PI - clamped_cosine_zonal(l)).abs() < 1e-10);
    }
}

/// Expected transfer of an unoccluded point with normal n: √(4π/(2l+1))·z_l·y_l^m(n) / π.
fn clamped_cosine_transfer(order: usize, normal: DVec3) -> Vec<f64> {
    let (theta, phi) = sh::angles(normal);
    (0..sh::coeff_count(order))
        .map(|j| {
            let (l, m) = sh::band_and_m(j);
            let scale = (4.0 * std::f64::consts::PI / (2 * l + 1) as f64).sqrt();
            scale * clamped_cosine_zonal(l) * sh::eval_slow(l, m, theta, phi) / std::f64::consts::PI
        })
        .collect()
}

fn check_unoccluded_patch(normal: Vec3, samples: u32) {
    let order = 7; // bands 0..6, as far as the oracle table goes
    let scene = scene(vec![patch(Vec3::new(0.3, -0.2, 0.1), normal, 0.5)]);
    let baked = bake_vertices(&scene, &shadowed(order, samples), &[0, 1, 2]);
    let mut expected = band_moments(order, normal.as_dvec3(), 0.0, 1.0);
    let closed_form = clamped_cosine_transfer(order, normal.as_dvec3());
    for (q, c) in expected.mean.iter().zip(&closed_form) {
        assert!(
            (q - c).abs() < 1e-10,
            "quadrature {q} and closed form {c} disagree"
        );
    }
    expected.mean = closed_form;
    for (v, got) in baked.iter().enumerate() {
        assert_matches(
            &format!("normal {normal}, vertex {v}"),
            got,
            &expected,
            samples,
        );
    }
}

#[test]
fn clamped_cosine_through_the_baker_for_the_z_normal() {
    check_unoccluded_patch(Vec3::Z, 1 << 16);
}

#[test]
fn clamped_cosine_through_the_baker_for_random_normals() {
    let mut rng = Pcg32::new(2024, 1);
    for _ in 0..8 {
        let normal = uniform_sphere(rng.next_f32(), rng.next_f32()).normalize();
        check_unoccluded_patch(normal, 1 << 14);
    }
    // Axis-aligned and near-axis normals are the special cases of frame construction.
    for normal in [
        -Vec3::Z,
        Vec3::X,
        -Vec3::Y,
        Vec3::new(1e-4, 0.0, -1.0).normalize(),
    ] {
        check_unoccluded_patch(normal, 1 << 14);
    }
}
