//! Alpha-tested occlusion: a glTF card whose base colour texture cuts it
//! into stripes (`alphaMode: MASK`) must shadow a floor as the same stripes modelled as
//! geometry do, with the same rays, on both backends; a `BLEND` card stops a ray with the
//! probability of its alpha, the same on both backends. Each oracle also checks that the
//! card baked as opaque does not pass, so switching the feature off fails it.

use glam::{Vec2, Vec3};
use prt_baker::support::progress::Silent;
use prt_baker::trace::{Backend, build};
use prt_baker::trace::{Tracer, TracerOptions};
use prt_baker::{BakeOptions, Scene, Transfer};
use prt_tests::*;
use serde_json::json;

/// Floor cells per side (the floor is 5 × 5 at y = 0, y up as in glTF).
const CELLS: u32 = 24;
/// Rays per vertex, as the acceptance criterion says.
const SAMPLES: u32 = 256;

/// A glTF primitive: positions, glTF texture coordinates, indices, material index.
struct Primitive {
    positions: Vec<Vec3>,
    uvs: Vec<Vec2>,
    indices: Vec<u32>,
    material: usize,
}

/// The floor: a grid facing +y.
fn floor() -> Primitive {
    let g = grid(
        "floor",
        Vec3::new(-2.5, 0.0, 2.5),
        Vec3::X * 5.0,
        Vec3::NEG_Z * 5.0,
        CELLS,
    );
    let uvs = vec![Vec2::ZERO; g.positions.len()];
    Primitive {
        positions: g.positions,
        uvs,
        indices: g.triangles.iter().flatten().copied().collect(),
        material: 0,
    }
}

/// A horizontal rectangle at height 0.6 over x ∈ [x0, x1], z ∈ [−1, 1], its texture
/// coordinates those of the 2 × 2 card over [−1, 1]²: u = (x + 1)/2, v = (z + 1)/2.
fn card_part(x0: f32, x1: f32, material: usize) -> Primitive {
    let corners = [(x0, -1.0), (x1, -1.0), (x1, 1.0), (x0, 1.0)];
    Primitive {
        positions: corners.map(|(x, z)| Vec3::new(x, 0.6, z)).to_vec(),
        uvs: corners
            .map(|(x, z)| Vec2::new((x + 1.0) / 2.0, (z + 1.0) / 2.0))
            .to_vec(),
        indices: vec![0, 2, 1, 0, 3, 2],
        material,
    }
}

/// An 8 × 1 RGBA PNG: white, alpha 255 in even texels and 0 in odd ones (8 stripes along u).
fn stripes_png() -> Vec<u8> {
    let mut image = image::RgbaImage::new(8, 1);
    for (x, _, p) in image.enumerate_pixels_mut() {
        *p = image::Rgba([255, 255, 255, if x % 2 == 0 { 255 } else { 0 }]);
    }
    let mut png = Vec::new();
    image
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .expect("png");
    png
}

/// A `.glb` of one node per primitive, the materials given as glTF JSON; the stripes PNG is
/// image 0 (texture 0).
fn glb(primitives: &[Primitive], materials: serde_json::Value) -> Vec<u8> {
    let (mut bin, mut views, mut accessors, mut meshes) = (vec![], vec![], vec![], vec![]);
    let mut view = |bytes: Vec<u8>, bin: &mut Vec<u8>| {
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        bin.extend(bytes);
        views.len() - 1
    };
    let png = view(stripes_png(), &mut bin);
    for p in primitives {
        let floats = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        let pos: Vec<f32> = p.positions.iter().flat_map(|v| v.to_array()).collect();
        let uv: Vec<f32> = p.uvs.iter().flat_map(|v| v.to_array()).collect();
        let ind: Vec<u8> = p.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let base = accessors.len();
        accessors.push(json!({"bufferView": view(floats(&pos), &mut bin), "count": p.positions.len(),
            "type": "VEC3", "componentType": 5126, "min": [-10.0, -10.0, -10.0], "max": [10.0, 10.0, 10.0]}));
        accessors.push(
            json!({"bufferView": view(floats(&uv), &mut bin), "count": p.uvs.len(),
            "type": "VEC2", "componentType": 5126}),
        );
        accessors.push(
            json!({"bufferView": view(ind, &mut bin), "count": p.indices.len(),
            "type": "SCALAR", "componentType": 5125}),
        );
        meshes.push(
            json!({"primitives": [{"attributes": {"POSITION": base, "TEXCOORD_0": base + 1},
            "indices": base + 2, "material": p.material}]}),
        );
    }
    let nodes: Vec<_> = (0..meshes.len()).map(|m| json!({"mesh": m})).collect();
    let document = json!({
        "asset": {"version": "2.0"}, "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}], "nodes": nodes,
        "meshes": meshes, "accessors": accessors, "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}],
        "images": [{"bufferView": png, "mimeType": "image/png"}],
        "textures": [{"source": 0}],
        "materials": materials,
    });
    prt_tests::glb(&serde_json::to_vec(&document).unwrap(), &bin)
}

