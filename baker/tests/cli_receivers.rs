//! `bake --receivers` end to end: a bake of some objects holds, for their vertices, exactly
//! the whole bake's transfer (every other object still occludes and, interreflected,
//! reflects), records which objects it covers, and `export`, `relight` and `inspect` read
//! it; glTF node names and `extras.prt.receive` choose receivers too.

mod common;

use std::io::Read;

use common::*;
use prt_baker::{CoefficientFile, Scene};
use serde_json::{Value, json};

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);

/// The Cornell objects `floor` and `tall_box_*` (the floor lies in the boxes' shadows).
fn floor_and_tall_box(scene: &Scene) -> Vec<u32> {
    (0..scene.objects.len() as u32)
        .filter(|&o| {
            let name = &scene.objects[o as usize].name;
            name == "floor" || name.starts_with("tall_box_")
        })
        .collect()
}

/// Asserts that `part` (a bake of `objects`) holds, row for row, `whole`'s transfer at
/// those objects' vertices, bit for bit.
fn assert_rows_equal(
    scene: &Scene,
    whole: &CoefficientFile,
    part: &CoefficientFile,
    objects: &[u32],
) {
    let receivers = part.header.receivers.as_ref().expect("a receiver section");
    assert_eq!(receivers.objects, objects);
    assert_eq!(receivers.object_count as usize, scene.objects.len());
    let rows = receivers.vertices(scene);
    assert_eq!(part.header.vertex_count, rows.len() as u64);
    assert!(rows.len() < scene.vertex_count());
    assert_eq!(part.header.channels, whole.header.channels);
    for c in 0..whole.header.channels as usize {
        for (r, &v) in rows.iter().enumerate() {
            let (found, expected) = (part.vertex(r, c), whole.vertex(v as usize, c));
            assert!(
                found
                    .iter()
                    .zip(expected)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "vertex {v} (row {r}), channel {c}: {found:?} vs the whole bake's {expected:?}"
            );
        }
    }
}

/// The oracle: shadowed (both backends, adaptive, matrix) and interreflected bakes of the floor and the tall
/// box equal the whole bake at their vertices, so every other object occluded (and
/// reflected) as in the whole scene; the shadowed part casts only its own vertices' rays.
#[test]
fn receivers_bake_exactly_the_whole_bakes_transfer_at_their_vertices() {
    let s = Scratch::new();
    let scene = Scene::load(CORNELL.as_ref()).unwrap();
    let objects = floor_and_tall_box(&scene);
    let mut cases = vec![
        ("obvhs", vec!["--backend", "obvhs"]),
        (
            "adaptive",
            // Raw: a denoised vertex bake of some objects is refused.
            vec![
                "--target-error",
                "0.01",
                "--samples",
                "256",
                "--denoise",
                "off",
            ],
        ),
        ("matrix", vec!["--transfer", "matrix", "--order", "3"]),
        (
            "interreflected",
            vec!["--mode", "interreflected", "--aux", "ao,bent-normal"],
        ),
    ];
    // `make no-embree` runs these tests in a build without Embree.
    if cfg!(feature = "embree") {
        cases.push(("embree", vec!["--backend", "embree"]));
    }
    for (name, extra) in cases {
        let whole = format!("{name}-whole.prt");
        let part = format!("{name}-part.prt");
        s.bake(CORNELL, &whole, &extra);
        let mut args = extra.clone();
        args.extend(["--receivers", "floor,tall_box_*"]);
        let run = s.bake(CORNELL, &part, &args);
        let whole = CoefficientFile::read(&s.path(&format!("out/{whole}"))).unwrap();
        let part_file = CoefficientFile::read(&s.path(&format!("out/{part}"))).unwrap();
        assert_rows_equal(&scene, &whole, &part_file, &objects);
        let rows = part_file
            .header
            .receivers
            .as_ref()
            .unwrap()
            .vertices(&scene);
        if let (Some(ao), Some(whole_ao)) = (&part_file.ao, &whole.ao) {
            for (r, &v) in rows.iter().enumerate() {
                assert_eq!(ao[r].to_bits(), whole_ao[v as usize].to_bits());
            }
        }
        assert!(
            run.stdout.contains(&format!(
                "baked {} vertices of 6 receiving objects",
                rows.len()
            )),
            "{}",
            run.stdout
        );
        if !["interreflected", "adaptive"].contains(&name) {
            let rays = format!("{} rays", rows.len() * 64);
            assert!(run.stdout.contains(&rays), "{name}: {}", run.stdout);
        }
    }
}

