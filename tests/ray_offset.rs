//! Rays must not hit the surface they leave (baker/src/trace/offset.rs), at any scale and
//! anywhere in space, and the offset must not depend on geometry far away.
//!
//! A convex body cannot see any part of itself from its surface, and neither can a flat grid
//! of coplanar triangles: on those, the shadowed bake must equal the unshadowed one bit for
//! bit (same directions, every ray unblocked).

use glam::Vec3;
use prt_baker::support::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer};
use prt_baker::{BakeOptions, Mode, Scene};
use prt_tests::*;

const SAMPLES: u32 = 256;

fn blocked_vertices(scene: &Scene) -> Vec<usize> {
    let options = BakeOptions {
        order: 3,
        samples: SAMPLES,
        mode: Mode::Shadowed,
        seed: 3,
        ..BakeOptions::default()
    };
    let tracer = EmbreeTracer::new(scene, EmbreeOptions::default()).expect("embree");
    let shadowed = prt_baker::bake(scene, Some(&tracer), &options, &Silent).expect("bake");
    let unshadowed = prt_baker::bake(
        scene,
        None,
        &BakeOptions {
            mode: Mode::Unshadowed,
            ..options
        },
        &Silent,
    )
    .expect("bake");
    (0..scene.vertex_count())
        .filter(|&v| shadowed.vertex(v, 0) != unshadowed.vertex(v, 0))
        .collect()
}

/// Scales from a tenth of a millimetre to a hundred kilometres (in metres), at the origin and
/// far from it.
const PLACEMENTS: [(f32, Vec3); 6] = [
    (1e-4, Vec3::ZERO),
    (1.0, Vec3::ZERO),
    (1e5, Vec3::ZERO),
    (1.0, Vec3::new(1e4, -2e4, 5e3)),
    (1e-2, Vec3::new(300.0, 20.0, -100.0)),
    (1e3, Vec3::new(-1e6, 0.0, 2e6)),
];

#[test]
fn a_convex_sphere_never_sees_itself() {
    for (scale, offset) in PLACEMENTS {
        let scene = scene(vec![sphere(offset, scale, 24, 48)]);
        let blocked = blocked_vertices(&scene);
        assert!(
            blocked.is_empty(),
            "scale {scale} at {offset}: {} of {} vertices see the sphere",
            blocked.len(),
            scene.vertex_count()
        );
    }
}

#[test]
fn a_flat_grid_never_sees_itself() {
    for (scale, offset) in PLACEMENTS {
        let tilted = Vec3::new(0.3, 0.1, 1.0).normalize();
        let u = tilted.any_orthonormal_vector();
        let v = tilted.cross(u);
        let scene = scene(vec![grid("grid", offset, u * scale, v * scale, 16)]);
        let blocked = blocked_vertices(&scene);
        assert!(
            blocked.is_empty(),
            "scale {scale} at {offset}: vertices {blocked:?} see the grid"
        );
    }
}

/// Regression: the offset was once 2^-16 of the *scene's* half-diagonal, so adding a large,
/// distant object lifted every ray origin and lit the foot of a wall (the wall oracle was off
/// by 7e-4). The offset must depend only on a vertex's own triangles.
#[test]
fn geometry_far_away_does_not_change_a_vertex() {
    let near = vec![
        patch(Vec3::ZERO, Vec3::Z, 0.25),
        grid(
            "wall",
            Vec3::new(1.0, -10.0, 0.0),
            Vec3::Y * 20.0,
            Vec3::Z,
            1,
        ),
    ];
    let mut far = near.clone();
    // Below the floor, out of every ray's reach, but it grows the scene 10,000-fold.
    far.push(grid(
        "far",
        Vec3::new(-5e3, -5e3, -1e4),
        Vec3::X * 1e4,
        Vec3::Y * 1e4,
        1,
    ));
    let options = shadowed(2, 4096);
    let alone = bake_vertices(&scene(near), &options, &[0]);
    let with_far = bake_vertices(&scene(far), &options, &[0]);
    assert_eq!(alone, with_far);
}

/// A floor vertex exactly at the foot of a wall that belongs to another mesh (as in the demo
/// scene, where floor and walls meet edge to edge): half of its cosine-weighted hemisphere is
/// behind the wall, so no light may leak under it.
#[test]
fn no_light_leaks_where_a_floor_meets_a_wall() {
    let length = 2000.0;
    let wall = grid(
        "wall",
        Vec3::new(0.0, -length / 2.0, 0.0),
        Vec3::Y * length,
        Vec3::Z * length,
        1,
    );
    let floor = grid(
        "floor",
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::X,
        Vec3::Y * 2.0,
        2,
    );
    let scene = scene(vec![floor, wall]);
    // Floor vertex (1, 0, 0): i = 2, j = 1 on the 3×3 grid.
    let v = 3 + 2;
    assert_eq!(scene.positions[v], Vec3::ZERO);
    let samples = 1 << 16;
    let t00 = bake_vertices(&scene, &shadowed(1, samples), &[v])[0][0];
    let y00 = 0.282_094_791_773_878_1;
    let tol = tolerance(y00 * y00 * 0.25, samples);
    assert!(
        (t00 - y00 / 2.0).abs() <= tol,
        "T00 at the foot of the wall = {t00}, expected {} ± {tol}",
        y00 / 2.0
    );
}