/// Loads a `.glb` written to a temporary folder. With `PRT_ALPHA_SCENES=folder`, the
/// scenes are also kept there as `scene-N.glb` (in the order the tests load them), for
/// timing bakes with `prt-bake` (docs/explanation/performance.md, "Alpha cutouts").
fn load(bytes: &[u8]) -> Scene {
    if let Some(folder) = std::env::var_os("PRT_ALPHA_SCENES") {
        static KEPT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = KEPT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let path = std::path::Path::new(&folder).join(format!("scene-{n}.glb"));
        std::fs::write(path, bytes).expect("keep the scene");
    }
    let folder = tempfile::tempdir().expect("temporary folder");
    let path = folder.path().join("scene.glb");
    std::fs::write(&path, bytes).expect("write glb");
    Scene::load(&path).expect("load glb")
}

fn bake(scene: &Scene, backend: Backend, options: &BakeOptions) -> Transfer {
    let tracer: Box<dyn Tracer> = build(backend, scene, TracerOptions::default()).expect("tracer");
    prt_baker::bake(scene, Some(&*tracer), options, &Silent).expect("bake")
}

/// The transfer vectors of the floor's vertices (object 0).
fn floor_transfer(scene: &Scene, transfer: &Transfer) -> Vec<Vec<f32>> {
    let n = transfer.coefficients.len() / transfer.receiver_count / transfer.channels;
    scene.objects[0]
        .vertices
        .clone()
        .map(|v| transfer.coefficients[v as usize * n * transfer.channels..][..n].to_vec())
        .collect()
}

/// The fraction of floor vertices whose every coefficient agrees within `tolerance`, and the
/// worst difference.
fn agreement(a: &[Vec<f32>], b: &[Vec<f32>], tolerance: f32) -> (f64, f32) {
    let mut worst = 0.0f32;
    let agreeing = a
        .iter()
        .zip(b)
        .filter(|(x, y)| {
            let d = x
                .iter()
                .zip(*y)
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f32::max);
            worst = worst.max(d);
            d <= tolerance
        })
        .count();
    (agreeing as f64 / a.len() as f64, worst)
}

