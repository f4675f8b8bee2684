//! Transfer-matrix oracles: `bake --transfer matrix` through the real estimator and
//! Embree, against M_ij = ∫ V y_i y_j over the visible directions computed by quadrature, at
//! order 4 with 16,384 rays, within 0.01 per entry.
//!
//! * an unoccluded surface (normal tilted off every axis, so the rotation into world space is
//!   tested): M is the hemisphere's ∫ y_i y_j;
//! * under a coaxial disk and at the bottom of a hemispherical bowl (the scenes of
//!   visibility_oracles.rs): M is the visible band's ∫ y_i y_j;
//! * the clamped cosine projected through M, (1/π)·M·ĉ, is the diffuse vector bake up to the
//!   band-limit error stated in docs/guides/glossy.md: |(1/π)(M·ĉ)_j − T_j| ≤ ‖r‖/π, r the part of
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
/// The required tolerance per matrix entry (and per projected coefficient).
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
    assert_entries_close(what, got, expected, sh::coeff_count(ORDER), TOLERANCE);
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

// ---------------------------------------------------------------------------------------------
// Interreflected matrices (`--mode interreflected`): M^c = ∫ V y_i y_j + ∫_blocked y_i ρ_c T^c_j(h)

/// `mesh` with the diffuse albedo `kd`.
fn with_albedo(mut mesh: prt_baker::scene::Mesh, kd: Vec3) -> prt_baker::scene::Mesh {
    mesh.material = prt_baker::scene::Material {
        name: format!("kd {kd}"),
        kd,
        ..Default::default()
    };
    mesh
}

fn interreflected_options(bounces: u32, samples: u32) -> BakeOptions {
    BakeOptions {
        mode: Mode::Interreflected,
        bounces,
        ..shadowed(ORDER, samples)
    }
}

/// Receiver `v`'s interreflected matrices, one per channel (n⁴ each, row-major), through the
/// real bake (the vector pass over every vertex, then the matrix pass at `v`).
fn bake_interreflected_matrix(scene: &Scene, bounces: u32, v: usize) -> Vec<Vec<f64>> {
    let options = BakeOptions {
        transfer: TransferKind::Matrix,
        ..interreflected_options(bounces, SAMPLES)
    };
    let tracer = EmbreeTracer::new(scene, EmbreeOptions::default()).expect("embree scene");
    let (channels, m) =
        prt_baker::bake::matrix_bounce::receiver_matrices(scene, &tracer, &options, v..v + 1)
            .expect("valid options");
    let n = sh::coeff_count(ORDER);
    assert_eq!(m.len(), channels * n * n);
    m.chunks_exact(n * n)
        .map(|c| c.iter().map(|&x| f64::from(x)).collect())
        .collect()
}

/// A floor (x ≥ 0, normal +z, albedo `floor`) meeting a wall (the plane x = 0, normal +x,
/// albedo `wall`) at a right angle, both 1000 units long: nearly the infinite planes of
/// oracles.md. Returns the scene and the floor vertex at (x ≈ 1, 0, 0).
fn floor_and_wall(floor: Vec3, wall: Vec3) -> (Scene, usize) {
    let xs = graded(1000.0, 1.6);
    let ys: Vec<f32> = xs
        .iter()
        .rev()
        .map(|y| -y)
        .chain(xs.iter().skip(1).copied())
        .collect();
    let floor_mesh = graded_grid("floor", Vec3::ZERO, Vec3::X, Vec3::Y, &xs, &ys);
    let wall_mesh = graded_grid("wall", Vec3::ZERO, Vec3::Y, Vec3::Z, &ys, &xs);
    let scene = scene(vec![
        with_albedo(floor_mesh, floor),
        with_albedo(wall_mesh, wall),
    ]);
    let ix = xs
        .iter()
        .position(|&x| x > 0.7)
        .expect("a coordinate near 1");
    let iy = ys.iter().position(|&y| y == 0.0).expect("y = 0");
    (scene, iy * xs.len() + ix)
}

/// The closed form at a floor point beside an infinite wall (oracles.md): the floor sees the
/// quarter sphere {z > 0, x > 0} (Q_ij = ∫ y_i y_j there); the other quarter, P_i = ∫ y_i,
/// hits the wall, whose transfer is the same vector W everywhere. So M^c = Q + ρ_wall,c · P Wᵀ,
/// and with two bounces W = T¹_wall = B + (ρ_floor/2)·A (A, B the floor's and the wall's
/// shadowed transfer; a wall point's rays below the horizon hit the floor, half of its
/// cosine-weighted hemisphere). Returns (Q, P, A, W).
struct FloorWall {
    q: Vec<f64>,
    p: Vec<f64>,
    a: Vec<f64>,
    w: Vec<f64>,
}

