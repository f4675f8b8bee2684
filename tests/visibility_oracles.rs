//! Closed-form visibility through Embree on real geometry (oracles.md): a floor point next to
//! an infinitely long wall, a point under a coaxial disk, and points in a hemispherical bowl.
//! Every comparison uses the standard-error tolerance of `prt_tests` with the per-sample
//! variance computed exactly for the visible region.

use glam::{DVec3, Vec3};
use prt_baker::math::sh;
use prt_tests::*;

/// Rays per oracle vertex: the zonal tests (order 5, a 117 MB sample table) use 2^20; the
/// wall's T_00 (order 1) uses 2^22, which resolves a lift of the origin by 0.1 % of the wall.
const SAMPLES: u32 = 1 << 20;
const WALL_SAMPLES: u32 = 1 << 22;
const Y00: f64 = 0.282_094_791_773_878_1;

/// oracles.md, "Floor point next to an infinitely long wall": T_00 and the visible
/// cosine-weighted fraction for a wall of height H at horizontal distance d.
fn wall_oracle(d: f64, h: f64) -> (f64, f64) {
    let t00 = (1.0 + d / (d * d + h * h).sqrt()) / (4.0 * std::f64::consts::PI.sqrt());
    let k = h / d;
    let visible = 1.0 - 0.5 * (1.0 - 1.0 / (1.0 + k * k).sqrt());
    (t00, visible)
}

/// A floor patch at the origin and a wall at x = d, z in [0, H], 2,000·d long: the part of an
/// infinite wall it leaves out subtends a cosine-weighted fraction below 1e-6.
fn wall_scene(d: f32, h: f32, scale: f32, offset: Vec3) -> prt_baker::Scene {
    let length = 2000.0 * d;
    let wall = grid(
        "wall",
        (Vec3::new(d, -length / 2.0, 0.0)) * scale + offset,
        Vec3::Y * length * scale,
        Vec3::Z * h * scale,
        1,
    );
    scene(vec![patch(offset, Vec3::Z, 0.25 * d * scale), wall])
}

/// Checks T_00 of the floor point (vertex 0) against the wall oracle.
fn check_wall(d: f32, h: f32, scale: f32, offset: Vec3) {
    let scene = wall_scene(d, h, scale, offset);
    let got = bake_vertices(&scene, &shadowed(1, WALL_SAMPLES), &[0])[0][0];
    let (t00, visible) = wall_oracle(d as f64, h as f64);
    let tol = tolerance(Y00 * Y00 * visible * (1.0 - visible), WALL_SAMPLES);
    eprintln!("wall d={d} H={h} scale={scale}: T00 = {got:.6}, expected {t00:.6} ± {tol:.1e}");
    assert!(
        (got - t00).abs() <= tol,
        "wall d={d} H={h} scale={scale} offset={offset}: {got} vs {t00} ± {tol}"
    );
}

#[test]
fn floor_point_next_to_an_infinitely_long_wall() {
    check_wall(1.0, 1.0, 1.0, Vec3::ZERO); // k = 1: occluded fraction 0.146447
    check_wall(0.5, 2.0, 1.0, Vec3::ZERO); // k = 4
    check_wall(2.0, 0.5, 1.0, Vec3::ZERO); // k = 1/4
}

#[test]
fn the_wall_oracle_holds_at_every_scale_and_far_from_the_origin() {
    check_wall(1.0, 1.0, 1e-4, Vec3::ZERO);
    check_wall(1.0, 1.0, 1e5, Vec3::ZERO);
    check_wall(1.0, 1.0, 10.0, Vec3::new(1e4, -2e4, 5e3));
}

#[test]
fn point_under_a_coaxial_disk() {
    let order = 5;
    // r = h = 1: the disk hides the cone of 45° around the normal. The 512-gon's missing area
    // changes the occluded fraction by about 1e-5, below the tolerance.
    let scene = scene(vec![
        patch(Vec3::ZERO, Vec3::Z, 0.1),
        disk(Vec3::Z, 1.0, 512),
    ]);
    let got = &bake_vertices(&scene, &shadowed(order, SAMPLES), &[0])[0];
    let expected = band_moments(order, DVec3::Z, 0.0, std::f64::consts::FRAC_1_SQRT_2);
    // Cosine-weighted occluded fraction r²/(r² + h²) = 1/2.
    assert!((expected.mean[0] / Y00 - 0.5).abs() < 1e-12);
    assert_matches("under the disk", got, &expected, SAMPLES);
}

/// A hemispherical bowl of radius 1 whose bottom is at the origin, open upwards.
fn bowl() -> prt_baker::Scene {
    scene(vec![spherical_cap(
        Vec3::Z,
        1.0,
        std::f32::consts::FRAC_PI_2,
        96,
        256,
        false,
    )])
}

#[test]
fn bottom_of_a_hemispherical_bowl() {
    let order = 5;
    let scene = bowl();
    assert_eq!(scene.positions[0], Vec3::ZERO);
    assert_eq!(scene.normals[0], Vec3::Z);
    let got = &bake_vertices(&scene, &shadowed(order, SAMPLES), &[0])[0];
    // The rim is seen at 45° from the normal: a visible cone of 45°.
    let expected = band_moments(order, DVec3::Z, std::f64::consts::FRAC_1_SQRT_2, 1.0);
    for l in 0..order {
        let z = visible_cone_zonal(l, std::f64::consts::FRAC_1_SQRT_2) / std::f64::consts::PI;
        assert!((expected.mean[sh::index(l, 0)] - z).abs() < 1e-12);
    }
    assert_matches("bowl bottom", got, &expected, SAMPLES);
}