fn mask_material(mode: &str) -> serde_json::Value {
    json!({"name": "stripes", "alphaMode": mode, "alphaCutoff": 0.5, "doubleSided": true,
        "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}})
}

/// The acceptance criterion: ≥ 99 % of the floor's vertices within 2e-3 of the floor under
/// the four opaque stripes modelled as geometry, with the same 256 rays, on both backends.
#[test]
fn a_cut_out_card_shadows_like_its_stripes_modelled_as_geometry() {
    let grey = json!({"name": "grey"});
    let cut = load(&glb(
        &[floor(), card_part(-1.0, 1.0, 1)],
        json!([grey, mask_material("MASK")]),
    ));
    let opaque_card = load(&glb(
        &[floor(), card_part(-1.0, 1.0, 1)],
        json!([grey, mask_material("OPAQUE")]),
    ));
    let mut stripes = vec![floor()];
    for k in 0..4 {
        let x0 = -1.0 + 0.5 * k as f32;
        stripes.push(card_part(x0, x0 + 0.25, 0));
    }
    let stripes = load(&glb(&stripes, json!([grey])));
    let options = shadowed(3, SAMPLES);
    for backend in [Backend::Embree, Backend::Obvhs] {
        let reference = floor_transfer(&stripes, &bake(&stripes, backend, &options));
        let baked = floor_transfer(&cut, &bake(&cut, backend, &options));
        let (fraction, worst) = agreement(&baked, &reference, 2e-3);
        eprintln!(
            "{}: {:.2} % of {} floor vertices within 2e-3 (worst {worst:.2e})",
            backend.name(),
            100.0 * fraction,
            baked.len()
        );
        assert!(fraction >= 0.99, "{}: {fraction}", backend.name());
        // The oracle can fail: the card baked as opaque is far off.
        let solid = floor_transfer(&opaque_card, &bake(&opaque_card, backend, &options));
        let (fraction, worst) = agreement(&solid, &reference, 2e-3);
        eprintln!(
            "{}: opaque card: {:.2} % within 2e-3 (worst {worst:.2e})",
            backend.name(),
            100.0 * fraction
        );
        assert!(fraction < 0.9 && worst > 0.05, "{}", backend.name());
    }
}

/// `BLEND`: a uniform card of alpha a stops a ray with probability a, so the floor's
/// transfer is a·(under an opaque card) + (1 − a)·(open sky) within Monte Carlo noise; the
/// decision is a hash of the ray, so both backends give the same bake.
#[test]
fn a_blended_card_stops_rays_with_its_alpha_as_probability() {
    let grey = json!({"name": "grey"});
    let alpha = 0.3f32;
    let card = |mode: &str, a: f32| {
        json!({"name": "card", "alphaMode": mode,
            "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, a]}})
    };
    let blended = load(&glb(
        &[floor(), card_part(-1.0, 1.0, 1)],
        json!([grey, card("BLEND", alpha)]),
    ));
    let solid = load(&glb(
        &[floor(), card_part(-1.0, 1.0, 1)],
        json!([grey, card("OPAQUE", 1.0)]),
    ));
    let open = load(&glb(&[floor()], json!([grey])));
    let samples = 1024;
    let options = shadowed(2, samples);
    let embree = floor_transfer(&blended, &bake(&blended, Backend::Embree, &options));
    let obvhs = floor_transfer(&blended, &bake(&blended, Backend::Obvhs, &options));
    let (same, worst) = agreement(&embree, &obvhs, 1e-5);
    assert!(same >= 0.999, "backends: {same} agree, worst {worst:.2e}");
    let solid = floor_transfer(&solid, &bake(&solid, Backend::Embree, &options));
    let open = floor_transfer(&open, &bake(&open, Backend::Embree, &options));
    // The blended bake's difference from the mix is a sum over the card's rays of
    // (Bernoulli(a) − a)·y/N (cosine-weighted rays; |y| ≤ 0.49 in bands 0 and 1).
    let (mut sum, mut count, mut worst) = (0.0f64, 0usize, 0.0f64);
    for ((b, s), o) in embree.iter().zip(&solid).zip(&open) {
        for j in 0..b.len() {
            let expected = alpha * s[j] + (1.0 - alpha) * o[j];
            let d = f64::from(b[j] - expected);
            sum += d * d;
            count += 1;
            worst = worst.max(d.abs());
        }
    }
    let rms = (sum / count as f64).sqrt();
    let a = f64::from(alpha);
    let sigma = 0.49 * (a * (1.0 - a) / f64::from(samples)).sqrt();
    eprintln!("blend: rms {rms:.2e}, worst {worst:.2e}, σ bound {sigma:.2e}");
    assert!(
        rms < sigma && worst < 5.0 * sigma,
        "rms {rms}, worst {worst}"
    );
    // Switched off (the card opaque), the mix is far off.
    let off = solid
        .iter()
        .zip(&embree)
        .map(|(s, b)| (s[0] - b[0]).abs())
        .fold(0.0f32, f32::max);
    assert!(f64::from(off) > 5.0 * sigma, "{off}");
}

/// Closest hits (what bounce gathers and leak tests trace) pass the cut-out parts too: rays
/// from below the card find the card where the stripes' geometry is, on both backends.
#[test]
fn closest_hits_pass_through_the_cut_out_parts() {
    let grey = json!({"name": "grey"});
    let cut = load(&glb(
        &[floor(), card_part(-1.0, 1.0, 1)],
        json!([grey, mask_material("MASK")]),
    ));
    let mut rng = prt_baker::math::sampling::Pcg32::new(30, 1);
    let rays: Vec<prt_baker::trace::Ray> = (0..20_000)
        .map(|_| {
            let origin = Vec3::new(rng.next_f32() * 3.0 - 1.5, 0.1, rng.next_f32() * 3.0 - 1.5);
            let dir = Vec3::new(rng.next_f32() - 0.5, 1.0, rng.next_f32() - 0.5);
            prt_baker::trace::Ray {
                origin,
                dir,
                tfar: f32::INFINITY,
            }
        })
        .collect();
    for backend in [Backend::Embree, Backend::Obvhs] {
        let tracer = build(backend, &cut, TracerOptions::default()).expect("tracer");
        let mut hits = vec![None; rays.len()];
        tracer.intersect(&rays, &mut hits);
        let mut occluded = vec![false; rays.len()];
        tracer.occluded(&rays, &mut occluded);
        let (mut wrong, mut on_card, mut wrong_hits) = (0, 0, 0);
        for ((ray, hit), blocked) in rays.iter().zip(&hits).zip(&occluded) {
            // Where the ray crosses the card's plane, and whether a stripe is there.
            let p = ray.origin + ray.dir * ((0.6 - ray.origin.y) / ray.dir.y);
            let u = (p.x + 1.0) / 2.0;
            let solid = p.x.abs() < 1.0 && p.z.abs() < 1.0 && (u * 8.0).floor() as i32 % 2 == 0;
            on_card += usize::from(solid);
            wrong += usize::from(hit.is_some() != solid || *blocked != solid);
            wrong_hits += usize::from(hit.is_some() != solid);
        }
        eprintln!(
            "{}: {on_card} rays hit a stripe, {wrong} answers wrong ({wrong_hits} closest hits)",
            backend.name()
        );
        assert!(on_card > 2_000 && wrong <= 5, "{}: {wrong}", backend.name());
    }
}
