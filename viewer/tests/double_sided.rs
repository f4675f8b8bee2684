//! A glTF `doubleSided` card lit only from behind, in the viewer (docs/guides/production-assets.md, "Two-sided
//! surfaces"): seen from behind it shows its back sheet, lit; seen from the front, its front
//! sheet, dark. Each sheet is drawn with back faces culled, so neither hides its twin.

mod common;

use glam::Vec3;
use prt_baker::{BakeOptions, Mode};
use prt_viewer::lights::Lights;
use prt_viewer::{Bake, Camera, FrameInputs, View};
use serde_json::json;

const SIZE: (u32, u32) = (64, 64);

/// A 2 × 2 card in glTF's y = 0 plane facing +y (the viewer's +z), white, `doubleSided`.
fn card_glb() -> Vec<u8> {
    let positions: [[f32; 3]; 4] = [
        [-1.0, 0.0, -1.0],
        [-1.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 0.0, -1.0],
    ];
    let indices: [u32; 6] = [0, 1, 2, 0, 2, 3];
    let mut bin: Vec<u8> = positions
        .as_flattened()
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    let document = json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "card"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "materials": [{"name": "leaf", "doubleSided": true}],
        "accessors": [
            {"bufferView": 0, "count": 4, "type": "VEC3", "componentType": 5126,
             "min": [-1.0, 0.0, -1.0], "max": [1.0, 0.0, 1.0]},
            {"bufferView": 1, "count": 6, "type": "SCALAR", "componentType": 5125},
        ],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 24}],
        "buffers": [{"byteLength": bin.len()}],
    });
    let mut text = serde_json::to_vec(&document).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + text.len() + 8 + bin.len()) as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(text);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

/// The mean sRGB code of the image's central quarter, seen from `eye` (viewer frame, z up)
/// under a sun straight below.
fn centre_brightness(gpu: &prt_viewer::Gpu, bake: &Bake, eye: Vec3) -> f64 {
    let folder = tempfile::tempdir().unwrap();
    let rig = folder.path().join("below.toml");
    std::fs::write(
        &rig,
        "[[light]]\nkind = \"sun\"\ntheta = 180\nphi = 0\nintensity = 2.0\n",
    )
    .unwrap();
    let lights = Lights::load(Some(&rig), bake.order())
        .unwrap()
        .for_up(bake.up());
    let view = View::new(Camera::looking_at(eye, Vec3::ZERO, 1.0), lights);
    let image = common::render(gpu, bake, &FrameInputs::from_view(&view, None), SIZE);
    let (w, h) = SIZE;
    let mut sum = 0.0;
    let mut count = 0.0;
    for y in h * 3 / 8..h * 5 / 8 {
        for x in w * 3 / 8..w * 5 / 8 {
            let p = image.get_pixel(x, y);
            sum += (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0;
            count += 1.0;
        }
    }
    sum / count
}

#[test]
fn a_double_sided_card_lit_from_behind_shows_its_lit_back_from_behind() {
    let Some(gpu) = common::gpu() else { return };
    let folder = tempfile::tempdir().unwrap();
    let path = folder.path().join("card.glb");
    std::fs::write(&path, card_glb()).unwrap();
    let options = BakeOptions {
        order: 3,
        samples: 64,
        mode: Mode::Shadowed,
        ..BakeOptions::default()
    };
    let bake = common::bake(&path, options);
    assert_eq!(bake.scene.objects.len(), 2, "the card's back sheet");
    let behind = centre_brightness(&gpu, &bake, Vec3::new(0.3, 0.2, -3.0));
    let front = centre_brightness(&gpu, &bake, Vec3::new(0.3, 0.2, 3.0));
    eprintln!("card under a sun below: seen from behind {behind:.1}, from the front {front:.1}");
    assert!(behind > 60.0, "the back, lit, is dark: {behind:.1}");
    assert!(
        front < 0.5 * behind,
        "the front shows the back's light: {front:.1}"
    );
}