/// The shape and data of array `name` of an npz export (little-endian float32).
fn npz_array(path: &std::path::Path, name: &str) -> Option<Vec<f32>> {
    let mut zip = zip::ZipArchive::new(std::fs::File::open(path).unwrap()).unwrap();
    let mut bytes = Vec::new();
    zip.by_name(&format!("{name}.npy"))
        .ok()?
        .read_to_end(&mut bytes)
        .unwrap();
    let header = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    Some(
        bytes[10 + header..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect(),
    )
}

/// `export --npz` writes every vertex: the baked rows at the receivers, the unshadowed lobe
/// (1/π)A_l·y_lm(n) elsewhere, and `receives`; `relight` relights the receivers as the
/// whole bake's; `inspect` shows the receivers; `compress` refuses such a file, and `export`
/// a transfer-matrix bake of some objects (whose other vertices are not filled in yet).
#[test]
fn export_relight_and_inspect_read_a_bake_of_some_objects() {
    let s = Scratch::new();
    let scene = Scene::load(CORNELL.as_ref()).unwrap();
    let objects = floor_and_tall_box(&scene);
    s.bake(CORNELL, "whole.prt", &[]);
    s.bake(CORNELL, "part.prt", &["--receivers", "floor,tall_box_*"]);
    let part = CoefficientFile::read(&s.path("out/part.prt")).unwrap();
    let rows = part.header.receivers.as_ref().unwrap().vertices(&scene);

    s.run(&[
        "export",
        "out/part.prt",
        "--scene",
        CORNELL,
        "--npz",
        "out/part.npz",
    ])
    .success();
    let transfer = npz_array(&s.path("out/part.npz"), "transfer").unwrap();
    let receives = npz_array(&s.path("out/part.npz"), "receives").unwrap();
    assert_eq!(receives.len(), scene.vertex_count());
    let n = 16;
    let mut baked = vec![false; scene.vertex_count()];
    for (r, &v) in rows.iter().enumerate() {
        baked[v as usize] = true;
        assert_eq!(&transfer[v as usize * n..][..n], part.vertex(r, 0));
    }
    for v in 0..scene.vertex_count() {
        assert_eq!(receives[v], if baked[v] { 1.0 } else { 0.0 }, "vertex {v}");
        if !baked[v] {
            // Bands 0 and 1 of the clamped cosine: 1/(2√π), and (2/3)·y_1m(n).
            let t = &transfer[v * n..][..n];
            let normal = scene.normals[v];
            let c1 = 2.0 / 3.0 * 0.488_602_5;
            let expected = [0.282_094_8, -c1 * normal.y, c1 * normal.z, -c1 * normal.x];
            for j in 0..4 {
                assert!(
                    (t[j] - expected[j]).abs() < 1e-5,
                    "vertex {v}, j {j}: {t:?}"
                );
            }
        }
    }

    // Relit, the receivers' radiance is the whole bake's.
    s.write(
        "rig.toml",
        "[[light]]\nkind = \"sun\"\ntheta = 30\nphi = 40\nintensity = 2.0\n",
    );
    for name in ["part", "whole"] {
        s.run(&[
            "relight",
            CORNELL,
            &format!("out/{name}.prt"),
            "--lights",
            "rig.toml",
            "-o",
            &format!("out/{name}.ply"),
        ])
        .success();
    }
    let (part_ply, whole_ply) = (s.read("out/part.ply"), s.read("out/whole.ply"));
    // The headers' comments name the files; the vertex records follow them.
    let header_end = |b: &[u8]| b.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let record = 9 * 4 + 3;
    let (ph, wh) = (header_end(&part_ply), header_end(&whole_ply));
    assert_eq!(part_ply.len() - ph, whole_ply.len() - wh);
    for &v in &rows {
        let at = v as usize * record;
        assert_eq!(
            part_ply[ph + at..ph + at + record],
            whole_ply[wh + at..wh + at + record],
            "vertex {v}"
        );
    }

    let inspect = s.run(&["inspect", "out/part.prt"]).success();
    let header: Value = serde_json::from_str(&inspect.stdout).unwrap();
    assert_eq!(
        header["receivers"],
        json!({"object_count": scene.objects.len(), "objects": objects})
    );
    let inspect = s.run(&["inspect", "out/whole.prt"]).success();
    assert!(!inspect.stdout.contains("receivers"));

    s.run(&[
        "compress",
        "out/part.prt",
        "-o",
        "out/c.prt",
        "--clusters",
        "4",
    ])
    .fails_with(EXIT_BAD_COMMAND_LINE, &["--receivers"]);
    let matrix = [
        "--receivers",
        "floor",
        "--transfer",
        "matrix",
        "--order",
        "3",
    ];
    s.bake(CORNELL, "m.prt", &matrix);
    s.run(&[
        "export",
        "out/m.prt",
        "--scene",
        CORNELL,
        "--npz",
        "out/m.npz",
    ])
    .fails_with_bad_input(&["a transfer-matrix bake of some objects"]);
}

/// A glob that matches nothing names the scene's objects; `--receivers` with a lightmap or
/// shards is refused by the command line.
#[test]
fn receiver_globs_that_match_nothing_and_conflicting_options_are_refused() {
    let s = Scratch::new();
    let run = s.run(&["bake", CORNELL, "-o", "out/x.prt", "--receivers", "flor"]);
    run.fails_with(
        EXIT_BAD_COMMAND_LINE,
        &["'flor' matches no object", "'floor'"],
    );
    let run = s.run(&["bake", CORNELL, "-o", "out/x.prt", "--receivers", "[floor"]);
    run.fails_with(EXIT_BAD_COMMAND_LINE, &["not a glob"]);
    for extra in [["--shard", "0/2"], ["--checkpoint", "out/c"]] {
        let mut args = vec!["bake", CORNELL, "-o", "out/x.prt", "--receivers", "floor"];
        args.extend(extra);
        let run = s.run(&args);
        assert_eq!(run.code, Some(EXIT_BAD_COMMAND_LINE), "{}", run.stderr);
    }
    assert!(!s.path("out/x.prt").exists());
}

/// A glTF builder: meshes of positions and triangles in one data-URI buffer.
fn gltf(meshes: &[(&[[f32; 3]], &[u32])], nodes: Value, roots: &[usize]) -> Vec<u8> {
    let meshes: Vec<_> = meshes.iter().map(|&(p, i)| (p, i, &[][..])).collect();
    gltf_uv1(&meshes, nodes, roots)
}

/// A mesh's positions, triangle indices and lightmap UVs (none where empty).
type MeshUv1<'a> = (&'a [[f32; 3]], &'a [u32], &'a [[f32; 2]]);

