//! Transfer-matrix oracles (issue 20): `bake --transfer matrix` through the real estimator and
//! Embree, against M_ij = ∫ V y_i y_j over the visible directions computed by quadrature, at
//! order 4 with 16,384 rays, within 0.01 per entry.
//!
//! * an unoccluded surface (normal tilted off every axis, so the rotation into world space is
//!   tested): M is the hemisphere's ∫ y_i y_j;
//! * under a coaxial disk and at the bottom of a hemispherical bowl (the scenes of
//!   visibility_oracles.rs): M is the visible band's ∫ y_i y_j;
//! * the clamped cosine projected through M, (1/π)·M·ĉ, is the diffuse vector bake up to the
//!   band-limit error stated in docs/glossy.md: |(1/π)(M·ĉ)_j − T_j| ≤ ‖r‖/π, r the part of
//!   max(cos θ, 0) above band n−1; and equals the quadrature's own (1/π)·M·ĉ − T.

use glam::{DVec3, Vec3};
use prt_baker::bake::matrix::receiver_matrices;
use prt_baker::bake::options::TransferKind;
use prt_baker::bake::transfer::Estimator;
use prt_baker::math::sh;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer, Tracer};
use prt_baker::{BakeOptions, Mode, Scene};
use prt_tests::*;

const ORDER: usize = 4;
const SAMPLES: u32 = 16_384;
/// The tolerance per matrix entry (and per projected coefficient).
const TOLERANCE: f64 = 0.01;

fn matrix_options(mode: Mode) -> BakeOptions {
    BakeOptions {
        transfer: TransferKind::Matrix,
        mode,
        ..shadowed(ORDER, SAMPLES)
    }
}

/// Vertex `v`'s baked matrix (n² × n², row-major), alone, through Embree.
fn bake_matrix(scene: &Scene, mode: Mode, v: usize) -> Vec<f64> {
    let options = matrix_options(mode);
    let tracer = EmbreeTracer::new(scene, EmbreeOptions::default()).expect("embree scene");
    let estimator = Estimator::new(scene, &options).expect("valid options");
    let tracer = (mode == Mode::Shadowed).then_some(&tracer as &dyn Tracer);
    receiver_matrices(&estimator, tracer, v..v + 1)
        .into_iter()
        .map(f64::from)
        .collect()
}

/// ∫ y_i y_j over the directions around `axis` with axis·s in [t_lo, t_hi], by quadrature.
fn band_matrix(axis: DVec3, t_lo: f64, t_hi: f64) -> Vec<f64> {
    let n = sh::coeff_count(ORDER);
    let mut m = vec![0.0; n * n];
    band_quadrature(ORDER, axis, t_lo, t_hi, |w, _, y| {
        for i in 0..n {
            for j in 0..n {
                m[i * n + j] += w * y[i] * y[j];
            }
        }
    });
    m
}

/// The largest |got − expected| entry, printed; fails beyond [`TOLERANCE`].
fn assert_close(what: &str, got: &[f64], expected: &[f64]) {
    assert_eq!(got.len(), expected.len());
    let n = sh::coeff_count(ORDER);
    let (worst, k) = got
        .iter()
        .zip(expected)
        .enumerate()
        .map(|(k, (g, e))| ((g - e).abs(), k))
        .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
    eprintln!(
        "{what}: worst entry ({}, {}) off by {worst:.2e} (got {:.5}, expected {:.5})",
        k / n,
        k % n,
        got[k],
        expected[k]
    );
    assert!(
        worst <= TOLERANCE,
        "{what}: entry ({}, {}) is {} but should be {} (± {TOLERANCE})",
        k / n,
        k % n,
        got[k],
        expected[k]
    );
}

/// A lone patch at the origin with normal `normal`: nothing to block its rays.
fn open_patch(normal: Vec3) -> Scene {
    scene(vec![patch(Vec3::ZERO, normal, 0.1)])
}

#[test]
fn an_unoccluded_surface_sees_the_hemisphere() {
    let normal = Vec3::new(0.3, -0.5, 0.8).normalize();
    let expected = band_matrix(normal.as_dvec3(), 0.0, 1.0);
    // The hemisphere's M_00 is half the sphere's ∫ y_0² = 1.
    assert!((expected[0] - 0.5).abs() < 1e-12);
    let scene = open_patch(normal);
    assert_close(
        "open surface, shadowed",
        &bake_matrix(&scene, Mode::Shadowed, 0),
        &expected,
    );
    assert_close(
        "open surface, unshadowed",
        &bake_matrix(&scene, Mode::Unshadowed, 0),
        &expected,
    );
}

