//! SH rotation (oracles.md, "Rotation"): the thesis's ZYZ construction against the two
//! independent methods — Ivanic–Ruedenberg's recurrence (what the baker uses) and the
//! projection of rotated basis functions (`sh::Rotator`) — and against lights projected at rotated
//! directions, for random rotations (fixed seed) and the gimbal cases.

use glam::{DMat3, DQuat, DVec3};
use prt_baker::light::{Light, LightCoefficients, project_sum};
use prt_baker::math::sampling::Pcg32;
use prt_baker::math::sh::rotation::{ShRotation, ZyzRotator, euler_zyz};
use prt_baker::math::sh::{self, Rotator};

/// f64 rounding of a rotated coefficient: five (2l+1)-term matrix products for l ≤ 7 (ZYZ) or
/// the recurrence's chain of ≤ 8 band products, entries ≤ 1 and coefficients ≤ ~3 in these
/// tests: ≲ 8·15·3·2⁻⁵² ≈ 1e-13. Allowing 100× that keeps the check about rounding only.
const ROUNDING: f64 = 1e-11;
/// The bar for the agreement of the two methods.
const METHODS_AGREE: f64 = 1e-5;
const SEED: u64 = 5;

/// Uniformly random rotations (Shoemake's subgroup algorithm), from a fixed seed.
fn random_rotations(count: usize) -> Vec<DQuat> {
    let mut rng = Pcg32::new(SEED, 3);
    let mut u = || f64::from(rng.next_f32());
    (0..count)
        .map(|_| {
            let (u1, u2, u3) = (u(), u(), u());
            let tau = std::f64::consts::TAU;
            DQuat::from_xyzw(
                (1.0 - u1).sqrt() * (tau * u2).sin(),
                (1.0 - u1).sqrt() * (tau * u2).cos(),
                u1.sqrt() * (tau * u3).sin(),
                u1.sqrt() * (tau * u3).cos(),
            )
        })
        .collect()
}