/// [`gltf`], each mesh with lightmap UVs (TEXCOORD_1) where its third slice is not empty.
fn gltf_uv1(meshes: &[MeshUv1<'_>], nodes: Value, roots: &[usize]) -> Vec<u8> {
    let mut bin = Vec::new();
    let (mut views, mut accessors, mut gltf_meshes) = (vec![], vec![], vec![]);
    for (positions, indices, uv1) in meshes {
        let lo: Vec<f32> = (0..3)
            .map(|k| positions.iter().map(|p| p[k]).fold(f32::INFINITY, f32::min))
            .collect();
        let hi: Vec<f32> = (0..3)
            .map(|k| {
                positions
                    .iter()
                    .map(|p| p[k])
                    .fold(f32::NEG_INFINITY, f32::max)
            })
            .collect();
        views.push(
            json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": positions.len() * 12}),
        );
        bin.extend(positions.iter().flatten().flat_map(|x| x.to_le_bytes()));
        accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5126,
            "count": positions.len(), "type": "VEC3", "min": lo, "max": hi}));
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": indices.len() * 4}));
        bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
        accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5125,
            "count": indices.len(), "type": "SCALAR"}));
        let mut primitive = json!({"attributes": {"POSITION": accessors.len() - 2},
            "indices": accessors.len() - 1});
        if !uv1.is_empty() {
            views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": uv1.len() * 8}));
            bin.extend(uv1.iter().flatten().flat_map(|x| x.to_le_bytes()));
            accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5126,
                "count": uv1.len(), "type": "VEC2"}));
            primitive["attributes"]["TEXCOORD_1"] = json!(accessors.len() - 1);
        }
        gltf_meshes.push(json!({"primitives": [primitive]}));
    }
    let document = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": roots}],
        "nodes": nodes,
        "meshes": gltf_meshes,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len(),
            "uri": format!("data:application/octet-stream;base64,{}", base64(&bin))}],
    });
    serde_json::to_vec(&document).unwrap()
}

