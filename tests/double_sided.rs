//! Double-sided surfaces (the rule is in docs/guides/production-assets.md,
//! "Two-sided surfaces"): transfer is baked for the side a triangle's normal faces; a surface seen from
//! both sides is two single-sided sheets back to back, and each sheet's receivers see past
//! their twin. A single-sided triangle occludes from both sides, on both backends. A glTF
//! `doubleSided` card gets its back sheet from the loader, baked as the twin made by hand.

use glam::Vec3;
use prt_baker::math::sh;
use prt_baker::support::progress::Silent;
use prt_baker::trace::{Backend, TracerOptions, build};
use prt_baker::{Scene, Transfer};
use prt_tests::*;
use serde_json::json;

const ORDER: usize = 3;
const SAMPLES: u32 = 256;

fn bake(scene: &Scene, backend: Backend) -> Transfer {
    let tracer = build(backend, scene, TracerOptions::default()).expect("tracer");
    prt_baker::bake(scene, Some(&*tracer), &shadowed(ORDER, SAMPLES), &Silent).expect("bake")
}

/// Vertex `v`'s coefficients (channel 0).
fn coefficients(t: &Transfer, v: u32) -> &[f32] {
    let n = sh::coeff_count(ORDER);
    &t.coefficients[v as usize * n * t.channels..][..n]
}

/// The radiance transfer toward a distant light from direction `d` (the light's SH is a
/// delta there): Σ_j c_j y_j(d).
fn response(c: &[f32], d: Vec3) -> f32 {
    let mut y = vec![0.0; c.len()];
    sh::Basis::new(ORDER).eval(d, &mut y);
    c.iter().zip(&y).map(|(a, b)| a * b).sum()
}

/// A 2 × 2 card at height 1: its front sheet faces +z; `back` adds its twin facing −z.
fn card(back: bool) -> Vec<prt_baker::scene::Mesh> {
    let corner = Vec3::new(-1.0, -1.0, 1.0);
    let mut sheets = vec![grid("front", corner, Vec3::X * 2.0, Vec3::Y * 2.0, 4)];
    if back {
        sheets.push(grid("back", corner, Vec3::Y * 2.0, Vec3::X * 2.0, 4));
    }
    sheets
}

/// A card lit only from behind (a light straight below): its front side stays dark and its
/// back side is lit as an engine shows it (the lobe about the flipped normal); the twin
/// sheet does not shadow its partner.
#[test]
fn a_card_lit_from_behind_is_dark_in_front_and_lit_behind() {
    let scene = scene(card(true));
    for backend in [Backend::Embree, Backend::Obvhs] {
        let t = bake(&scene, backend);
        let side = |object: usize| {
            let vertices = scene.objects[object].vertices.clone();
            let count = vertices.len() as f32;
            let (mut below, mut above, mut open) = (0.0, 0.0, 0.0);
            for v in vertices {
                let c = coefficients(&t, v);
                below += response(c, Vec3::NEG_Z) / count;
                above += response(c, Vec3::Z) / count;
                open += t.visibility[v as usize].accessibility / count;
            }
            (below, above, open)
        };
        let (front, back) = (side(0), side(1));
        eprintln!("{backend:?}: front (from below, above, open) {front:?}, back {back:?}");
        // Lit: the order-3 clamped cosine's response at its axis (0.338); dark: its response
        // at the opposite pole (0.020, the truncated series' ringing).
        assert!(
            back.0 > 0.3 && back.1.abs() < 0.03,
            "{backend:?}: back {back:?}"
        );
        assert!(
            front.0.abs() < 0.03 && front.1 > 0.3,
            "{backend:?}: front {front:?}"
        );
        assert!(
            front.2 > 0.99 && back.2 > 0.99,
            "{backend:?}: a twin shadows its partner"
        );
    }
}