fn floor_wall_closed_form(rho_floor: f64) -> FloorWall {
    let n = sh::coeff_count(ORDER);
    let mut q = vec![0.0; n * n];
    quarter_quadrature(ORDER, DVec3::Z, DVec3::X, |w, _, y| {
        for i in 0..n {
            for j in 0..n {
                q[i * n + j] += w * y[i] * y[j];
            }
        }
    });
    let mut p = vec![0.0; n];
    quarter_quadrature(ORDER, DVec3::Z, DVec3::NEG_X, |w, _, y| {
        for (p, y) in p.iter_mut().zip(y) {
            *p += w * y;
        }
    });
    let a = quarter_moments(ORDER, DVec3::Z, DVec3::X).mean;
    let b = quarter_moments(ORDER, DVec3::X, DVec3::Z).mean;
    let w = b
        .iter()
        .zip(&a)
        .map(|(b, a)| b + 0.5 * rho_floor * a)
        .collect();
    FloorWall { q, p, a, w }
}

#[test]
fn beside_a_coloured_wall_the_matrix_is_the_closed_form_per_channel() {
    let (rho_floor, rho_wall) = (0.5f32, Vec3::new(0.8, 0.4, 0.1));
    let (scene, v) = floor_and_wall(Vec3::splat(rho_floor), rho_wall);
    eprintln!("floor vertex {v} at {}", scene.positions[v]);
    let got = bake_interreflected_matrix(&scene, 2, v);
    assert_eq!(got.len(), 3, "a coloured wall makes three channels");
    let exact = floor_wall_closed_form(f64::from(rho_floor));
    let n = sh::coeff_count(ORDER);
    for (c, got) in got.iter().enumerate() {
        let rho = f64::from(rho_wall[c]);
        let expected: Vec<f64> = (0..n * n)
            .map(|k| exact.q[k] + rho * exact.p[k / n] * exact.w[k % n])
            .collect();
        assert_close(
            &format!("floor beside the wall, channel {c}"),
            got,
            &expected,
        );
    }
    // The wall's colour: the bounced part (M − Q) of the red channel is 8 times the blue's.
    let bounced = |c: usize, k: usize| got[c][k] - exact.q[k];
    let (i, j) = (sh::index(1, 1), 0);
    let (red, blue) = (bounced(0, i * n + j), bounced(2, i * n + j));
    eprintln!("bounced light along y_1^1 from the DC light: red {red:.4}, blue {blue:.4}");
    assert!(
        red.abs() > 0.05 && (red / blue - 8.0).abs() < 0.5,
        "red {red}, blue {blue}"
    );
}

#[test]
fn the_clamped_cosine_through_the_interreflected_matrix_is_the_interreflected_bake() {
    // The floor beside the wall, grey, two bounces: (1/π)·ĉᵀM against the vector bake with
    // two bounces. They differ by (1/π)∫ r·f_j over the hemisphere, f_j the incident radiance
    // of light y_j (y_j where unblocked, ρ·W_j on the wall) and r the clamped cosine above band
    // n − 1: at most ‖r‖/π · (1 + ρ·|W_j|·√π) (Cauchy–Schwarz, the wall's quarter being π sr),
    // and quadrature gives the difference itself. ρ = 0.8: bright enough that a third bounce
    // (or a missing second) would show beyond 0.01.
    let rho = 0.8;
    let (scene, v) = floor_and_wall(Vec3::splat(rho), Vec3::splat(rho));
    let got = bake_interreflected_matrix(&scene, 2, v);
    assert_eq!(got.len(), 1, "grey albedos make one channel");
    let n = sh::coeff_count(ORDER);
    let mut cosine = vec![0.0; n];
    for l in 0..ORDER {
        cosine[sh::index(l, 0)] = clamped_cosine_zonal(l);
    }
    let tail = (std::f64::consts::TAU / 3.0 - cosine.iter().map(|c| c * c).sum::<f64>()).sqrt();
    let projected = project_cosine_transposed(&got[0], &cosine);
    let vector = bake_scene(&scene, &interreflected_options(2, SAMPLES));
    let vector: Vec<f64> = vector.vertex(v, 0).iter().map(|&x| f64::from(x)).collect();
    let exact = floor_wall_closed_form(f64::from(rho));
    let rho = f64::from(rho);
    let exact_m: Vec<f64> = (0..n * n)
        .map(|k| exact.q[k] + rho * exact.p[k / n] * exact.w[k % n])
        .collect();
    let exact_projected = project_cosine_transposed(&exact_m, &cosine);
    let mut worst: f64 = 0.0;
    for j in 0..n {
        // T² at the floor: A + (ρ/2)·W.
        let exact_vector = exact.a[j] + 0.5 * rho * exact.w[j];
        let difference = projected[j] - vector[j];
        let expected = exact_projected[j] - exact_vector;
        let bound = tail / std::f64::consts::PI * (1.0 + rho * exact.w[j].abs() * PI_SQRT);
        eprintln!(
            "j = {j:2}: (1/π)ĉᵀM = {:+.5}, T = {:+.5}, difference {difference:+.5} \
             (quadrature {expected:+.5}, bound {bound:.4})",
            projected[j], vector[j]
        );
        worst = worst.max((difference - expected).abs());
        assert!(
            difference.abs() <= bound + TOLERANCE,
            "coefficient {j}: (1/π)ĉᵀM − T = {difference}, beyond the band-limit bound {bound}"
        );
        assert!(
            (difference - expected).abs() <= TOLERANCE,
            "coefficient {j}: (1/π)ĉᵀM − T = {difference}, quadrature says {expected}"
        );
    }
    eprintln!("worst departure from the predicted difference: {worst:.2e}");
}

