use super::*;
use crate::math::sh::{Basis, Rotator};
use glam::DVec3;

/// Rounding of a few hundred f64 products per entry: far below any real error.
const EXACT: f64 = 1e-12;

fn max_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn band_one_rotates_like_the_vector_with_the_convention_signs() {
    // f(s) = a·s has coefficients k·(−a_y, a_z, −a_x); g(s) = f(Rᵀs) = (Ra)·s.
    let k = (3.0 / (4.0 * std::f64::consts::PI)).sqrt();
    let a = DVec3::new(0.3, -0.5, 0.8);
    let r = DMat3::from_axis_angle(DVec3::new(1.0, 2.0, -0.5).normalize(), 0.9);
    let coefficients = |v: DVec3| vec![0.0, -k * v.y, k * v.z, -k * v.x];
    let want = coefficients(r * a);
    for rotation in [
        ShRotation::from_matrix(2, r),
        ShRotation::from_matrix_recurrence(2, r),
    ] {
        let got = rotation.rotate(&coefficients(a));
        assert!(max_difference(&got, &want) < EXACT, "{got:?} vs {want:?}");
    }
}

#[test]
fn recurrence_equals_the_projection_method_up_to_order_10() {
    let order = 10;
    let rotator = Rotator::new(order);
    let n = coeff_count(order);
    for (axis, angle) in [
        (DVec3::X, std::f64::consts::FRAC_PI_2),
        (DVec3::new(0.2, -0.9, 0.4), 2.1),
    ] {
        let r = DMat3::from_axis_angle(axis.normalize(), angle);
        let rotation = ShRotation::from_matrix_recurrence(order, r);
        for i in 0..n {
            let mut unit = vec![0.0; n];
            unit[i] = 1.0;
            let mut want = vec![0.0; n];
            rotator.rotate(r, &unit, &mut want);
            let got = rotation.rotate(&unit);
            // The projection method's pseudo-inverse loses a few digits at order 10.
            assert!(max_difference(&got, &want) < 1e-9, "column {i}");
        }
    }
}

#[test]
fn rotate_in_place_equals_the_phased_matrix_and_the_projection_method() {
    // One scratch reused across rotations, as the baker reuses it across receivers.
    let mut scratch = RotationScratch::default();
    for order in [1, 2, 4, 7] {
        let n = coeff_count(order);
        let (rotator, recurrence) = (ZyzRotator::new(order), RecurrenceRotator::new(order));
        let projection = Rotator::new(order);
        let c: Vec<f64> = (0..n).map(|i| ((i * 7 + 3) % 11) as f64 - 5.0).collect();
        for (axis, angle) in [(DVec3::new(0.3, 1.0, -0.2), 0.7), (DVec3::Y, -2.9)] {
            let r = DMat3::from_axis_angle(axis.normalize(), angle);
            let mut got = vec![f64::NAN; n];
            rotator.rotate(r, &c, &mut got, &mut scratch);
            let matrix = recurrence.rotation(r).rotate(&c);
            assert!(max_difference(&got, &matrix) < EXACT, "order {order}");
            let mut want = vec![0.0; n];
            projection.rotate(r, &c, &mut want);
            assert!(max_difference(&got, &want) < 1e-10, "order {order}");
        }
    }
}

