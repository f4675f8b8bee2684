//! `--mover-occluder`: the viewer's per-frame shadowed transfer (occluders.rs) relit by a light
//! equals `prt-bake relight --occluder`'s triple product (`OccludedLight`) per vertex, darkens
//! the floor under the ball and leaves vertices out of reach as baked.

mod common;

use glam::{DQuat, Vec3};
use prt_baker::export::relight_occluded::OccludedLight;
use prt_baker::formats::occluder_file::{LocalSphere, OccluderFile};
use prt_baker::light::Rig;
use prt_baker::{BakeOptions, Mode};
use prt_viewer::occluders::MoverShadow;

#[test]
fn the_shadowed_transfer_relights_as_relight_occluder_does() {
    let bake = common::bake(
        &common::workspace().join("scenes/cornell/cornell.scene"),
        BakeOptions {
            order: 4,
            samples: 64,
            mode: Mode::Shadowed,
            seed: 1,
            ..BakeOptions::default()
        },
    );
    let ball = OccluderFile {
        spheres: vec![LocalSphere {
            centre: Vec3::ZERO,
            radius: 0.25,
        }],
    };
    let at = Vec3::new(-0.5, -0.55, 0.27);
    let shadow = MoverShadow::new(&bake, ball.clone()).unwrap();
    let start = std::time::Instant::now();
    let shadowed = shadow.transfer((at, DQuat::IDENTITY));
    println!(
        "a frame's shadowed transfer: {:.2} ms",
        start.elapsed().as_secs_f64() * 1e3
    );
    let rig = common::workspace().join("viewer/src/default-rig.toml");
    let light = Rig::load(&rig).unwrap().project(4);
    let reference = OccludedLight::new(&light);
    let spheres = ball.placed(at.as_dvec3(), DQuat::IDENTITY);
    let channels = bake.channels();
    let (mut darker, mut worst) = (0, 0.0f64);
    for v in 0..bake.scene.vertex_count() {
        let t = |c: usize, data: &[f32]| {
            let at = (v * channels + if channels == 3 { c } else { 0 }) * 16;
            data[at..at + 16].to_vec()
        };
        let base = &bake.file.coefficients;
        let expected = reference.radiance(
            [&t(0, base)[..], &t(1, base)[..], &t(2, base)[..]],
            bake.scene.positions[v],
            bake.scene.normals[v],
            &spheres,
        );
        for (c, e) in expected.iter().enumerate() {
            let dot = |data: &[f32]| -> f64 {
                t(c, data)
                    .iter()
                    .zip(&light.rgb[c])
                    .map(|(a, b)| f64::from(*a) * b)
                    .sum()
            };
            let got = dot(&shadowed);
            worst = worst.max((got - e).abs() / e.abs().max(1e-2));
            if bake.scene.positions[v].distance(at) > 2.5 + 1e-3 {
                assert_eq!(
                    t(c, &shadowed),
                    t(c, base),
                    "vertex {v} out of reach changed"
                );
            } else if got < dot(base) - 1e-3 {
                darker += 1;
            }
        }
    }
    assert!(worst < 1e-4, "largest relative difference {worst}");
    assert!(darker > 100, "{darker} vertex channels darker");
}
