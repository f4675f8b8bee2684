//! glTF `doubleSided` through the `prt-bake` binary (docs/guides/production-assets.md, "Two-sided surfaces"):
//! `--double-sided off` bakes the file a bake before the flag was read made; `auto` adds the
//! back sheet's receivers, which `--receivers`, lightmaps (generated or given TEXCOORD_1
//! atlases), relight and the glTF export (single-sided materials, both sheets) carry; a
//! reader pairs a file baked either way with the scene; a bad flag is refused.

mod common;

use common::*;
use prt_baker::CoefficientFile;
use serde_json::{Value, json};

/// A ground quad (y = 0, facing +y) and a card above it (y = 1, facing +y, 2 × 2 cells,
/// its material `"doubleSided": flag` and TEXCOORD_1 over [0, 1]²), as a .gltf.
fn scene(flag: Value) -> Vec<u8> {
    let ground: Vec<[f32; 3]> = vec![
        [-2.0, 0.0, -2.0],
        [-2.0, 0.0, 2.0],
        [2.0, 0.0, 2.0],
        [2.0, 0.0, -2.0],
    ];
    let mut card = Vec::new();
    let mut uv1 = Vec::new();
    for j in 0..3 {
        for i in 0..3 {
            card.push([i as f32 - 1.0, 1.0, j as f32 - 1.0]);
            uv1.push([i as f32 / 2.0, j as f32 / 2.0]);
        }
    }
    let mut card_indices = Vec::new();
    for j in 0..2u32 {
        for i in 0..2u32 {
            let at = |i: u32, j: u32| 3 * j + i;
            card_indices.extend([at(i, j), at(i, j + 1), at(i + 1, j + 1)]);
            card_indices.extend([at(i, j), at(i + 1, j + 1), at(i + 1, j)]);
        }
    }
    let ground_indices: Vec<u32> = vec![0, 1, 2, 0, 2, 3];
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut view = |bytes: Vec<u8>, bin: &mut Vec<u8>| {
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        bin.extend(bytes);
        views.len() - 1
    };
    let floats = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let ints = |v: &[u32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let g = view(floats(ground.as_flattened()), &mut bin);
    let gi = view(ints(&ground_indices), &mut bin);
    let c = view(floats(card.as_flattened()), &mut bin);
    let cu = view(floats(uv1.as_flattened()), &mut bin);
    let ci = view(ints(&card_indices), &mut bin);
    let accessor = |view: usize, count: usize, kind: &str, component: u32| {
        let mut a =
            json!({"bufferView": view, "count": count, "type": kind, "componentType": component});
        if kind == "VEC3" {
            a["min"] = json!([-2.0, 0.0, -2.0]);
            a["max"] = json!([2.0, 1.0, 2.0]);
        }
        a
    };
    let document = json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0, "name": "ground"}, {"mesh": 1, "name": "card"}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": 2, "TEXCOORD_1": 3}, "indices": 4, "material": 1}]},
        ],
        "materials": [{"name": "grey"}, {"name": "leaf", "doubleSided": flag}],
        "accessors": [
            accessor(g, 4, "VEC3", 5126), accessor(gi, 6, "SCALAR", 5125),
            accessor(c, 9, "VEC3", 5126), accessor(cu, 9, "VEC2", 5126),
            accessor(ci, 24, "SCALAR", 5125),
        ],
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len(),
            "uri": format!("data:application/octet-stream;base64,{}", base64(&bin))}],
    });
    serde_json::to_vec_pretty(&document).unwrap()
}

/// The vertex count (header bytes 24..32) of a baked file.
fn vertex_count(bytes: &[u8]) -> u64 {
    u64::from_le_bytes(bytes[24..32].try_into().unwrap())
}

const RIG: &str = "[[light]]\nkind = \"sun\"\ntheta = 170\nphi = 0\nintensity = 2.0\n";