/// Positions and triangle indices of a mesh.
type MeshData = (Vec<[f32; 3]>, Vec<u32>);

/// A ground quad (y up; its vertex 4 at the centre) and a unit cube above it.
fn ground_and_cube() -> (MeshData, MeshData) {
    let ground = vec![
        [-2.0, 0.0, -2.0],
        [2.0, 0.0, -2.0],
        [2.0, 0.0, 2.0],
        [-2.0, 0.0, 2.0],
        [0.0, 0.0, 0.0],
    ];
    let ground_triangles = vec![0, 4, 1, 1, 4, 2, 2, 4, 3, 3, 4, 0];
    let mut cube = Vec::new();
    for corner in 0..8 {
        cube.push([
            if corner & 1 == 0 { -0.5 } else { 0.5 },
            if corner & 2 == 0 { 0.5 } else { 1.5 },
            if corner & 4 == 0 { -0.5 } else { 0.5 },
        ]);
    }
    let cube_triangles = vec![
        0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4,
        1, 5, 7, 1, 7, 3,
    ];
    ((ground, ground_triangles), (cube, cube_triangles))
}

/// glTF: a node marked `"extras": {"prt": {"receive": false}}` leaves its subtree out of a
/// bake without `--receivers`; `--receivers` matches ancestor node names and overrides the
/// marks.
#[test]
fn gltf_extras_and_node_names_choose_receivers() {
    let s = Scratch::new();
    let ((ground, ground_triangles), (cube, cube_triangles)) = ground_and_cube();
    let nodes = json!([
        {"name": "Ground", "mesh": 0},
        {"name": "Props", "children": [2], "extras": {"prt": {"receive": false}}},
        {"name": "Crate", "mesh": 1},
    ]);
    s.write(
        "scene.gltf",
        gltf(
            &[(&ground, &ground_triangles), (&cube, &cube_triangles)],
            nodes,
            &[0, 1],
        ),
    );
    let scene = Scene::load(&s.path("scene.gltf")).unwrap();
    let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["Ground", "Crate"]);
    s.bake("scene.gltf", "marked.prt", &[]);
    s.bake("scene.gltf", "props.prt", &["--receivers", "Prop?"]);
    s.bake("scene.gltf", "all.prt", &["--receivers", "*"]);
    let read = |name: &str| CoefficientFile::read(&s.path(&format!("out/{name}"))).unwrap();
    let (marked, props, all) = (read("marked.prt"), read("props.prt"), read("all.prt"));
    assert_eq!(marked.header.receivers.as_ref().unwrap().objects, [0]);
    assert_eq!(props.header.receivers.as_ref().unwrap().objects, [1]);
    assert!(all.header.receivers.is_none());
    assert_rows_equal(&scene, &all, &marked, &[0]);
    assert_rows_equal(&scene, &all, &props, &[1]);
    // The cube shadows the ground's centre (unoccluded T0 = 0.282) in the bake of the
    // ground alone.
    let under = marked.vertex(4, 0)[0];
    assert!(
        under < 0.2,
        "ground centre T0 {under}: no shadow from the cube"
    );
}

