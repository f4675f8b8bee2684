//! Interreflected transfer against closed forms (oracles.md): a hemispherical bowl under a
//! constant sky, and a floor meeting a large wall at a right angle; plus energy, geometric
//! convergence and colour bleeding in the Cornell room.
//!
//! Bounce k alone is the difference of the bakes with k and k − 1 bounces (same seed, so the
//! same rays and the same direct pass). Its tolerance adds two terms: the Monte Carlo error
//! of the bounce's own estimator (per-sample variance from the closed form, over the M bounce
//! samples — a quarter of the N samples by default, the sequence's first M points, so with N
//! a power of two a scrambled net of their own — `prt_tests::tolerance`) and the error it
//! inherits from the previous bounce's values at the hit vertices, at most (fraction of rays
//! that hit) × ρ × that bounce's tolerance.

use glam::{DVec3, Vec3};
use prt_baker::math::sh;
use prt_baker::scene::Material;
use prt_baker::{BakeOptions, Mode, Scene};
use prt_tests::*;

const Y00: f64 = 0.282_094_791_773_878_1;

fn interreflected(order: usize, samples: u32, bounces: u32) -> BakeOptions {
    BakeOptions {
        order,
        samples,
        mode: Mode::Interreflected,
        bounces,
        seed: 11,
        ..BakeOptions::default()
    }
}

/// Coefficients of vertex `v` (channel 0) for bakes with 0..=`max` bounces.
fn per_bounce_totals(
    scene: &Scene,
    order: usize,
    samples: u32,
    max: u32,
    v: usize,
) -> Vec<Vec<f64>> {
    (0..=max)
        .map(|b| {
            let options = if b == 0 {
                shadowed(order, samples)
            } else {
                interreflected(order, samples, b)
            };
            let options = BakeOptions {
                seed: 11,
                ..options
            };
            let transfer = bake_scene(scene, &options);
            transfer
                .vertex(v, 0)
                .iter()
                .map(|&x| f64::from(x))
                .collect()
        })
        .collect()
}

fn with_albedo(mut mesh: prt_baker::scene::Mesh, albedo: f32) -> prt_baker::scene::Mesh {
    mesh.material = Material {
        name: "grey".into(),
        kd: Vec3::splat(albedo),
        ..Material::default()
    };
    mesh
}

#[test]
fn bowl_under_a_constant_sky_approaches_the_closed_form() {
    // oracles.md: every interior point sees the sky with cosine-weighted fraction 1/2, so
    // T_0,00 = y00/2, and each bounce adds the previous one's contribution times ρ/2:
    // E = (πL/2)/(1 − ρ/2) in the limit.
    let rho = 0.6f32;
    let samples = 1 << 15;
    let bowl = with_albedo(
        spherical_cap(Vec3::Z, 1.0, std::f32::consts::FRAC_PI_2, 24, 48, false),
        rho,
    );
    let scene = scene(vec![bowl]);
    // An interior vertex half-way up the bowl (ring 12 of 24).
    let v = 1 + 11 * 48 + 5;
    let totals = per_bounce_totals(&scene, 1, samples, 3, v);
    let bounce_samples = samples / 4;
    let rho = f64::from(rho);
    let mut expected_bounce = Y00 / 2.0;
    let mut tol = tolerance(Y00 * Y00 * 0.25, samples);
    for k in 0..=3 {
        let bounce = if k == 0 {
            totals[0][0]
        } else {
            totals[k][0] - totals[k - 1][0]
        };
        eprintln!("bowl bounce {k}: {bounce:.6} expected {expected_bounce:.6} ± {tol:.1e}");
        assert!(
            (bounce - expected_bounce).abs() <= tol,
            "bounce {k}: {bounce} vs {expected_bounce} ± {tol}"
        );
        // Next bounce: a hit fraction of 1/2 with value ρ·(this bounce's value).
        let next = expected_bounce * rho / 2.0;
        let sample = 2.0 * next; // the value of a sample that hits
        tol = tolerance(sample * sample * 0.25, bounce_samples) + 0.5 * rho * tol;
        expected_bounce = next;
    }
    let limit = (Y00 / 2.0) / (1.0 - rho / 2.0);
    let remaining = (Y00 / 2.0) * (rho / 2.0).powi(4) / (1.0 - rho / 2.0);
    eprintln!(
        "bowl total after 3 bounces {:.6}, closed-form limit {limit:.6} (remaining {remaining:.1e})",
        totals[3][0]
    );
}

