//! End-to-end tests of a texel bake's exports: `export --exr` (coefficients as OpenEXR images,
//! read back here with the `exr` crate's reader), `relight -o .exr`, and `export --glb`
//! (TEXCOORD_1 = the atlas, read back with the `gltf` crate).

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::*;
use prt_baker::CoefficientFile;

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);
/// A unit cube, outward-facing, 8 vertices shared by its 12 triangles.
const CUBE: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
    f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\n\
    f 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
const RIG: &str = include_str!("../../viewer/src/default-rig.toml");

/// An EXR's size, its channels' samples (image rows, top first) and whether they are f16.
struct Exr {
    width: usize,
    height: usize,
    channels: BTreeMap<String, Vec<f32>>,
    half: bool,
}

fn read_exr(path: &Path) -> Exr {
    use exr::prelude::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .unwrap_or_else(|err| panic!("{}: {err}", path.display()));
    let layer = &image.layer_data;
    let mut half = true;
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            half &= matches!(c.sample_data, FlatSamples::F16(_));
            (
                c.name.to_string(),
                c.sample_data.values_as_f32().collect::<Vec<f32>>(),
            )
        })
        .collect();
    Exr {
        width: layer.size.width(),
        height: layer.size.height(),
        channels,
        half,
    }
}

/// The texel shown at pixel `i` (row-major, top row first) of a W×H lightmap image: image row
/// r is texel row H−1−r.
fn texel_of_pixel(i: usize, width: usize, height: usize) -> usize {
    let (x, row) = (i % width, i / width);
    (height - 1 - row) * width + x
}

/// `read` equals `exact` to f32 (bit for bit) or, for f16 images, to f16 rounding.
fn assert_stored(read: f32, exact: f32, half: bool, what: &str) {
    let ok = match half {
        false => read.to_bits() == exact.to_bits(),
        // 11 significant bits: round to nearest is within 2^-11 relative; subnormals 2^-25.
        true => (read - exact).abs() <= (exact.abs() * 2f32.powi(-11)).max(2f32.powi(-25)),
    };
    assert!(ok, "{what}: image holds {read}, the .prt {exact}");
}

/// The images `export --exr` wrote match the .prt texel for texel, and the manifest says so.
fn check_exr_export(s: &Scratch, prt: &str, dir: &str, half: bool) {
    let file = CoefficientFile::read(&s.path(prt)).unwrap();
    let block = file.lightmap.as_ref().unwrap();
    let (w, h) = (block.width as usize, block.height as usize);
    let n = (file.header.order * file.header.order) as usize;
    let manifest: serde_json::Value =
        serde_json::from_slice(&s.read(&format!("{dir}/manifest.json"))).unwrap();
    assert_eq!(manifest["width"], w);
    assert_eq!(manifest["height"], h);
    assert_eq!(manifest["order"], file.header.order);
    assert_eq!(manifest["channels"], 1);
    assert_eq!(manifest["pixel_type"], if half { "f16" } else { "f32" });
    let transfer = manifest["transfer"].as_array().unwrap();
    assert_eq!(transfer.len(), n.div_ceil(4), "{manifest}");
    let mut names = vec!["manifest.json".to_string(), "texel_state.exr".to_string()];
    let mut seen = vec![false; n];
    for entry in transfer {
        let name = entry["file"].as_str().unwrap();
        names.push(name.to_string());
        let exr = read_exr(&s.path(&format!("{dir}/{name}")));
        assert_eq!((exr.width, exr.height, exr.half), (w, h, half), "{name}");
        let rgba = entry["rgba"].as_array().unwrap();
        for (i, channel) in ["R", "G", "B", "A"].iter().enumerate() {
            let samples = &exr.channels[*channel];
            match rgba[i].as_u64() {
                // Padding: zero everywhere.
                None => assert!(samples.iter().all(|&x| x == 0.0), "{name} {channel}"),
                Some(j) => {
                    let j = j as usize;
                    seen[j] = true;
                    assert!(
                        name.contains(&format!("{:02}", j - j % 4)),
                        "{name} holds {j}"
                    );
                    for (p, &read) in samples.iter().enumerate() {
                        let t = texel_of_pixel(p, w, h);
                        let what = format!("{name} {channel} pixel {p} (texel {t}, T{j})");
                        assert_stored(read, file.vertex(t, 0)[j], half, &what);
                    }
                }
            }
        }
    }
    assert!(seen.iter().all(|&s| s), "coefficients missing: {seen:?}");
    let state = read_exr(&s.path(&format!("{dir}/texel_state.exr")));
    for (p, &read) in state.channels["Y"].iter().enumerate() {
        let t = texel_of_pixel(p, w, h);
        let expected = match (block.valid[t], block.dilated[t]) {
            (true, _) => 1.0,
            (false, true) => 0.5,
            _ => 0.0,
        };
        assert_eq!(read, expected, "texel_state pixel {p}");
    }
    if let Some(ao) = &file.ao {
        assert_eq!(manifest["ao"]["file"], "ao.exr");
        names.push("ao.exr".into());
        let image = read_exr(&s.path(&format!("{dir}/ao.exr")));
        for (p, &read) in image.channels["Y"].iter().enumerate() {
            assert_stored(read, ao[texel_of_pixel(p, w, h)], half, "ao");
        }
    }
    if let Some(bent) = &file.bent_normal {
        assert_eq!(manifest["bent_normal"]["file"], "bent_normal.exr");
        names.push("bent_normal.exr".into());
        let image = read_exr(&s.path(&format!("{dir}/bent_normal.exr")));
        for (axis, channel) in ["R", "G", "B"].iter().enumerate() {
            for (p, &read) in image.channels[*channel].iter().enumerate() {
                let exact = bent[texel_of_pixel(p, w, h)][axis];
                assert_stored(read, exact, half, "bent normal");
            }
        }
    }
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    assert_folder_holds(&s.path(dir), &names);
}