/// The ZYZ product applied to a vector equals the recurrence's blocks, at every order the
/// baker bakes and in the gimbal cases (a receiver whose normal is ±z).
#[test]
fn the_zyz_product_turns_a_vector_as_the_recurrence_does() {
    let mut scratch = RotationScratch::default();
    for order in [1, 2, 3, 4, 8, 12, 16] {
        let n = coeff_count(order);
        let (zyz, recurrence) = (ZyzRotator::new(order), RecurrenceRotator::new(order));
        let c: Vec<f64> = (0..n).map(|i| ((i * 7 + 3) % 11) as f64 - 5.0).collect();
        let flip = DMat3::from_cols(DVec3::X, -DVec3::Y, -DVec3::Z);
        for r in [
            DMat3::from_axis_angle(DVec3::new(0.3, 1.0, -0.2).normalize(), 0.7),
            DMat3::from_axis_angle(DVec3::Y, -2.9),
            DMat3::from_rotation_z(1.3),
            flip * DMat3::from_rotation_z(0.4),
        ] {
            let mut got = vec![f64::NAN; n];
            zyz.rotate(r, &c, &mut got, &mut scratch);
            let want = recurrence.rotation(r).rotate(&c);
            let scale = c.iter().map(|x| x.abs()).fold(0.0, f64::max);
            assert!(
                max_difference(&got, &want) < 1e-11 * scale,
                "order {order}: {}",
                max_difference(&got, &want)
            );
        }
    }
}

/// What a receiver's rotation costs each way, the recurrence's blocks built and applied
/// (not a check: run it by name).
#[test]
#[ignore]
fn rotation_speed() {
    let mut scratch = RotationScratch::default();
    for order in [3, 4, 6, 8, 12] {
        let n = coeff_count(order);
        let (zyz, recurrence) = (ZyzRotator::new(order), RecurrenceRotator::new(order));
        let c: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let mut out = vec![0.0; n];
        let count = 200_000;
        let frames: Vec<DMat3> = (0..count)
            .map(|i| DMat3::from_axis_angle(DVec3::new(0.3, 1.0, -0.2).normalize(), i as f64))
            .collect();
        let started = std::time::Instant::now();
        for &r in &frames {
            zyz.rotate(r, &c, &mut out, &mut scratch);
        }
        let zyz_time = started.elapsed().as_secs_f64() / count as f64;
        let started = std::time::Instant::now();
        for &r in &frames {
            recurrence.rotation(r).apply(&c, &mut out);
        }
        let recurrence_time = started.elapsed().as_secs_f64() / count as f64;
        eprintln!(
            "order {order}: zyz {:.3} µs, recurrence {:.3} µs",
            zyz_time * 1e6,
            recurrence_time * 1e6
        );
    }
}

#[test]
fn euler_angles_rebuild_the_matrix_including_gimbal_cases() {
    let zyz = |a: f64, b: f64, g: f64| {
        DMat3::from_rotation_z(g) * DMat3::from_rotation_y(b) * DMat3::from_rotation_z(a)
    };
    let pi = std::f64::consts::PI;
    for (a, b, g) in [
        (0.3, 1.1, -2.0),
        (1.0, 0.0, 0.5),
        (1.0, 1e-9, 0.5),
        (-2.5, pi, 0.7),
        (-2.5, pi - 1e-9, 0.7),
        (3.0, 2.9, -3.0),
    ] {
        let m = zyz(a, b, g);
        let (a2, b2, g2) = euler_zyz(m);
        let rebuilt = zyz(a2, b2, g2);
        let error = (rebuilt - m)
            .to_cols_array()
            .iter()
            .map(|x| x.abs())
            .fold(0.0, f64::max);
        assert!(
            error < EXACT,
            "({a}, {b}, {g}) → ({a2}, {b2}, {g2}): {error}"
        );
    }
}

#[test]
fn light_angles_take_z_to_the_direction() {
    let order = 5;
    let basis = Basis::new(order);
    let (theta, phi) = (1.2f64, -2.3f64);
    let d = DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    );
    let (mut at_z, mut at_d) = (vec![0.0; 25], vec![0.0; 25]);
    basis.eval_recurrence(DVec3::Z, &mut at_z);
    basis.eval_recurrence(d, &mut at_d);
    // A delta at +z has coefficients y(z); rotated, a delta at d.
    let got = ShRotation::from_light_angles(order, theta, phi).rotate(&at_z);
    assert!(max_difference(&got, &at_d) < EXACT);
}