/// Hostile scene structure: a glTF of a few megabytes that places one triangle at a million
/// nodes is refused before it is flattened (its size named against --max-memory), and a file
/// that declares EXT_mesh_gpu_instancing without using it on a node bakes as it is, without
/// a warning (baker/tests/instancing.rs tests the extension itself).
#[test]
fn a_million_instances_are_refused_before_flattening_and_gpu_instancing_is_read() {
    let s = Scratch::new();
    let triangle = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]];
    let count = 1_000_000;
    let nodes = Value::Array(vec![json!({"mesh": 0}); count]);
    let roots: Vec<usize> = (0..count).collect();
    s.write(
        "million.gltf",
        gltf(&[(&triangle, &[0, 1, 2])], nodes, &roots),
    );
    let run = s.run(&[
        "bake",
        "million.gltf",
        "-o",
        "out/x.prt",
        "--max-memory",
        "100",
    ]);
    run.fails_with_bad_input(&[
        "million.gltf",
        "flattening 1000000 mesh nodes into 3000000 vertices and 1000000 triangles",
        "memory limit",
    ]);
    assert!(!s.path("out/x.prt").exists());

    let ((ground, ground_triangles), _) = ground_and_cube();
    let mut document: Value = serde_json::from_slice(&gltf(
        &[(&ground, &ground_triangles)],
        json!([{"name": "Ground", "mesh": 0}]),
        &[0],
    ))
    .unwrap();
    document["extensionsUsed"] = json!(["EXT_mesh_gpu_instancing"]);
    s.write("instanced.gltf", serde_json::to_vec(&document).unwrap());
    let run = s.run(&[
        "bake",
        "instanced.gltf",
        "-o",
        "out/i.prt",
        "--samples",
        "16",
    ]);
    let run = run.success();
    assert!(
        !run.stderr.contains("EXT_mesh_gpu_instancing"),
        "{}",
        run.stderr
    );
}

/// The ground and a 1.5 × 1.5 roof facing down at height 1 above its centre, with lightmap
/// UVs (TEXCOORD_1) apart: the ground's in u ∈ [0.05, 0.45], the roof's in [0.6, 0.9].
fn ground_and_roof_uv1() -> Vec<u8> {
    let ((ground, ground_triangles), _) = ground_and_cube();
    let roof: Vec<[f32; 3]> = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]
        .iter()
        .map(|[x, z]| [0.75 * x, 1.0, 0.75 * z])
        .collect();
    let roof_triangles = [0, 1, 2, 0, 2, 3];
    let ground_uv1: Vec<[f32; 2]> = ground
        .iter()
        .map(|p| [0.05 + 0.1 * (p[0] + 2.0), 0.05 + 0.225 * (p[2] + 2.0)])
        .collect();
    let roof_uv1: Vec<[f32; 2]> = roof
        .iter()
        .map(|p| [0.6 + 0.2 * (p[0] + 0.75), 0.3 + 0.2 * (p[2] + 0.75)])
        .collect();
    let nodes = json!([{"name": "Ground", "mesh": 0}, {"name": "Roof", "mesh": 1}]);
    gltf_uv1(
        &[
            (&ground, &ground_triangles, &ground_uv1),
            (&roof, &roof_triangles, &roof_uv1),
        ],
        nodes,
        &[0, 1],
    )
}