/// A single-sided card shadows a floor the same whichever way it faces.
#[test]
fn a_single_sided_card_occludes_from_both_sides() {
    let floor = || {
        grid(
            "floor",
            Vec3::new(-3.0, -3.0, 0.0),
            Vec3::X * 6.0,
            Vec3::Y * 6.0,
            12,
        )
    };
    let up = scene(vec![floor(), card(false).remove(0)]);
    let down = scene(vec![
        floor(),
        grid(
            "down",
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::Y * 2.0,
            Vec3::X * 2.0,
            4,
        ),
    ]);
    let alone = scene(vec![floor()]);
    for backend in [Backend::Embree, Backend::Obvhs] {
        let (up_t, down_t, alone_t) = (
            bake(&up, backend),
            bake(&down, backend),
            bake(&alone, backend),
        );
        let centre = 6 * 13 + 6; // the floor's centre vertex, under the card
        let dc = coefficients(&alone_t, centre)[0];
        let (u, d) = (
            coefficients(&up_t, centre)[0],
            coefficients(&down_t, centre)[0],
        );
        eprintln!(
            "{backend:?}: centre DC open {dc:.4}, under a card facing up {u:.4}, down {d:.4}"
        );
        assert!(
            u < 0.8 * dc,
            "{backend:?}: a card facing away does not occlude"
        );
        for v in up.objects[0].vertices.clone() {
            assert_eq!(
                coefficients(&up_t, v),
                coefficients(&down_t, v),
                "{backend:?}: vertex {v}"
            );
        }
    }
}

/// The front sheet of [`card`] as a `.glb` (positions, normals, indices; node at the
/// identity, so the positions are the scene's bit for bit) whose material is `doubleSided`.
fn gltf_card(double_sided: bool) -> Vec<u8> {
    let front = card(false).remove(0);
    let floats = |v: &[Vec3]| -> Vec<u8> {
        v.iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes)
            .collect()
    };
    let mut bin = floats(&front.positions);
    let normals_at = bin.len();
    bin.extend(floats(front.normals.as_ref().expect("grid normals")));
    let indices_at = bin.len();
    bin.extend(
        front
            .triangles
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes()),
    );
    let count = front.positions.len();
    let view = |offset: usize, length: usize| json!({"buffer": 0, "byteOffset": offset, "byteLength": length});
    let document = json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "card"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"name": "leaf", "doubleSided": double_sided}],
        "accessors": [
            {"bufferView": 0, "count": count, "type": "VEC3", "componentType": 5126,
             "min": [-1.0, -1.0, 1.0], "max": [1.0, 1.0, 1.0]},
            {"bufferView": 1, "count": count, "type": "VEC3", "componentType": 5126},
            {"bufferView": 2, "count": 3 * front.triangles.len(), "type": "SCALAR", "componentType": 5125},
        ],
        "bufferViews": [view(0, normals_at), view(normals_at, indices_at - normals_at),
            view(indices_at, bin.len() - indices_at)],
        "buffers": [{"byteLength": bin.len()}],
    });
    glb(&serde_json::to_vec(&document).expect("json"), &bin)
}

fn load_glb(bytes: &[u8]) -> Scene {
    let folder = tempfile::tempdir().expect("temporary folder");
    let path = folder.path().join("card.glb");
    std::fs::write(&path, bytes).expect("write glb");
    Scene::load(&path).expect("load glb")
}

/// Per object (front, back), the mean response to a light straight below and above, and the
/// mean accessibility.
fn sides(scene: &Scene, t: &Transfer) -> Vec<(f32, f32, f32)> {
    scene
        .objects
        .iter()
        .map(|object| {
            let count = object.vertices.len() as f32;
            let (mut below, mut above, mut open) = (0.0, 0.0, 0.0);
            for v in object.vertices.clone() {
                let c = coefficients(t, v);
                below += response(c, Vec3::NEG_Z) / count;
                above += response(c, Vec3::Z) / count;
                open += t.visibility[v as usize].accessibility / count;
            }
            (below, above, open)
        })
        .collect()
}

