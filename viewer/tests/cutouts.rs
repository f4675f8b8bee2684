//! Cut-outs as engines draw them (docs/reference/viewer.md, "Materials"): the cut-out card of
//! `scenes/cutout` (a 2 × 2 card over a floor, alphaMode MASK cutting it into 8 stripes, 4
//! kept) against its geometry twin (the 4 kept stripes modelled as triangles), each baked
//! with the same rays, seen from above. The bake already shadows the floor alike under both
//! (tests/alpha_cutouts.rs); here the viewer must also show the floor through the card's
//! gaps: per vertex in PRT and Blinn-Phong, and per texel.

mod common;

use std::path::Path;

use glam::Vec3;
use prt_baker::bake::lightmap::{self, Atlas};
use prt_baker::support::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer};
use prt_baker::{BakeOptions, CoefficientFile, Mode as BakeMode, Scene};
use prt_viewer::lights::Lights;
use prt_viewer::{Bake, Camera, FrameInputs, Mode, View};

const SIZE: (u32, u32) = (256, 256);
/// The bound: at least 99 % of the pixels within 8 codes in every channel.
const CODES: u8 = 8;
const SHARE: f64 = 0.99;

fn options() -> BakeOptions {
    BakeOptions {
        order: 4,
        samples: 256,
        mode: BakeMode::Shadowed,
        seed: 1,
        ..BakeOptions::default()
    }
}

fn scene(name: &str) -> Scene {
    Scene::load(&common::workspace().join("scenes/cutout").join(name)).expect("the scene loads")
}

fn vertex_bake(name: &str) -> Bake {
    common::bake(
        &common::workspace().join("scenes/cutout").join(name),
        options(),
    )
}

/// A 64² texel bake on a generated atlas of a fixed texel size, as `prt-bake bake
/// --lightmap 64 --texel-size 0.12`: the floor, the largest chart, then lies on the same
/// texels in both scenes (sized by the scene's total area instead, the two floors' texels
/// differ, and so does their noise).
fn texel_bake(name: &str) -> Bake {
    let scene = scene(name);
    let tracer = EmbreeTracer::new(&scene, EmbreeOptions::default()).expect("Embree");
    let atlas = Atlas::generate(&scene, 64, Some(0.12)).expect("an atlas");
    let bake = lightmap::bake(&scene, Some(&tracer), &options(), atlas, &Silent).expect("bake");
    let file = CoefficientFile::from_lightmap_bake(&scene, &bake);
    Bake::new(scene, file, Path::new("texels.prt")).expect("the viewer takes it")
}

/// The scene from above the card (viewer frame, z up; the card is 0.6 up), default rig.
fn render(gpu: &prt_viewer::Gpu, bake: &Bake, mode: Mode) -> image::RgbaImage {
    let lights = Lights::load(None, bake.order())
        .expect("the default rig")
        .for_up(bake.up());
    let camera = Camera::looking_at(Vec3::new(0.0, -0.4, 3.6), Vec3::new(0.0, 0.0, 0.6), 1.0);
    let mut view = View::new(camera, lights);
    view.mode = mode;
    common::render(gpu, bake, &FrameInputs::from_view(&view, None), SIZE)
}

/// The share of pixels within `CODES` in every channel.
fn agreement(a: &image::RgbaImage, b: &image::RgbaImage) -> f64 {
    1.0 - common::difference(a, b, CODES).outliers
}

#[test]
fn a_cut_out_card_looks_like_its_geometry_twin_from_above() {
    let Some(gpu) = common::gpu() else { return };
    let (card, twin) = (vertex_bake("card.glb"), vertex_bake("twin.glb"));
    let (card_texels, twin_texels) = (texel_bake("card.glb"), texel_bake("twin.glb"));
    let mut failures = Vec::new();
    for (label, a, b, mode) in [
        ("per vertex, PRT", &card, &twin, Mode::Prt),
        ("per vertex, Blinn-Phong", &card, &twin, Mode::Phong),
        ("per texel, PRT", &card_texels, &twin_texels, Mode::Prt),
    ] {
        let (x, y) = (render(&gpu, a, mode), render(&gpu, b, mode));
        let share = agreement(&x, &y);
        let d = common::difference(&x, &y, CODES);
        eprintln!(
            "{label}: {:.2} % of pixels within {CODES} codes (mean {:.3}, worst {})",
            100.0 * share,
            d.mean,
            d.max
        );
        if share < SHARE {
            let dir = common::workspace().join("target/tmp");
            std::fs::create_dir_all(&dir).unwrap();
            let stem = label.replace([',', ' '], "-");
            x.save(dir.join(format!("cutout-{stem}-card.png"))).unwrap();
            y.save(dir.join(format!("cutout-{stem}-twin.png"))).unwrap();
            failures.push(format!("{label}: {:.2} %", 100.0 * share));
        }
    }
    assert!(
        failures.is_empty(),
        "the cut-out card and its twin differ (images in target/tmp): {failures:?}"
    );
}