/// `--lightmap --receivers`: on the scene's own lightmap UVs, the ground's texels are bit for
/// bit those of the bake of every object (same texels, same streams, same occluders), the
/// roof is left out of the atlas ((−1, −1)) and shades the ground; a glTF mark
/// `"prt": {"receive": false}` chooses the same file; export reads it.
#[test]
fn lightmap_receivers_bake_the_whole_bakes_texels_on_scene_uvs() {
    let s = Scratch::new();
    s.write("uv.gltf", ground_and_roof_uv1());
    let mut marked: Value = serde_json::from_slice(&ground_and_roof_uv1()).unwrap();
    marked["nodes"][1]["extras"] = json!({"prt": {"receive": false}});
    s.write("marked.gltf", serde_json::to_vec(&marked).unwrap());
    let lightmap = ["--lightmap", "32", "--samples", "16", "--aux", "ao"];
    s.bake("uv.gltf", "whole.prt", &lightmap);
    let mut args = lightmap.to_vec();
    args.extend(["--receivers", "Ground"]);
    s.bake("uv.gltf", "ground.prt", &args);
    s.bake("marked.gltf", "marked.prt", &lightmap);
    let read = |name: &str| CoefficientFile::read(&s.path(&format!("out/{name}"))).unwrap();
    let (whole, ground, marked) = (read("whole.prt"), read("ground.prt"), read("marked.prt"));
    let (w, g) = (
        whole.lightmap.as_ref().unwrap(),
        ground.lightmap.as_ref().unwrap(),
    );
    assert_eq!(g.uv1[..4], w.uv1[..4], "the ground's UVs");
    assert!(
        g.uv1[4..]
            .iter()
            .flatten()
            .all(|c| c.x == -1.0 && c.y == -1.0)
    );
    let ground_texels = (0..w.valid.len()).filter(|&t| w.valid[t] && t % 32 < 16);
    let baked: Vec<usize> = (0..g.valid.len()).filter(|&t| g.valid[t]).collect();
    assert_eq!(baked, ground_texels.collect::<Vec<_>>());
    for &t in &baked {
        assert_eq!(ground.vertex(t, 0), whole.vertex(t, 0), "texel {t}");
        assert_eq!(
            ground.ao.as_ref().unwrap()[t],
            whole.ao.as_ref().unwrap()[t],
            "texel {t}'s AO"
        );
    }
    // The roof shades the ground's centre (texel (8, 16)), not its corner (2, 2).
    let (under, open) = (
        ground.vertex(16 * 32 + 8, 0)[0],
        ground.vertex(2 * 32 + 2, 0)[0],
    );
    assert!(
        under < 0.8 * open,
        "T0 {under} under the roof, {open} in the open"
    );
    assert_eq!(marked.coefficients, ground.coefficients);
    assert_eq!(marked.lightmap, ground.lightmap);
    for out in [
        ["--glb", "out/g.glb"],
        ["--npz", "out/g.npz"],
        ["--exr", "out/exr"],
    ] {
        let mut args = vec!["export", "out/ground.prt", "--scene", "uv.gltf"];
        args.extend(out);
        s.run(&args).success();
    }
}