#[test]
// `j` indexes the two oracles and the three bakes, and names the coefficient in messages.
#[allow(clippy::needless_range_loop)]
fn floor_meeting_a_wall_at_a_right_angle() {
    // oracles.md: with the shadowed transfer constant on each infinite plane (A on the floor,
    // B on the wall), the bounce totals at a floor point are A, A + (ρ/2)B, A + (ρ/2)B + (ρ²/4)A.
    let (rho, far) = (0.5f32, 2000.0f32);
    let order = 3;
    let samples = 1 << 14;
    let xs = graded(far, 1.35);
    let ys: Vec<f32> = xs
        .iter()
        .rev()
        .map(|y| -y)
        .chain(xs.iter().skip(1).copied())
        .collect();
    // Floor: x in [0, far], normal +z. Wall: the plane x = 0, z in [0, far], normal +x.
    let floor = with_albedo(
        graded_grid("floor", Vec3::ZERO, Vec3::X, Vec3::Y, &xs, &ys),
        rho,
    );
    let wall = with_albedo(
        graded_grid("wall", Vec3::ZERO, Vec3::Y, Vec3::Z, &ys, &xs),
        rho,
    );
    let scene = scene(vec![floor, wall]);
    // The floor vertex at (x ≈ 1, 0, 0).
    let ix = xs
        .iter()
        .position(|&x| x > 0.9)
        .expect("a coordinate near 1");
    let iy = ys.iter().position(|&y| y == 0.0).expect("y = 0");
    let v = iy * xs.len() + ix;
    eprintln!("floor test vertex {v} at {}", scene.positions[v]);

    let a = quarter_moments(order, DVec3::Z, DVec3::X); // floor (x > 0): sees s.x > 0
    let b = quarter_moments(order, DVec3::X, DVec3::Z); // wall: sees s.z > 0
    let totals = per_bounce_totals(&scene, order, samples, 2, v);
    let bounce_samples = samples / 4;
    let half_rho = f64::from(rho) / 2.0;
    let n = sh::coeff_count(order);
    for j in 0..n {
        let tol0 = tolerance(a.variance(j), samples);
        let tol0_wall = tolerance(b.variance(j), samples);
        // Bounce 1 at the floor point: half the rays hit the wall, each worth ρ·B_j.
        let sample1 = f64::from(rho) * b.mean[j];
        let tol1 = tolerance(sample1 * sample1 * 0.25, bounce_samples) + half_rho * tol0_wall;
        let sample2 = f64::from(rho) * half_rho * a.mean[j];
        let tol2 = tolerance(sample2 * sample2 * 0.25, bounce_samples) + half_rho * tol1;
        let expected = [
            a.mean[j],
            a.mean[j] + half_rho * b.mean[j],
            a.mean[j] + half_rho * b.mean[j] + half_rho * half_rho * a.mean[j],
        ];
        let tols = [tol0, tol0 + tol1, tol0 + tol1 + tol2];
        for k in 0..3 {
            let got = totals[k][j];
            assert!(
                (got - expected[k]).abs() <= tols[k],
                "coefficient {j} {:?} after {k} bounces: {got:.6} vs {:.6} ± {:.1e}",
                sh::band_and_m(j),
                expected[k],
                tols[k]
            );
        }
        eprintln!(
            "coefficient {j}: {:.5} {:.5} {:.5} (expected {:.5} {:.5} {:.5})",
            totals[0][j], totals[1][j], totals[2][j], expected[0], expected[1], expected[2]
        );
    }
}

fn cornell() -> Scene {
    let path = std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/cornell/cornell.scene"
    ));
    Scene::load(path).expect("cornell scene")
}

#[test]
fn bounces_only_add_light_and_converge_geometrically() {
    let scene = cornell();
    let (order, samples) = (2, 1024);
    let n = sh::coeff_count(order);
    let direct = bake_scene(
        &scene,
        &BakeOptions {
            seed: 11,
            ..shadowed(order, samples)
        },
    );
    let bakes: Vec<_> = (1..=3)
        .map(|b| bake_scene(&scene, &interreflected(order, samples, b)))
        .collect();
    assert!(
        bakes.iter().all(|t| t.channels == 3),
        "the Cornell room has coloured walls"
    );
    // Largest albedo of any channel: each bounce is at most this times the previous one.
    let rho_max = scene
        .materials
        .iter()
        .map(|m| m.kd.max_element())
        .fold(0.0f32, f32::max);
    let dc = |t: &prt_baker::Transfer, v: usize, c: usize| {
        f64::from(t.coefficients[(v * t.channels + c) * n])
    };
    let mut previous_max = (0..scene.vertex_count())
        .map(|v| f64::from(direct.vertex(v, 0)[0]))
        .fold(0.0, f64::max);
    for (k, bake) in bakes.iter().enumerate() {
        let before = if k == 0 { None } else { Some(&bakes[k - 1]) };
        let mut bounce_max = 0.0f64;
        for v in 0..scene.vertex_count() {
            for c in 0..3 {
                let (now, was) = (
                    dc(bake, v, c),
                    before.map_or(f64::from(direct.vertex(v, 0)[0]), |b| dc(b, v, c)),
                );
                // Energy: each bounce adds non-negative irradiance (up to f32 rounding).
                assert!(
                    now >= was - 1e-6,
                    "bounce {} lowered vertex {v} channel {c}: {was} -> {now}",
                    k + 1
                );
                bounce_max = bounce_max.max(now - was);
            }
        }
        eprintln!(
            "bounce {}: largest DC contribution {bounce_max:.5} (previous {previous_max:.5}, ρ_max {rho_max})",
            k + 1
        );
        // Geometric convergence: a bounce is a convex combination of the previous one's
        // values, scaled by albedos ≤ ρ_max and a hit fraction ≤ 1.
        assert!(
            bounce_max <= f64::from(rho_max) * previous_max + 1e-6,
            "bounce {} did not shrink",
            k + 1
        );
        previous_max = bounce_max;
    }
}