#[test]
fn exr_export_holds_the_texel_coefficients() {
    let s = Scratch::new();
    // Order 3: 9 coefficients, the third image holds T8 and three zeros.
    s.bake(
        CORNELL,
        "lm.prt",
        &[
            "--lightmap",
            "24",
            "--order",
            "3",
            "--samples",
            "16",
            "--aux",
            "ao,bent-normal",
        ],
    );
    let export = |dir: &str, extra: &[&str]| {
        let mut args = vec!["export", "out/lm.prt", "--scene", CORNELL, "--exr", dir];
        args.extend(extra);
        s.run(&args)
    };
    // The folder is made, nested too.
    let run = export("out/exr/f32", &[]).success();
    assert!(
        run.stdout.contains("6 24×24 f32 OpenEXR images"),
        "{}",
        run.stdout
    );
    check_exr_export(&s, "out/lm.prt", "out/exr/f32", false);
    let manifest: serde_json::Value =
        serde_json::from_slice(&s.read("out/exr/f32/manifest.json")).unwrap();
    let last = &manifest["transfer"][2];
    assert_eq!(last["file"], "transfer_08-11.exr");
    assert_eq!(last["coefficients"], serde_json::json!([8]));
    assert_eq!(last["zero_padded_channels"], 3);
    export("out/exr/f16", &["--exr-type", "f16"]).success();
    check_exr_export(&s, "out/lm.prt", "out/exr/f16", true);
    // Deterministic: the same export twice is the same bytes.
    export("out/again", &[]).success();
    for name in ["transfer_00-03.exr", "ao.exr", "texel_state.exr"] {
        assert!(
            s.read(&format!("out/exr/f32/{name}")) == s.read(&format!("out/again/{name}")),
            "{name} differs between two exports"
        );
    }
    s.assert_out_holds(&["lm.prt", "exr", "again"]);
}

#[test]
fn exr_export_refuses_vertex_bakes_and_bad_folders() {
    let s = Scratch::new();
    s.bake(CORNELL, "v.prt", &["--samples", "4"]);
    s.run(&[
        "export",
        "out/v.prt",
        "--scene",
        CORNELL,
        "--exr",
        "out/exr",
    ])
    .fails_with(2, &["out/v.prt", "per-vertex bake", "--lightmap"]);
    // --exr-type needs --exr.
    let run = s.run(&[
        "export",
        "out/v.prt",
        "--scene",
        CORNELL,
        "--npz",
        "out/v.npz",
        "--exr-type",
        "f16",
    ]);
    assert_eq!(run.code, Some(2), "{}", run.stderr);
    s.bake(CORNELL, "lm.prt", &["--lightmap", "16", "--samples", "4"]);
    // A file where the folder should be.
    s.write("out/file", "mine");
    s.run(&[
        "export",
        "out/lm.prt",
        "--scene",
        CORNELL,
        "--exr",
        "out/file",
    ])
    .fails_with(2, &["out/file", "not a directory"]);
    // One image's path is refused (a folder): nothing is written, not even the others.
    std::fs::create_dir_all(s.path("out/exr/texel_state.exr")).unwrap();
    s.run(&[
        "export",
        "out/lm.prt",
        "--scene",
        CORNELL,
        "--exr",
        "out/exr",
    ])
    .fails_with(2, &["texel_state.exr", "is a directory"]);
    assert_folder_holds(&s.path("out/exr"), &["texel_state.exr"]);
    assert_eq!(s.read("out/file"), b"mine");
    s.assert_out_holds(&["v.prt", "lm.prt", "file", "exr"]);
}