/// `--lightmap --receivers` on a generated atlas: the receivers are unwrapped alone, so an
/// unshadowed bake of the ground under the roof is bit for bit the bake of a scene of the
/// ground only; shadowed, the roof's shadow differs. Interreflected is refused (exit 2).
#[test]
fn lightmap_receivers_unwrap_the_receivers_alone() {
    let s = Scratch::new();
    let ((ground, ground_triangles), _) = ground_and_cube();
    let mut scene: Value = serde_json::from_slice(&ground_and_roof_uv1()).unwrap();
    for mesh in scene["meshes"].as_array_mut().unwrap() {
        mesh["primitives"][0]["attributes"]
            .as_object_mut()
            .unwrap()
            .remove("TEXCOORD_1");
    }
    s.write("roof.gltf", serde_json::to_vec(&scene).unwrap());
    let nodes = json!([{"name": "Ground", "mesh": 0}]);
    s.write(
        "alone.gltf",
        gltf(&[(&ground, &ground_triangles)], nodes, &[0]),
    );
    let args = |mode: &'static str, receivers: bool| {
        let mut args = vec!["--lightmap", "32", "--samples", "16", "--mode", mode];
        if receivers {
            args.extend(["--receivers", "Ground"]);
        }
        args
    };
    s.bake("roof.gltf", "roof-u.prt", &args("unshadowed", true));
    s.bake("alone.gltf", "alone-u.prt", &args("unshadowed", false));
    s.bake("roof.gltf", "roof-s.prt", &args("shadowed", true));
    s.bake("alone.gltf", "alone-s.prt", &args("shadowed", false));
    let read = |name: &str| CoefficientFile::read(&s.path(&format!("out/{name}"))).unwrap();
    let (roof, alone) = (read("roof-u.prt"), read("alone-u.prt"));
    let (r, a) = (
        roof.lightmap.as_ref().unwrap(),
        alone.lightmap.as_ref().unwrap(),
    );
    assert_eq!(r.uv1[..4], a.uv1[..]);
    assert_eq!(r.valid, a.valid);
    assert_eq!(roof.coefficients, alone.coefficients);
    assert_ne!(
        read("roof-s.prt").coefficients,
        read("alone-s.prt").coefficients
    );
    let run = s.run(&[
        "bake",
        "roof.gltf",
        "-o",
        "out/ir.prt",
        "--lightmap",
        "32",
        "--mode",
        "interreflected",
        "--receivers",
        "Ground",
    ]);
    run.fails_with(
        EXIT_BAD_COMMAND_LINE,
        &["--receivers with --lightmap", "interreflected"],
    );
    assert!(!s.path("out/ir.prt").exists());
}

/// `--lightmap --receivers` on a per-object atlas (the roof has no lightmap UVs, so each
/// receiver is packed alone): with a lid over the roof left out, the unshadowed lightmap is
/// bit for bit the scene's without the lid; the lid is placed at scale 0, offset (−1, −1), its
/// triangles out of the atlas; export reads the file.
#[test]
fn lightmap_receivers_pack_per_object_atlases_without_the_others() {
    let s = Scratch::new();
    let mut scene: Value = serde_json::from_slice(&ground_and_roof_uv1()).unwrap();
    scene["meshes"][1]["primitives"][0]["attributes"]
        .as_object_mut()
        .unwrap()
        .remove("TEXCOORD_1");
    s.write("two.gltf", serde_json::to_vec(&scene).unwrap());
    scene["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!({"name": "Lid", "mesh": 1, "translation": [0.0, 0.5, 0.0]}));
    scene["scenes"][0]["nodes"] = json!([0, 1, 2]);
    s.write("three.gltf", serde_json::to_vec(&scene).unwrap());
    let args = ["--lightmap", "32", "--samples", "8", "--mode", "unshadowed"];
    s.bake("two.gltf", "two.prt", &args);
    let mut some = args.to_vec();
    some.extend(["--receivers", "Ground,Roof"]);
    s.bake("three.gltf", "three.prt", &some);
    let read = |name: &str| CoefficientFile::read(&s.path(&format!("out/{name}"))).unwrap();
    let (two, three) = (read("two.prt"), read("three.prt"));
    let (a, b) = (
        two.lightmap.as_ref().unwrap(),
        three.lightmap.as_ref().unwrap(),
    );
    assert_eq!(b.source, prt_baker::formats::header::AtlasSource::PerObject);
    assert_eq!(b.objects[..2], a.objects[..]);
    assert_eq!(
        (b.objects[2].scale, b.objects[2].offset),
        ([0.0; 2], [-1.0; 2])
    );
    assert_eq!(b.uv1[..6], a.uv1[..]);
    assert!(
        b.uv1[6..]
            .iter()
            .flatten()
            .all(|c| c.x == -1.0 && c.y == -1.0)
    );
    assert_eq!(
        (&b.valid, &three.coefficients),
        (&a.valid, &two.coefficients)
    );
    for out in [["--glb", "out/t.glb"], ["--npz", "out/t.npz"]] {
        let mut args = vec!["export", "out/three.prt", "--scene", "three.gltf"];
        args.extend(out);
        s.run(&args).success();
    }
}