/// The point under a disk of radius 1 at height 1: the cone of 45° about the normal hidden.
fn disk_scene() -> Scene {
    scene(vec![
        patch(Vec3::ZERO, Vec3::Z, 0.1),
        disk(Vec3::Z, 1.0, 512),
    ])
}

#[test]
fn under_a_coaxial_disk_the_visible_band_remains() {
    let got = bake_matrix(&disk_scene(), Mode::Shadowed, 0);
    let expected = band_matrix(DVec3::Z, 0.0, std::f64::consts::FRAC_1_SQRT_2);
    assert_close("under the disk", &got, &expected);
}

#[test]
fn at_the_bottom_of_a_bowl_the_visible_cap_remains() {
    let bowl = scene(vec![spherical_cap(
        Vec3::Z,
        1.0,
        std::f32::consts::FRAC_PI_2,
        96,
        256,
        false,
    )]);
    assert_eq!(bowl.normals[0], Vec3::Z);
    let got = bake_matrix(&bowl, Mode::Shadowed, 0);
    let expected = band_matrix(DVec3::Z, std::f64::consts::FRAC_1_SQRT_2, 1.0);
    assert_close("bowl bottom", &got, &expected);
}

/// (1/π)·M·ĉ.
fn project_cosine(m: &[f64], c: &[f64]) -> Vec<f64> {
    let n = c.len();
    (0..n)
        .map(|i| (0..n).map(|j| m[i * n + j] * c[j]).sum::<f64>() / std::f64::consts::PI)
        .collect()
}

#[test]
fn the_clamped_cosine_through_the_matrix_is_the_diffuse_bake() {
    let n = sh::coeff_count(ORDER);
    // ĉ: max(n·s, 0) projected to order 4 about the normal (+z): only zonal terms.
    let mut cosine = vec![0.0; n];
    for l in 0..ORDER {
        cosine[sh::index(l, 0)] = clamped_cosine_zonal(l);
    }
    // The stated band-limit error: ‖r‖/π, ‖r‖² = ∫_H cos² − Σ_{l<n} ĉ_l² = 2π/3 − Σ ĉ_l².
    let tail = (std::f64::consts::TAU / 3.0 - cosine.iter().map(|c| c * c).sum::<f64>()).sqrt();
    let bound = tail / std::f64::consts::PI;
    eprintln!("band-limit bound at order {ORDER}: {bound:.4}");
    let t_cut = std::f64::consts::FRAC_1_SQRT_2;
    let scene = disk_scene();
    let matrix = bake_matrix(&scene, Mode::Shadowed, 0);
    let projected = project_cosine(&matrix, &cosine);
    let vector = &bake_vertices(&scene, &shadowed(ORDER, SAMPLES), &[0])[0];
    // What quadrature says the two differ by, band limit and all.
    let exact_projected = project_cosine(&band_matrix(DVec3::Z, 0.0, t_cut), &cosine);
    let exact_vector = band_moments(ORDER, DVec3::Z, 0.0, t_cut).mean;
    for j in 0..n {
        let difference = projected[j] - vector[j];
        let expected = exact_projected[j] - exact_vector[j];
        eprintln!(
            "j = {j:2}: (1/π)M·ĉ = {:+.5}, T = {:+.5}, difference {difference:+.5} \
             (quadrature {expected:+.5})",
            projected[j], vector[j]
        );
        assert!(
            difference.abs() <= bound + TOLERANCE,
            "coefficient {j}: (1/π)M·ĉ − T = {difference}, beyond the band-limit bound {bound}"
        );
        assert!(
            (difference - expected).abs() <= TOLERANCE,
            "coefficient {j}: (1/π)M·ĉ − T = {difference}, quadrature says {expected}"
        );
    }
}

#[test]
fn matrix_bakes_are_bit_identical_for_any_thread_count() {
    let scene = disk_scene();
    let options = BakeOptions {
        samples: 1024,
        ..matrix_options(Mode::Shadowed)
    };
    let bake_with = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        pool.install(|| bake_scene(&scene, &options))
    };
    let one = bake_with(1);
    let three = bake_with(3);
    let n = sh::coeff_count(ORDER);
    assert_eq!(one.coefficients.len(), scene.vertex_count() * n * n);
    let bits = |t: &prt_baker::Transfer| {
        t.coefficients
            .iter()
            .map(|c| c.to_bits())
            .collect::<Vec<_>>()
    };
    assert!(bits(&one) == bits(&three), "1 and 3 threads differ");
    // Every matrix is symmetric, exactly.
    for m in one.coefficients.chunks_exact(n * n) {
        for i in 0..n {
            for j in 0..n {
                assert_eq!(m[i * n + j].to_bits(), m[j * n + i].to_bits());
            }
        }
    }
}