/// Per texel Σ_j T_j·L_cj with the rig turned to the bake's up axis, computed here.
fn expected_radiance(file: &CoefficientFile, rig: &Path) -> Vec<[f32; 3]> {
    let light = prt_baker::light::Rig::load(rig)
        .unwrap()
        .project(file.header.order as usize)
        .in_scene_frame(file.header.up);
    (0..file.header.vertex_count as usize)
        .map(|t| {
            std::array::from_fn(|c| {
                let transfer = file.vertex(t, 0);
                transfer
                    .iter()
                    .zip(&light.rgb[c])
                    .map(|(&x, &l)| f64::from(x) * l)
                    .sum::<f64>() as f32
            })
        })
        .collect()
}

#[test]
fn relight_to_exr_is_the_linear_lightmap_and_the_png_its_tone_mapped_image() {
    let s = Scratch::new();
    s.write("rig.toml", RIG);
    // z-up as baked, and y-up: the rig is turned to the bake's axis for both images.
    for (name, up) in [("z", "z"), ("y", "y")] {
        let prt = format!("{name}.prt");
        s.bake(
            CORNELL,
            &prt,
            &["--lightmap", "20", "--samples", "16", "--up", up],
        );
        let relight = |output: &str| {
            s.run(&[
                "relight",
                CORNELL,
                &format!("out/{prt}"),
                "--lights",
                "rig.toml",
                "-o",
                output,
            ])
        };
        relight(&format!("out/{name}.exr")).success();
        relight(&format!("out/{name}.png")).success();
        let file = CoefficientFile::read(&s.path(&format!("out/{prt}"))).unwrap();
        let block = file.lightmap.as_ref().unwrap();
        let expected = expected_radiance(&file, &s.path("rig.toml"));
        let exr = read_exr(&s.path(&format!("out/{name}.exr")));
        assert!(!exr.half);
        let png = image::load_from_memory(&s.read(&format!("out/{name}.png")))
            .unwrap()
            .to_rgb8();
        let mut largest = 0.0f32;
        for p in 0..20 * 20 {
            let t = texel_of_pixel(p, 20, 20);
            let rgb = [
                exr.channels["R"][p],
                exr.channels["G"][p],
                exr.channels["B"][p],
            ];
            for c in 0..3 {
                let e = expected[t][c];
                assert!(
                    (rgb[c] - e).abs() <= 1e-5 * e.abs().max(1.0),
                    "up {up}, pixel {p} (texel {t}) channel {c}: {} against {e}",
                    rgb[c]
                );
                largest = largest.max(e);
            }
            let filled = block.valid[t] || block.dilated[t];
            assert_eq!(exr.channels["A"][p], f32::from(u8::from(filled)));
            // The PNG is the same image, tone-mapped (exposure 0).
            assert_eq!(
                png.get_pixel((p % 20) as u32, (p / 20) as u32).0,
                prt_baker::export::relight::display_colour(rgb, 0.0),
                "pixel {p}"
            );
        }
        assert!(largest > 0.1, "a dark lightmap ({largest}) tests little");
    }
    // A vertex bake relights to a mesh only.
    s.bake(CORNELL, "v.prt", &["--samples", "4"]);
    s.run(&[
        "relight",
        CORNELL,
        "out/v.prt",
        "--lights",
        "rig.toml",
        "-o",
        "out/v.exr",
    ])
    .fails_with(2, &["out/v.exr", ".ply"]);
    s.assert_out_holds(&[
        "z.prt", "z.exr", "z.png", "y.prt", "y.exr", "y.png", "v.prt",
    ]);
}