fn max_difference(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Every entry of every band block of two rotations.
fn max_block_difference(a: &ShRotation, b: &ShRotation) -> f64 {
    (0..a.order())
        .map(|l| max_difference(a.band(l), b.band(l)))
        .fold(0.0, f64::max)
}

/// The projection method's rotation as band blocks (its columns: rotated unit vectors).
fn projection_blocks(order: usize, r: DMat3) -> Vec<Vec<f64>> {
    let rotator = Rotator::new(order);
    let n = sh::coeff_count(order);
    let mut columns = Vec::with_capacity(n);
    for i in 0..n {
        let mut unit = vec![0.0; n];
        unit[i] = 1.0;
        let mut out = vec![0.0; n];
        rotator.rotate(r, &unit, &mut out);
        columns.push(out);
    }
    (0..order)
        .map(|l| {
            let (start, w) = (l * l, 2 * l + 1);
            let mut block = vec![0.0; w * w];
            for i in 0..w {
                for j in 0..w {
                    block[i * w + j] = columns[start + j][start + i];
                }
            }
            block
        })
        .collect()
}

/// Three lights with closed-form projections at any direction: rotating them is rotating
/// their directions.
fn lights(r: DMat3) -> Vec<Light> {
    vec![
        Light::Sun {
            direction: r * DVec3::new(0.2, -0.5, 0.8).normalize(),
            irradiance: DVec3::new(1.0, 0.7, 0.4),
            angular_radius: 0.3,
        },
        Light::Directional {
            direction: r * DVec3::new(-0.9, 0.1, 0.3).normalize(),
            irradiance: DVec3::new(0.5, 0.5, 1.0),
        },
        Light::Hemisphere {
            up: r * DVec3::Z,
            sky: DVec3::new(0.3, 0.4, 0.6),
            ground: DVec3::new(0.1, 0.08, 0.05),
        },
    ]
}

fn max_light_difference(a: &LightCoefficients, b: &LightCoefficients) -> f64 {
    a.rgb
        .iter()
        .zip(&b.rgb)
        .map(|(x, y)| max_difference(x, y))
        .fold(0.0, f64::max)
}

#[test]
fn rotate_then_project_equals_project_then_rotate_for_orders_1_to_8() {
    let mut worst = 0.0f64;
    for order in 1..=8 {
        let unrotated = project_sum(&lights(DMat3::IDENTITY), order);
        for q in random_rotations(20) {
            let r = DMat3::from_quat(q);
            let rotated_then_projected = project_sum(&lights(r), order);
            let projected_then_rotated = unrotated.rotated(&ShRotation::from_quat(order, q));
            let d = max_light_difference(&rotated_then_projected, &projected_then_rotated);
            assert!(d < ROUNDING, "order {order}, rotation {q}: {d:e}");
            worst = worst.max(d);
        }
    }
    eprintln!("rotate-then-project vs project-then-rotate, orders 1-8: max difference {worst:.2e}");
}

#[test]
fn both_methods_agree_with_the_zyz_construction() {
    let order = 8;
    let (mut vs_projection, mut vs_recurrence) = (0.0f64, 0.0f64);
    for q in random_rotations(20) {
        let r = DMat3::from_quat(q);
        let zyz = ShRotation::from_matrix(order, r);
        let recurrence = ShRotation::from_matrix_recurrence(order, r);
        vs_recurrence = vs_recurrence.max(max_block_difference(&zyz, &recurrence));
        for (l, block) in projection_blocks(order, r).iter().enumerate() {
            vs_projection = vs_projection.max(max_difference(zyz.band(l), block));
        }
    }
    eprintln!(
        "ZYZ vs projection: {vs_projection:.2e}; ZYZ vs Ivanic-Ruedenberg: {vs_recurrence:.2e} (order 8, 20 rotations)"
    );
    assert!(vs_projection < METHODS_AGREE, "{vs_projection:e}");
    assert!(vs_recurrence < METHODS_AGREE, "{vs_recurrence:e}");
}

#[test]
fn rotation_times_its_inverse_is_the_identity() {
    let order = 8;
    let rotator = ZyzRotator::new(order);
    let identity = ShRotation::identity(order);
    for (a, b, g) in [(0.3, 1.2, -2.2), (3.0, 0.01, 1.0), (-1.0, 3.1, 0.2)] {
        let forward = rotator.rotation(a, b, g);
        let backward = rotator.rotation(-g, -b, -a);
        let d = max_block_difference(&forward.then_after(&backward), &identity);
        assert!(d < ROUNDING, "R({a}, {b}, {g})·R(−γ, −β, −α): {d:e}");
        let d = max_block_difference(&forward.then_after(&forward.inverse()), &identity);
        assert!(d < ROUNDING, "R·R⁻¹: {d:e}");
    }
}

#[test]
fn every_band_block_is_orthogonal() {
    let order = 8;
    for q in random_rotations(10) {
        let rotation = ShRotation::from_quat(order, q);
        for l in 0..order {
            let (b, w) = (rotation.band(l), 2 * l + 1);
            for i in 0..w {
                for j in 0..w {
                    let dot: f64 = (0..w).map(|k| b[i * w + k] * b[j * w + k]).sum();
                    let expect = if i == j { 1.0 } else { 0.0 };
                    assert!(
                        (dot - expect).abs() < ROUNDING,
                        "band {l} rows {i}, {j}: {dot}"
                    );
                }
            }
        }
    }
}

#[test]
fn z_rotations_leave_zonal_functions_unchanged() {
    let order = 8;
    let mut zonal = vec![0.0; sh::coeff_count(order)];
    for l in 0..order {
        zonal[sh::index(l, 0)] = 1.0 / (1.0 + l as f64);
    }
    for angle in [0.4, -2.0, 3.0] {
        for rotation in [
            ShRotation::from_euler_zyz(order, angle, 0.0, 0.0),
            ShRotation::from_euler_zyz(order, 0.0, 0.0, angle),
            ShRotation::from_matrix(order, DMat3::from_rotation_z(angle)),
            ShRotation::from_matrix_recurrence(order, DMat3::from_rotation_z(angle)),
        ] {
            let d = max_difference(&rotation.rotate(&zonal), &zonal);
            assert!(d < ROUNDING, "angle {angle}: {d:e}");
        }
    }
}

/// β = 0 and β = π are where ZYZ angles stop being unique: the construction must still give
/// the matrix's rotation, from angles and from the matrix (through [`euler_zyz`]).
#[test]
fn gimbal_cases_beta_near_0_and_pi() {
    let order = 8;
    let pi = std::f64::consts::PI;
    let rotator = ZyzRotator::new(order);
    for beta in [0.0, 1e-12, 1e-7, pi - 1e-7, pi - 1e-12, pi] {
        let (alpha, gamma) = (0.7, -1.9);
        let r = DMat3::from_rotation_z(gamma)
            * DMat3::from_rotation_y(beta)
            * DMat3::from_rotation_z(alpha);
        let recurrence = ShRotation::from_matrix_recurrence(order, r);
        let from_angles = rotator.rotation(alpha, beta, gamma);
        let from_matrix = ShRotation::from_matrix(order, r);
        let (a, b, g) = euler_zyz(r);
        assert!((0.0..=pi).contains(&b), "β = {b}");
        for (what, rotation) in [("angles", &from_angles), ("matrix", &from_matrix)] {
            let d = max_block_difference(rotation, &recurrence);
            assert!(
                d < ROUNDING,
                "β = {beta}, from {what} (decomposed {a}, {b}, {g}): {d:e}"
            );
        }
        for (l, block) in projection_blocks(order, r).iter().enumerate() {
            let d = max_difference(from_matrix.band(l), block);
            assert!(d < METHODS_AGREE, "β = {beta}, band {l}: {d:e}");
        }
    }
}

#[test]
fn a_quaternion_gives_the_rotation_of_its_matrix() {
    for q in random_rotations(5) {
        let a = ShRotation::from_quat(6, q);
        let b = ShRotation::from_matrix_recurrence(6, DMat3::from_quat(q));
        assert!(max_block_difference(&a, &b) < ROUNDING);
    }
}