#[test]
fn white_floor_near_the_red_wall_turns_red() {
    let scene = cornell();
    let transfer = bake_scene(&scene, &interreflected(2, 4096, 2));
    let floor = scene
        .objects
        .iter()
        .find(|o| o.name == "floor")
        .expect("floor");
    let (mut near_red, mut near_green) = (0, 0);
    for v in floor.vertices.clone() {
        let v = v as usize;
        let p = scene.positions[v];
        let [r, g, b] = [0, 1, 2].map(|c| f64::from(transfer.vertex(v, c)[0]));
        // Stated margins for visible bleeding, within 0.1 of a coloured wall (2 bounces): at
        // least 10 % more red than green or blue beside the red wall (ρ 0.63 / 0.065 / 0.05;
        // measured 27–34 %), and 5 % more green beside the green wall, whose green reflectance
        // 0.45 is below the white surfaces' 0.73 (measured 10–18 %).
        if p.x < -0.9 && p.y.abs() < 0.6 {
            near_red += 1;
            assert!(
                r > 1.1 * g && r > 1.1 * b,
                "floor at {p} next to the red wall: rgb {r:.4} {g:.4} {b:.4}"
            );
        }
        if p.x > 0.9 && p.y.abs() < 0.6 {
            near_green += 1;
            assert!(
                g > 1.05 * r && g > 1.05 * b,
                "floor at {p} next to the green wall: rgb {r:.4} {g:.4} {b:.4}"
            );
        }
    }
    assert!(
        near_red > 10 && near_green > 10,
        "{near_red} and {near_green} vertices checked"
    );
}

/// A room's floor running out past its wall, as boards often do, with or without an overhang
/// outside: the floor (12 × 12 cells over x ∈ [−1.5, 1.5]) crosses the wall x = −1.1 mid-cell,
/// so triangles inside the room have corners outside. `outside` adds a board above the outer
/// strip (z = 0.3, facing down), hidden from every point inside by the wall (height 2).
fn floor_past_a_wall(outside: bool) -> Scene {
    let rho = 0.5;
    let mut meshes = vec![
        with_albedo(
            grid(
                "floor",
                Vec3::new(-1.5, -1.0, 0.0),
                Vec3::X * 3.0,
                Vec3::Y * 2.0,
                12,
            ),
            rho,
        ),
        with_albedo(
            grid(
                "wall",
                Vec3::new(-1.1, -1.0, 0.0),
                Vec3::Y * 2.0,
                Vec3::Z * 2.0,
                8,
            ),
            rho,
        ),
    ];
    if outside {
        meshes.push(with_albedo(
            grid(
                "overhang",
                Vec3::new(-1.15, -1.0, 0.3),
                -Vec3::X * 0.35,
                Vec3::Y * 2.0,
                4,
            ),
            rho,
        ));
    }
    scene(meshes)
}

#[test]
fn light_outside_the_room_does_not_reach_in_through_the_floors_corners() {
    // The floor's vertices beyond the wall are embedded (their rays see the wall's back):
    // their own transfer (the sky's light, or the overhang's shadow) must not leak into the
    // bounces of the room, which cannot see outside. So every vertex inside the room bakes
    // the same with and without the overhang: the rays are the same (the overhang is the
    // last mesh, every earlier vertex keeps its index) and none of them reaches it.
    let options = interreflected(2, 1024, 2);
    let open = bake_scene(&floor_past_a_wall(false), &options);
    let covered = bake_scene(&floor_past_a_wall(true), &options);
    let scene = floor_past_a_wall(false);
    let n = sh::coeff_count(2);
    let (mut inside, mut worst) = (0, 0.0f32);
    for v in 0..scene.vertex_count() {
        if scene.positions[v].x <= -1.1 + 1e-3 && scene.normals[v].z > 0.5 {
            continue; // the floor outside (and at the wall's foot)
        }
        inside += 1;
        for (a, b) in open.vertex(v, 0).iter().zip(covered.vertex(v, 0)) {
            worst = worst.max((a - b).abs());
        }
    }
    // Floor vertex (i, j) = (1, 6): x = −1.25, y = 0, under the middle of the overhang.
    let outside_dc = |t: &prt_baker::Transfer| f64::from(t.vertex(6 * 13 + 1, 0)[0]);
    eprintln!(
        "{inside} vertices inside, {n} coefficients: largest difference {worst:.2e}; T00 outside {:.4} open, {:.4} under the overhang",
        outside_dc(&open),
        outside_dc(&covered)
    );
    assert!(
        outside_dc(&open) > outside_dc(&covered) + 0.05,
        "the overhang darkens the floor outside"
    );
    assert!(
        worst <= 1e-6,
        "a vertex inside the room changed by {worst:.3e} when only the outside did"
    );
}