#[test]
fn every_interior_point_of_a_bowl_sees_half_the_sky() {
    // Inside a sphere the kernel is constant: from any interior point of the bowl the opening
    // covers a cosine-weighted fraction of exactly 1/2, so T_00 = y_00 / 2.
    let scene = bowl();
    let segments = 256;
    // Vertices on rings 8, 24, …, 72 of 96 (polar angles 7.5° to 67.5°), at several azimuths.
    let vertices: Vec<usize> = (0..5)
        .flat_map(|i| {
            let ring = 8 + 16 * i;
            (0..3).map(move |k| 1 + (ring - 1) * segments + k * 97 % segments)
        })
        .collect();
    let baked = bake_vertices(&scene, &shadowed(1, WALL_SAMPLES), &vertices);
    let tol = tolerance(Y00 * Y00 * 0.25, WALL_SAMPLES);
    for (v, t) in vertices.iter().zip(&baked) {
        eprintln!(
            "bowl vertex {v} at {}: T00 = {:.6} (expected {:.6} ± {tol:.1e})",
            scene.positions[*v],
            t[0],
            Y00 / 2.0
        );
        assert!(
            (t[0] - Y00 / 2.0).abs() <= tol,
            "vertex {v}: {} vs {}",
            t[0],
            Y00 / 2.0
        );
    }
}

/// Ambient accessibility (the thesis's chapter-5 quantity, from the shadowed pass's rays) is
/// the cosine-weighted visible fraction; the bent normal is the cosine-weighted mean visible
/// direction.
mod ambient_occlusion {
    use super::*;

    const AO_SAMPLES: u32 = 1 << 16;

    /// Tolerance of an accessibility whose visible fraction is `p` (Bernoulli samples).
    fn ao_tolerance(p: f64) -> f64 {
        tolerance(p * (1.0 - p), AO_SAMPLES)
    }

    /// Tolerance of a bent normal's component that vanishes by symmetry: a sample's value
    /// s_x·V has variance ≤ E[s_x²] = 1/4 under cosine weighting; normalising divides by the
    /// mean's length `mean_length`.
    fn symmetric_component_tolerance(mean_length: f64) -> f64 {
        tolerance(0.25, AO_SAMPLES) / mean_length
    }

    #[test]
    fn accessibility_of_the_oracle_cones() {
        let cos45 = std::f64::consts::FRAC_1_SQRT_2;
        // Bottom of the bowl: a visible cone of 45°, sin²45° = 1/2; mean visible direction
        // along the normal with E[V s_z] = (2/3)(1 − cos³45°).
        let bowl = bowl();
        let under_disk = scene(vec![
            patch(Vec3::ZERO, Vec3::Z, 0.1),
            disk(Vec3::Z, 1.0, 512),
        ]);
        let cases = [
            ("bowl bottom", &bowl, 0.5, 2.0 / 3.0 * (1.0 - cos45.powi(3))),
            // Under the disk (r = h): occluded 1/2; E[V s_z] = (2/3)·cos³45°.
            (
                "under the disk",
                &under_disk,
                0.5,
                2.0 / 3.0 * cos45.powi(3),
            ),
        ];
        for (name, scene, visible, mean_z) in cases {
            let v = visibility_of(scene, &shadowed(1, AO_SAMPLES), &[0])[0];
            let (ao, bent) = (f64::from(v.accessibility), v.bent_normal.as_dvec3());
            eprintln!("{name}: accessibility {ao:.5} (expected {visible}), bent normal {bent}");
            assert!(
                (ao - visible).abs() <= ao_tolerance(visible),
                "{name}: accessibility {ao}"
            );
            let tol = symmetric_component_tolerance(mean_z);
            assert!(
                bent.x.abs() <= tol && bent.y.abs() <= tol,
                "{name}: bent normal {bent} should be +z"
            );
        }
    }

    #[test]
    fn wall_case_accessibility_and_bent_normal() {
        let (d, h) = (1.0, 1.0);
        let scene = wall_scene(d, h, 1.0, Vec3::ZERO);
        let v = visibility_of(&scene, &shadowed(1, AO_SAMPLES), &[0])[0];
        let (_, visible) = wall_oracle(f64::from(d), f64::from(h));
        let ao = f64::from(v.accessibility);
        eprintln!(
            "wall: accessibility {ao:.5} (expected {visible:.5}), bent normal {}",
            v.bent_normal
        );
        assert!((ao - visible).abs() <= ao_tolerance(visible));
        // The wall is at +x: the mean visible direction leans away from it, and the scene
        // is symmetric in y.
        assert!(
            v.bent_normal.x < -0.05,
            "bent normal {} does not point away from the wall",
            v.bent_normal
        );
        assert!(f64::from(v.bent_normal.y).abs() <= symmetric_component_tolerance(0.5));
        assert!(v.bent_normal.z > 0.9);
    }
}