const PI_SQRT: f64 = 1.772_453_850_905_516;

/// (1/π)·ĉᵀM: the diffuse transfer of the receiver from its incident-radiance matrix
/// (row i of M is the incident radiance's coefficient i, so the cosine contracts rows).
fn project_cosine_transposed(m: &[f64], c: &[f64]) -> Vec<f64> {
    let n = c.len();
    (0..n)
        .map(|j| (0..n).map(|i| c[i] * m[i * n + j]).sum::<f64>() / std::f64::consts::PI)
        .collect()
}

#[test]
fn at_the_bottom_of_a_bowl_the_dc_column_is_the_bounce_series() {
    // oracles.md: every interior point of a hemispherical bowl sees the sky with
    // cosine-weighted fraction 1/2, so under the constant light y_0 its transfer after k
    // bounces is T^k_0 = (y_0/2)·Σ_{m≤k} (ρ/2)^m everywhere. The bottom point sees the sky in
    // the 45° cone and the bowl below it; so column 0 of its two-bounce matrix is
    // M_i0 = y_0 ∫_cone y_i + ρ·T¹_0 ∫_rest y_i. The faceted bowl departs from the sphere by
    // a bias first-order in the facet size (at ρ = 0.6 the worst entry was 7.2e-3 off at
    // 24 × 48 cells, 3.6e-3 at 48 × 96); here, 48 × 96 and ρ = 0.9, 6.0e-3.
    // ρ = 0.9, so that a bounce too many or too few is seen (0.03 in M_00).
    let rho = 0.9f32;
    let bowl = with_albedo(
        spherical_cap(Vec3::Z, 1.0, std::f32::consts::FRAC_PI_2, 48, 96, false),
        Vec3::splat(rho),
    );
    let bowl = scene(vec![bowl]);
    assert_eq!(bowl.normals[0], Vec3::Z);
    let got = &bake_interreflected_matrix(&bowl, 2, 0)[0];
    let rho = f64::from(rho);
    let y0 = 0.5 / std::f64::consts::PI.sqrt();
    let t1 = 0.5 * y0 * (1.0 + 0.5 * rho);
    let cut = std::f64::consts::FRAC_1_SQRT_2;
    let sky = band_projection(ORDER, DVec3::Z, cut, 1.0);
    let wall = band_projection(ORDER, DVec3::Z, 0.0, cut);
    let n = sh::coeff_count(ORDER);
    let column: Vec<f64> = (0..n).map(|i| got[i * n]).collect();
    let expected: Vec<f64> = (0..n).map(|i| y0 * sky[i] + rho * t1 * wall[i]).collect();
    assert_close("bowl bottom, column 0", &column, &expected);
    // The shadowed part alone would be y_0 ∫_cone y_i: the bounces are seen.
    assert!((column[0] - y0 * sky[0]).abs() > 10.0 * TOLERANCE);
}

#[test]
fn with_black_surfaces_the_interreflected_matrix_is_the_shadowed_one() {
    // Nothing is reflected: only the direct part remains, summed from the same rays (in
    // another order: the bounce samples first), so equal up to f32 rounding.
    let (scene, v) = floor_and_wall(Vec3::ZERO, Vec3::ZERO);
    let got = bake_interreflected_matrix(&scene, 1, v);
    assert_eq!(got.len(), 1);
    let shadowed = bake_matrix(&scene, Mode::Shadowed, v);
    let worst = got[0]
        .iter()
        .zip(&shadowed)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    eprintln!("black surfaces: worst |interreflected − shadowed| {worst:.1e}");
    assert!(worst <= 1e-5, "{worst}");
}

#[test]
fn interreflected_matrix_bakes_are_bit_identical_for_any_thread_count() {
    let (scene, _) = floor_and_wall(Vec3::splat(0.5), Vec3::new(0.8, 0.4, 0.1));
    let options = BakeOptions {
        transfer: TransferKind::Matrix,
        ..interreflected_options(2, 256)
    };
    let bake_with = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        pool.install(|| bake_scene(&scene, &options))
    };
    let (one, three) = (bake_with(1), bake_with(3));
    let n = sh::coeff_count(ORDER);
    assert_eq!(one.channels, 3);
    assert_eq!(one.coefficients.len(), scene.vertex_count() * 3 * n * n);
    let bits = |t: &prt_baker::Transfer| -> Vec<u32> {
        t.coefficients.iter().map(|c| c.to_bits()).collect()
    };
    assert!(bits(&one) == bits(&three), "1 and 3 threads differ");
}