#[test]
fn double_sided_auto_adds_back_receivers_and_off_bakes_the_front_only() {
    let s = Scratch::new();
    s.write("card.gltf", scene(json!(true)));
    s.write("single.gltf", scene(json!(false)));
    let bake = ["--order", "3", "--samples", "32"];
    s.bake("card.gltf", "auto.prt", &bake);
    s.bake(
        "card.gltf",
        "off.prt",
        &[&bake[..], &["--double-sided", "off"]].concat(),
    );
    s.bake("single.gltf", "single.prt", &bake);
    let (auto, off, single) = (
        s.read("out/auto.prt"),
        s.read("out/off.prt"),
        s.read("out/single.prt"),
    );
    assert_eq!(
        vertex_count(&auto),
        4 + 9 + 9,
        "auto: the card's back sheet"
    );
    assert_eq!(vertex_count(&off), 4 + 9);
    // Off is the bake before the flag was read: the file of the same scene without the
    // flag, but for the fingerprint (the glTF's bytes differ) and the checksum.
    assert_eq!(off.len(), single.len());
    let differing: Vec<usize> = (0..off.len()).filter(|&i| off[i] != single[i]).collect();
    assert!(
        differing
            .iter()
            .all(|i| (56..64).contains(i) || (124..128).contains(i)),
        "off differs from the single-sided bake at bytes {differing:?}"
    );
    // Readers pair both files with the scene (the fingerprint says which), and relight the
    // back sheet under a sun from below.
    s.write("rig.toml", RIG);
    for file in ["auto", "off"] {
        let (prt, ply) = (format!("out/{file}.prt"), format!("out/{file}.ply"));
        s.run(&[
            "relight",
            "card.gltf",
            &prt,
            "--lights",
            "rig.toml",
            "-o",
            &ply,
        ])
        .success();
    }
    // The export writes the back sheet as a mesh of its own, each sheet marked on its node.
    s.run(&[
        "export",
        "out/auto.prt",
        "--scene",
        "card.gltf",
        "--gltf",
        "out/auto.glb",
    ])
    .success();
    let glb = s.read("out/auto.glb");
    let json_length = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let exported: Value = serde_json::from_slice(&glb[20..20 + json_length]).unwrap();
    // The source's doubleSided is kept on its material; each sheet's node says which side
    // it is, for renderers that cull back faces to show each sheet's own transfer.
    let materials = exported["materials"].as_array().unwrap();
    let leaf = materials.iter().find(|m| m["name"] == "leaf").unwrap();
    assert_eq!(leaf["doubleSided"], json!(true), "{materials:?}");
    let sheets: Vec<&Value> = exported["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|n| n["extras"]["prt_sheet"].as_str().map(|_| n))
        .collect();
    assert_eq!(sheets.len(), 2, "{sheets:?}");
    assert_eq!(
        sheets[1]["name"].as_str().map(|n| n.ends_with("(back)")),
        Some(true)
    );
    assert_eq!(sheets[1]["extras"]["prt_sheet"], "back");
    let names: Vec<&str> = exported["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|n| n["name"].as_str())
        .collect();
    assert!(names.iter().any(|n| n.ends_with("(back)")), "{names:?}");
    // --receivers picks a back sheet with its front.
    s.bake(
        "card.gltf",
        "card.prt",
        &[&bake[..], &["--receivers", "card"]].concat(),
    );
    let file = CoefficientFile::read(&s.path("out/card.prt")).unwrap();
    let receivers = file.header.receivers.expect("a receiver section");
    assert_eq!(receivers.objects, [1, 2], "the card and its back sheet");
}

#[test]
fn lightmaps_give_the_back_sheet_texels_of_its_own() {
    let s = Scratch::new();
    s.write("card.gltf", scene(json!(true)));
    // Given TEXCOORD_1: the back sheet's UVs are its front's, so every object is packed
    // with a scale and an offset of its own (docs/guides/lightmaps.md, "Per-object lightmap UVs").
    let given = s.bake(
        "card.gltf",
        "given.prt",
        &["--order", "2", "--samples", "16", "--lightmap", "32"],
    );
    assert!(given.stderr.contains("overlap"), "{}", given.stderr);
    let file = CoefficientFile::read(&s.path("out/given.prt")).unwrap();
    let lightmap = file.lightmap.expect("a texel bake");
    assert_eq!(lightmap.objects.len(), 3, "ground, card, back sheet placed");
    // A generated atlas: the back sheet's charts are charts of their own.
    let generated = [
        "--order",
        "2",
        "--samples",
        "16",
        "--lightmap",
        "64",
        "--texel-size",
        "0.25",
    ];
    s.bake("card.gltf", "auto.prt", &generated);
    s.bake(
        "card.gltf",
        "off.prt",
        &[&generated[..], &["--double-sided", "off"]].concat(),
    );
    let texels = |name: &str| {
        let file = CoefficientFile::read(&s.path(name)).unwrap();
        let valid = file.lightmap.expect("a texel bake").valid;
        valid.iter().filter(|&&v| v).count()
    };
    let (auto, off) = (texels("out/auto.prt"), texels("out/off.prt"));
    // The card is a fifth of the surface without its back sheet, a third with it.
    assert!(
        auto as f64 > 1.15 * off as f64,
        "baked texels: auto {auto}, off {off}"
    );
}

#[test]
fn a_double_sided_flag_that_is_not_a_boolean_is_refused() {
    let s = Scratch::new();
    s.write("bad.gltf", scene(json!("yes")));
    s.run(&["bake", "bad.gltf", "-o", "out/x.prt", "--quiet"])
        .fails_with_bad_input(&["bad.gltf"]);
    s.assert_out_holds(&[]);
}
