//! The GPU's per-vertex PRT radiance against `prt-bake relight`'s CPU reference.

mod common;

use glam::Vec3;
use prt_baker::export::relight::{display_colour, vertex_radiance};
use prt_baker::{BakeOptions, Mode};
use prt_viewer::lights::Lights;
use prt_viewer::{Camera, FrameInputs, Renderer, View, offscreen, probe};

/// The bound, in linear radiance where 1 is the display's white (exposure 0); the
/// display colours (8-bit sRGB, as relight writes them) must also agree within 1 code. The
/// GPU sums n² f32 products where the CPU sums in f64, so the differences are rounding, far
/// below either bound.
const LINEAR_TOLERANCE: f32 = 1.0 / 255.0;

/// Compares the probe's readback with the CPU for the default rig; returns the largest
/// difference.
fn compare(gpu: &prt_viewer::Gpu, bake: &prt_viewer::Bake, what: &str) -> f32 {
    let lights = Lights::load(None, bake.order()).unwrap();
    let view = View::new(Camera::framing(&bake.scene.positions, 1.0), lights);
    let inputs = FrameInputs::from_view(&view, None);
    let mut renderer =
        Renderer::new(&gpu.device, &gpu.queue, bake, offscreen::FORMAT, (64, 64)).unwrap();
    renderer.update(&gpu.queue, &inputs);
    let gpu_radiance = probe::vertex_radiance(&renderer, &gpu.device, &gpu.queue).unwrap();
    // relight's radiance per unit albedo: the vertex shader's output, before the fragment
    // shader multiplies by Kd × texture.
    let white = vec![Vec3::ONE; bake.scene.vertex_count()];
    let cpu_radiance = vertex_radiance(&bake.file, &white, &inputs.prt_light);
    assert_eq!(gpu_radiance.len(), cpu_radiance.len());
    let mut worst = 0.0f32;
    for (v, (g, c)) in gpu_radiance.iter().zip(&cpu_radiance).enumerate() {
        for k in 0..3 {
            let d = (g[k] - c[k]).abs();
            assert!(
                d <= LINEAR_TOLERANCE,
                "{what}, vertex {v}: GPU {g:?}, CPU {c:?}"
            );
            worst = worst.max(d);
        }
        let (gd, cd) = (display_colour(*g, 0.0), display_colour(*c, 0.0));
        for k in 0..3 {
            assert!(
                gd[k].abs_diff(cd[k]) <= 1,
                "{what}, vertex {v}: {gd:?} vs {cd:?}"
            );
        }
    }
    eprintln!(
        "{what}: {} vertices, largest difference {worst:.2e}",
        gpu_radiance.len()
    );
    worst
}

/// Grey transfer (one channel serves R, G and B) at the thesis's order and at order 8.
#[test]
fn gpu_vertex_radiance_equals_the_cpu_relight_for_grey_transfer() {
    let Some(gpu) = common::gpu() else { return };
    for order in [4, 8] {
        let bake = common::demo_bake(order);
        assert_eq!(bake.channels(), 1);
        compare(&gpu, &bake, &format!("torus, shadowed, order {order}"));
    }
}

/// RGB transfer: an interreflected Cornell box, where light bounced off the red and green
/// walls makes the transfer coloured.
#[test]
fn gpu_vertex_radiance_equals_the_cpu_relight_for_rgb_transfer() {
    let Some(gpu) = common::gpu() else { return };
    let path = common::workspace().join("scenes/cornell/cornell.scene");
    let bake = common::bake(
        &path,
        BakeOptions {
            order: 6,
            samples: 256,
            mode: Mode::Interreflected,
            bounces: 1,
            seed: 1,
            ..BakeOptions::default()
        },
    );
    assert_eq!(bake.channels(), 3);
    compare(&gpu, &bake, "cornell, interreflected, order 6");
}

/// A bake of some objects (`bake --receivers`): the viewer draws every vertex, the baked
/// ones with their transfer and the others with the unshadowed lobe, and the GPU's radiance
/// equals `relight`'s CPU reference for it as for a whole bake.
#[test]
fn a_bake_of_some_objects_renders_like_the_cpu_relight() {
    use prt_baker::bake::receiver_subset::bake_objects;
    use prt_baker::trace::{EmbreeOptions, EmbreeTracer};
    use prt_baker::{CoefficientFile, Scene};

    let scene = Scene::load(&common::demo_scene_path()).unwrap();
    assert!(scene.objects.len() >= 2, "the demo has a torus and a floor");
    let options = BakeOptions {
        order: 4,
        samples: 64,
        mode: Mode::Shadowed,
        seed: 1,
        ..BakeOptions::default()
    };
    let tracer = EmbreeTracer::new(&scene, EmbreeOptions::default()).unwrap();
    let objects = [0u32];
    let silent = prt_baker::support::progress::Silent;
    let transfer = bake_objects(&scene, Some(&tracer), &options, &objects, &silent).unwrap();
    let file = CoefficientFile::from_object_bake(&scene, &transfer, &objects);
    let rows = file.header.receivers.as_ref().unwrap().vertices(&scene);
    let bake = prt_viewer::Bake::new(scene.clone(), file.clone(), "part.prt".as_ref()).unwrap();
    assert_eq!(bake.file.header.vertex_count as usize, scene.vertex_count());
    assert!(bake.file.header.receivers.is_none());
    for (r, &v) in rows.iter().enumerate() {
        assert_eq!(bake.file.vertex(v as usize, 0), file.vertex(r, 0));
    }
    let other = scene.objects[1].vertices.start as usize;
    // Unshadowed: band 0 of the clamped cosine, 1/(2√π).
    assert!((bake.file.vertex(other, 0)[0] - 0.282_094_8).abs() < 1e-5);
    let Some(gpu) = common::gpu() else { return };
    compare(&gpu, &bake, "bake of one object");
}