#[test]
fn glb_of_a_texel_bake_has_the_atlas_as_texcoord_1() {
    let s = Scratch::new();
    s.write("rig.toml", RIG);
    // A cube of 8 shared vertices unwraps into 6 planar charts: every vertex lies in three
    // of them, so the glb splits it into three.
    s.write("cube.obj", CUBE);
    s.bake(
        "cube.obj",
        "lm.prt",
        &["--lightmap", "32", "--samples", "4", "--mode", "unshadowed"],
    );
    let run = s
        .run(&[
            "export",
            "out/lm.prt",
            "--scene",
            "cube.obj",
            "--glb",
            "out/lm.glb",
            "--lights",
            "rig.toml",
        ])
        .success();
    assert!(run.stdout.contains("TEXCOORD_1"), "{}", run.stdout);
    s.run(&[
        "relight",
        "cube.obj",
        "out/lm.prt",
        "--lights",
        "rig.toml",
        "-o",
        "out/lit.png",
    ])
    .success();
    s.run(&[
        "export",
        "out/lm.prt",
        "--scene",
        "cube.obj",
        "--exr",
        "out/exr",
    ])
    .success();
    let state = read_exr(&s.path("out/exr/texel_state.exr"));
    let file = CoefficientFile::read(&s.path("out/lm.prt")).unwrap();
    let block = file.lightmap.as_ref().unwrap();
    let scene = prt_baker::Scene::load(&s.path("cube.obj")).unwrap();
    let glb = gltf::Gltf::from_slice(&s.read("out/lm.glb")).unwrap();
    let blob = glb.blob.as_deref().unwrap();
    let mut triangle = 0;
    let mut vertices = 0;
    for mesh in glb.meshes() {
        for primitive in mesh.primitives() {
            let reader = primitive.reader(|_| Some(blob));
            let uv1: Vec<[f32; 2]> = reader.read_tex_coords(1).unwrap().into_f32().collect();
            let positions: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
            let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
            vertices += positions.len();
            for corners in indices.chunks_exact(3) {
                for (c, &i) in corners.iter().enumerate() {
                    let atlas = block.uv1[triangle][c];
                    // glTF's v runs down from the image's top.
                    assert_eq!(
                        uv1[i as usize],
                        [atlas.x, 1.0 - atlas.y],
                        "triangle {triangle} corner {c}"
                    );
                    // The corner is still its vertex: z-up turned to glTF's y-up.
                    let p = scene.positions[scene.triangles[triangle][c] as usize];
                    assert_eq!(positions[i as usize], [p.x, p.z, -p.y]);
                }
                // An engine sampling the EXR with TEXCOORD_1 (v down, row 0 at the top) at
                // the triangle's UV centroid reads a baked texel.
                let centroid = corners
                    .iter()
                    .map(|&i| uv1[i as usize])
                    .fold([0.0; 2], |a, b| [a[0] + b[0] / 3.0, a[1] + b[1] / 3.0]);
                let (x, row) = ((centroid[0] * 32.0) as usize, (centroid[1] * 32.0) as usize);
                assert_eq!(
                    state.channels["Y"][row * 32 + x],
                    1.0,
                    "triangle {triangle}: texel_state.exr at its TEXCOORD_1 centroid"
                );
                triangle += 1;
            }
        }
    }
    assert_eq!(triangle, scene.triangles.len());
    assert_eq!(vertices, 24, "8 cube corners in 3 charts each");
    // The relit lightmap is embedded: relight's PNG, named by every material.
    let bytes = s.read("out/lm.glb");
    let json_length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let root: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_length]).unwrap();
    let index = root["materials"][0]["extras"]["prt_lightmap"]["index"]
        .as_u64()
        .expect("materials name the lightmap") as usize;
    assert_eq!(
        root["materials"][0]["extras"]["prt_lightmap"]["texCoord"],
        1
    );
    let texture = glb.textures().nth(index).unwrap();
    let gltf::image::Source::View { view, .. } = texture.source().source() else {
        panic!("an embedded image");
    };
    let png = &blob[view.offset()..view.offset() + view.length()];
    assert!(
        png == s.read("out/lit.png"),
        "the embedded lightmap is not relight's PNG"
    );
    s.assert_out_holds(&["lm.prt", "lm.glb", "lit.png", "exr"]);
    // A scene that is not the bake's is refused.
    s.run(&[
        "export",
        "out/lm.prt",
        "--scene",
        CORNELL,
        "--glb",
        "out/x.glb",
    ])
    .fails_with_bad_input(&["out/lm.prt"]);
}
