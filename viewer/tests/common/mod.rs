//! Fixtures for the viewer's tests: the demo scene baked at test time, the software device.

use std::path::{Path, PathBuf};

use prt_baker::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer};
use prt_baker::{BakeOptions, CoefficientFile, Mode, Scene};
use prt_viewer::{Bake, Gpu};

pub fn workspace() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

pub fn demo_scene_path() -> PathBuf {
    workspace().join("scenes/torus/torus.scene")
}

/// The demo scene baked with shadows: order 4, 256 rays per vertex, seed 1 (deterministic:
/// the same seed gives a bit-identical bake whatever the thread count).
pub fn demo_bake(order: usize) -> Bake {
    let path = demo_scene_path();
    let scene = Scene::load(&path).expect("the demo scene loads");
    let tracer = EmbreeTracer::new(&scene, EmbreeOptions::default()).expect("Embree");
    let options = BakeOptions {
        order,
        samples: 256,
        mode: Mode::Shadowed,
        seed: 1,
        ..BakeOptions::default()
    };
    let transfer =
        prt_baker::bake(&scene, Some(&tracer), &options, &Silent).expect("the demo scene bakes");
    let file = CoefficientFile::from_bake(&scene, &transfer);
    Bake::new(scene, file, Path::new("demo.prt")).expect("the bake belongs to its scene")
}

/// Mesa's software Vulkan (lavapipe), which the golden images were made with; `None`, with
/// a message, only if there is no adapter at all.
pub fn gpu() -> Option<Gpu> {
    match Gpu::software().expect("the adapter opens a device") {
        Some(gpu) => {
            eprintln!("device: {}", gpu.description());
            Some(gpu)
        }
        None => {
            eprintln!(
                "SKIPPED: no graphics adapter at all (install mesa-vulkan-drivers: scripts/install-deps.sh)"
            );
            None
        }
    }
}
