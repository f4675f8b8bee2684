//! Fixtures for the viewer's tests: the demo scene baked at test time, the software device,
//! image comparison.

// Each test binary uses its own part of these.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use prt_baker::support::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer};
use prt_baker::{BakeOptions, CoefficientFile, Mode, Scene};
use prt_viewer::{Bake, Gpu};

pub fn workspace() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

pub fn demo_scene_path() -> PathBuf {
    workspace().join("scenes/torus/torus.scene")
}

/// The demo scene baked with shadows at `order`: 256 rays per vertex, seed 1 (deterministic:
/// the same seed gives a bit-identical bake whatever the thread count).
pub fn demo_bake(order: usize) -> Bake {
    bake(
        &demo_scene_path(),
        BakeOptions {
            order,
            samples: 256,
            mode: Mode::Shadowed,
            seed: 1,
            ..BakeOptions::default()
        },
    )
}

/// A scene baked with Embree.
pub fn bake(path: &Path, options: BakeOptions) -> Bake {
    let scene = Scene::load(path).expect("the scene loads");
    let tracer = EmbreeTracer::new(&scene, EmbreeOptions::default()).expect("Embree");
    let transfer = prt_baker::bake(&scene, Some(&tracer), &options, &Silent).expect("the bake");
    let file = CoefficientFile::from_bake(&scene, &transfer);
    Bake::new(scene, file, Path::new("test.prt")).expect("the bake belongs to its scene")
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

/// Renders one frame of `inputs` at `size`.
pub fn render(
    gpu: &Gpu,
    bake: &Bake,
    inputs: &prt_viewer::FrameInputs,
    size: (u32, u32),
) -> image::RgbaImage {
    let mut renderer = prt_viewer::Renderer::new(
        &gpu.device,
        &gpu.queue,
        bake,
        prt_viewer::offscreen::FORMAT,
        size,
    )
    .expect("the renderer takes the bake");
    prt_viewer::offscreen::render_image(&gpu.device, &gpu.queue, &mut renderer, inputs)
        .expect("the frame reads back")
}

/// How two images differ, in 8-bit sRGB codes over the R, G and B channels.
#[derive(Clone, Copy, Debug)]
pub struct Difference {
    /// Mean absolute difference over every channel of every pixel.
    pub mean: f64,
    /// The largest difference of any channel.
    pub max: u8,
    /// The fraction of pixels with some channel differing by more than `threshold`.
    pub outliers: f64,
}

pub fn difference(a: &image::RgbaImage, b: &image::RgbaImage, threshold: u8) -> Difference {
    assert_eq!(a.dimensions(), b.dimensions(), "image sizes");
    let (mut sum, mut max, mut outliers) = (0u64, 0u8, 0usize);
    for (p, q) in a.pixels().zip(b.pixels()) {
        let d = [0, 1, 2].map(|c| p[c].abs_diff(q[c]));
        sum += d.iter().map(|&x| u64::from(x)).sum::<u64>();
        let worst = *d.iter().max().expect("3 channels");
        max = max.max(worst);
        outliers += usize::from(worst > threshold);
    }
    let pixels = a.pixels().len();
    Difference {
        mean: sum as f64 / (3 * pixels) as f64,
        max,
        outliers: outliers as f64 / pixels as f64,
    }
}

/// A half float's value (the radiance map is `Rgba16Float`).
pub fn from_f16(bits: u16) -> f32 {
    let sign = if bits & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exponent = i32::from((bits >> 10) & 0x1f);
    let mantissa = f32::from(bits & 0x3ff);
    sign * match exponent {
        0 => mantissa * 2f32.powi(-24),
        31 => f32::INFINITY,
        _ => (1.0 + mantissa / 1024.0) * 2f32.powi(exponent - 15),
    }
}

/// The vertices of `prt-bake relight`'s binary PLY: each position and its linear radiance.
pub fn read_ply(path: &Path) -> Vec<(glam::Vec3, [f32; 3])> {
    prt_baker::formats::ply::read_radiance(&std::fs::read(path).unwrap()).unwrap()
}

/// A vertex bake of `scene` whose band-0 transfer gives back `relit`'s radiance under a light
/// of band-0 coefficients `l00`: a CLI reference drawn by the viewer's own rasteriser.
pub fn band0_file(
    scene: &Scene,
    relit: &[(glam::Vec3, [f32; 3])],
    l00: [f64; 3],
    order: usize,
) -> CoefficientFile {
    let albedo = scene.vertex_albedo();
    let n = order * order;
    let mut coefficients = vec![0.0f32; scene.vertex_count() * 3 * n];
    for (v, (_, r)) in relit.iter().enumerate() {
        for c in 0..3 {
            coefficients[(v * 3 + c) * n] =
                (f64::from(r[c]) / (f64::from(albedo[v][c]) * l00[c])) as f32;
        }
    }
    let transfer = prt_baker::Transfer {
        options: BakeOptions {
            order,
            ..BakeOptions::default()
        },
        channels: 3,
        receiver_count: scene.vertex_count(),
        coefficients,
        visibility: Vec::new(),
        backend: prt_baker::trace::Backend::None,
        rays_cast: 0,
        seconds: 0.0,
        hit_cache_bytes: None,
    };
    CoefficientFile::from_bake(scene, &transfer)
}

/// The Cornell room's rig for things that move through it: a sun through its open front and a
/// sky (scenes/cornell/room-rig.toml, which the scripts read too).
pub const ROOM_RIG: &str = include_str!("../../../scenes/cornell/room-rig.toml");
