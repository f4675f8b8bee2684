//! The GPU's per-vertex PRT radiance against `prt-bake relight`'s CPU reference.

mod common;

use glam::Vec3;
use prt_baker::relight::{display_colour, vertex_radiance};
use prt_viewer::lights::Lights;
use prt_viewer::{Camera, FrameInputs, Renderer, View, offscreen, probe};

/// The bound, in linear radiance where 1 is the display's white (exposure 0).
const LINEAR_TOLERANCE: f32 = 1.0 / 255.0;

#[test]
fn gpu_vertex_radiance_equals_the_cpu_relight() {
    let Some(gpu) = common::gpu() else { return };
    for order in [4, 8] {
        let bake = common::demo_bake(order);
        let lights = Lights::load(None, order).unwrap();
        let view = View::new(Camera::framing(&bake.scene.positions, 1.0), lights);
        let inputs = FrameInputs::from_view(&view, None);
        let mut renderer =
            Renderer::new(&gpu.device, &gpu.queue, &bake, offscreen::FORMAT, (64, 64)).unwrap();
        renderer.update(&gpu.queue, &inputs);
        let gpu_radiance = probe::vertex_radiance(&renderer, &gpu.device, &gpu.queue).unwrap();
        let white = vec![Vec3::ONE; bake.scene.vertex_count()];
        let cpu_radiance = vertex_radiance(&bake.file, &white, &inputs.prt_light);
        let mut worst = (0.0f32, 0);
        for (v, (g, c)) in gpu_radiance.iter().zip(&cpu_radiance).enumerate() {
            for k in 0..3 {
                let d = (g[k] - c[k]).abs();
                assert!(
                    d <= LINEAR_TOLERANCE,
                    "order {order}, vertex {v}: GPU {g:?}, CPU {c:?}"
                );
                if d > worst.0 {
                    worst = (d, v);
                }
            }
            let (gd, cd) = (display_colour(*g, 0.0), display_colour(*c, 0.0));
            for k in 0..3 {
                assert!(
                    gd[k].abs_diff(cd[k]) <= 1,
                    "order {order}, vertex {v}: {gd:?} vs {cd:?}"
                );
            }
        }
        eprintln!(
            "order {order}: largest difference {:.2e} at vertex {}",
            worst.0, worst.1
        );
    }
}