/// A glTF `doubleSided` card lit only from behind: the loader adds its back sheet (flipped
/// normals, reversed winding), which bakes bit for bit as the twin a user models by hand
/// (though only the front is traced), lit from below (0.338) while the front stays dark
/// (0.020); the card without the flag has no receiver lit from behind.
#[test]
fn a_gltf_double_sided_card_bakes_its_back_sheet_as_a_hand_made_twin() {
    let gltf = load_glb(&gltf_card(true));
    assert_eq!(
        gltf.objects.len(),
        2,
        "no back sheet for a doubleSided material"
    );
    assert_eq!(
        gltf.objects[1].name,
        format!("{} (back)", gltf.objects[0].name)
    );
    let front = card(false).remove(0);
    let back = prt_baker::scene::Mesh {
        name: "back".into(),
        normals: front
            .normals
            .as_ref()
            .map(|n| n.iter().map(|n| -*n).collect()),
        triangles: front.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect(),
        ..front.clone()
    };
    let twins = scene(vec![front, back]);
    let single = load_glb(&gltf_card(false));
    assert_eq!(
        single.objects.len(),
        1,
        "a back sheet for a single-sided material"
    );
    for backend in [Backend::Embree, Backend::Obvhs] {
        let (t, hand) = (bake(&gltf, backend), bake(&twins, backend));
        assert_eq!(
            t.coefficients, hand.coefficients,
            "{backend:?}: not the twins' bake"
        );
        let s = sides(&gltf, &t);
        eprintln!(
            "{backend:?}: glTF card (from below, above, open): front {:?}, back {:?}",
            s[0], s[1]
        );
        assert!(
            s[1].0 > 0.3 && s[1].1.abs() < 0.03,
            "{backend:?}: back {:?}",
            s[1]
        );
        assert!(
            s[0].0.abs() < 0.03 && s[0].1 > 0.3,
            "{backend:?}: front {:?}",
            s[0]
        );
        assert!(
            s[0].2 > 0.99 && s[1].2 > 0.99,
            "{backend:?}: a sheet shadows its twin"
        );
        let s = sides(&single, &bake(&single, backend));
        assert!(s[0].0.abs() < 0.03, "{backend:?}: single-sided {:?}", s[0]);
    }
}

/// The light a glTF `doubleSided` card's underside reflects reaches the floor under it: a
/// closest hit on the back of the front sheet lands on the back sheet (`TwinFacing`), whose
/// transfer is the underside's. Without the back sheet that hit is a back face, which
/// reflects nothing, and the floor's interreflected transfer is its shadowed one.
#[test]
fn a_double_sided_card_reflects_from_its_back_onto_the_floor() {
    let floor = grid("floor", Vec3::new(-0.5, -0.5, 0.0), Vec3::X, Vec3::Y, 2);
    let mut card = card(false).remove(0);
    card.material.double_sided = true;
    let mut two = scene(vec![floor, card]);
    let one = two.clone();
    two.add_back_sheets().expect("back sheets");
    assert_eq!(two.objects.len(), 3);
    let options = prt_baker::BakeOptions {
        mode: prt_baker::Mode::Interreflected,
        bounces: 1,
        ..shadowed(ORDER, SAMPLES)
    };
    let centre = 4; // the floor's centre vertex
    for backend in [Backend::Embree, Backend::Obvhs] {
        let tracer = |s: &Scene| build(backend, s, TracerOptions::default()).expect("tracer");
        let bake_with = |s: &Scene, o: &prt_baker::BakeOptions| {
            prt_baker::bake(s, Some(&*tracer(s)), o, &Silent).expect("bake")
        };
        let shadowed_dc = coefficients(&bake_with(&one, &shadowed(ORDER, SAMPLES)), centre)[0];
        let (with, without) = (
            coefficients(&bake_with(&two, &options), centre)[0],
            coefficients(&bake_with(&one, &options), centre)[0],
        );
        eprintln!(
            "{backend:?}: floor centre DC shadowed {shadowed_dc:.4}, interreflected: \
             without back sheet {without:.4}, with {with:.4}"
        );
        assert!(
            (without - shadowed_dc).abs() < 1e-3,
            "{backend:?}: light off a back face"
        );
        assert!(
            with > without + 0.02,
            "{backend:?}: no light off the card's back sheet"
        );
    }
}
