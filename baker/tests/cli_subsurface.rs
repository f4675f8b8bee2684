//! `prt-bake bake --materials`: a translucent cube's bake is RGB and glows, a bad
//! materials file is refused with its file, line and key (exit 3), and what subsurface bakes
//! do not support yet is refused as usage (exit 2), with nothing written. Texel bakes
//! (`--lightmap`) of translucent materials work as vertex bakes do.

use std::path::Path;
use std::process::{Command, Output};

/// A closed unit cube of material `jade`, its faces' vertices of their own.
const CUBE: &str = "mtllib cube.mtl\nusemtl jade\n\
v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";

fn bake(dir: &Path, mats: &str, extra: &[&str]) -> Output {
    std::fs::write(dir.join("cube.obj"), CUBE).unwrap();
    std::fs::write(dir.join("cube.mtl"), "newmtl jade\nKd 1 1 1\n").unwrap();
    std::fs::write(dir.join("mats.toml"), mats).unwrap();
    Command::new(env!("CARGO_BIN_EXE_prt-bake"))
        .arg("bake")
        .arg(dir.join("cube.obj"))
        .arg("--materials")
        .arg(dir.join("mats.toml"))
        .arg("-o")
        .arg(dir.join("out.prt"))
        .args(["--samples", "64", "--quiet"])
        .args(extra)
        .output()
        .unwrap()
}

const JADE: &str = "[material.jade.subsurface]\nscattering = [3, 4, 3]\nabsorption = [0.2, 0.05, 0.2]\nior = 1.5\n";

#[test]
fn a_translucent_bake_is_rgb() {
    // Per vertex and per texel, shadowed and interreflected.
    for extra in [
        &[][..],
        &["--lightmap", "32"][..],
        &["--lightmap", "32", "--mode", "interreflected"][..],
    ] {
        let dir = tempfile::tempdir().unwrap();
        let out = bake(dir.path(), JADE, extra);
        assert!(
            out.status.success(),
            "{extra:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let inspect = Command::new(env!("CARGO_BIN_EXE_prt-bake"))
            .arg("inspect")
            .arg(dir.path().join("out.prt"))
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&inspect.stdout);
        assert!(text.contains("\"channels\": 3"), "{extra:?}: {text}");
    }
}

#[test]
fn bad_materials_are_refused_at_their_line() {
    let dir = tempfile::tempdir().unwrap();
    for (mats, expected) in [
        (
            "[material.jade.subsurface]\nscattering = 1\nabsorption = -1\n",
            "mats.toml:3",
        ),
        (
            "[material.jade.subsurface]\nscattering = 1\nabsorption = 0\nior = inf\n",
            "mats.toml:4",
        ),
        ("[material.jade.subsurface]\nscatter = 1\n", "mats.toml:2"),
        (
            "\n[material.jadde.subsurface]\nscattering = 1\nabsorption = 0\n",
            "mats.toml:2",
        ),
    ] {
        let out = bake(dir.path(), mats, &[]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(3), "{mats}: {stderr}");
        assert!(stderr.contains(expected), "{mats}: {stderr}");
        assert!(!dir.path().join("out.prt").exists());
    }
}

#[test]
fn what_subsurface_bakes_lack_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    for extra in [&["--mode", "unshadowed"][..], &["--transfer", "matrix"][..]] {
        let out = bake(dir.path(), JADE, extra);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{extra:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(!dir.path().join("out.prt").exists());
    }
}

/// A glTF cube of material `jade` (`cube.gltf` + `cube.bin` in `dir`), the same closed cube as
/// [`CUBE`], its material carrying `extensions`.
fn gltf_cube(dir: &Path, extensions: &serde_json::Value) -> std::path::PathBuf {
    let positions: [[f32; 3]; 8] = [
        [0., 0., 0.],
        [1., 0., 0.],
        [1., 1., 0.],
        [0., 1., 0.],
        [0., 0., 1.],
        [1., 0., 1.],
        [1., 1., 1.],
        [0., 1., 1.],
    ];
    let faces: [[u32; 3]; 12] = [
        [1, 3, 2],
        [1, 4, 3],
        [5, 6, 7],
        [5, 7, 8],
        [1, 2, 6],
        [1, 6, 5],
        [2, 3, 7],
        [2, 7, 6],
        [3, 4, 8],
        [3, 8, 7],
        [4, 1, 5],
        [4, 5, 8],
    ];
    let mut bin: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    bin.extend(faces.iter().flatten().flat_map(|i| (i - 1).to_le_bytes()));
    std::fs::write(dir.join("cube.bin"), &bin).unwrap();
    let json = serde_json::json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1, "material": 0 }] }],
        "materials": [{
            "name": "jade",
            "pbrMetallicRoughness": { "baseColorFactor": [1.0, 1.0, 1.0, 1.0] },
            "extensions": extensions,
        }],
        "buffers": [{ "uri": "cube.bin", "byteLength": bin.len() }],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": 96 },
            { "buffer": 0, "byteOffset": 96, "byteLength": 144 },
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0] },
            { "bufferView": 1, "componentType": 5125, "count": 36, "type": "SCALAR" },
        ],
    });
    let path = dir.join("cube.gltf");
    std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
    path
}

fn bake_gltf(scene: &Path, output: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_prt-bake"))
        .arg("bake")
        .arg(scene)
        .arg("-o")
        .arg(output)
        .args(["--samples", "64", "--order", "3", "--quiet"])
        .args(extra)
        .output()
        .unwrap()
}

fn jade_extensions(colour: serde_json::Value, thickness: f64) -> serde_json::Value {
    serde_json::json!({
        "KHR_materials_volume": {
            "thicknessFactor": thickness,
            "attenuationDistance": 0.5,
            "attenuationColor": colour,
        },
        "KHR_materials_diffuse_transmission": {
            "diffuseTransmissionFactor": 1.0,
            "diffuseTransmissionColorFactor": [0.8, 0.9, 0.6],
        },
        "KHR_materials_ior": { "ior": 1.4 },
    })
}

/// A glTF material with a volume and diffuse transmission bakes as the same scene with the
/// equivalent `--materials` entry (byte for byte), per vertex and per texel; a materials
/// file overrides the glTF's medium; without the extensions the cube bakes opaque (grey).
#[test]
fn gltf_volume_materials_bake_as_their_materials_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = gltf_cube(d, &jade_extensions(serde_json::json!([0.7, 0.8, 0.3]), 1.0));
    let media = prt_baker::scene::gltf_media(&scene).unwrap();
    assert!(media.warnings.is_empty(), "{:?}", media.warnings);
    let [(name, m)] = &media.media[..] else {
        panic!("one medium: {media:?}");
    };
    assert_eq!(name, "jade");
    let s = m.scattering;
    let a = m.absorption;
    let equivalent = format!(
        "[material.jade.subsurface]\nscattering = [{:?}, {:?}, {:?}]\nabsorption = [{:?}, {:?}, {:?}]\nior = {:?}\n",
        s.x, s.y, s.z, a.x, a.y, a.z, m.ior
    );
    std::fs::write(d.join("same.toml"), equivalent).unwrap();
    std::fs::write(d.join("other.toml"), JADE).unwrap();
    for extra in [&[][..], &["--lightmap", "16"][..]] {
        let run = |name: &str, more: &[&str]| {
            let out = bake_gltf(&scene, &d.join(name), &[extra, more].concat());
            assert!(
                out.status.success(),
                "{name} {extra:?}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            std::fs::read(d.join(name)).unwrap()
        };
        let own = run("own.prt", &[]);
        let same = run(
            "same.prt",
            &["--materials", d.join("same.toml").to_str().unwrap()],
        );
        let other = run(
            "other.prt",
            &["--materials", d.join("other.toml").to_str().unwrap()],
        );
        assert!(
            own == same,
            "{extra:?}: the glTF's medium bakes unlike its TOML"
        );
        assert!(
            own != other,
            "{extra:?}: --materials did not override the glTF"
        );
    }
    // Without the extensions: opaque, one grey channel.
    let plain = gltf_cube(d, &serde_json::json!({}));
    let out = bake_gltf(&plain, &d.join("plain.prt"), &[]);
    assert!(out.status.success());
    let inspect = Command::new(env!("CARGO_BIN_EXE_prt-bake"))
        .arg("inspect")
        .arg(d.join("plain.prt"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&inspect.stdout);
    assert!(text.contains("\"channels\": 1"), "{text}");
}

/// Hostile extension values are bad input (exit 3) naming the file and the material; a
/// glTF medium is refused with the bakes that cannot take one (exit 2); nothing is written.
#[test]
fn hostile_gltf_volumes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (colour, thickness, problem) in [
        (serde_json::json!([0.0, 0.8, 0.3]), 1.0, "attenuationColor"),
        (serde_json::json!([0.7, 0.8, 0.3]), -1.0, "thicknessFactor"),
        (serde_json::json!([0.7, -0.8, 0.3]), 1.0, "attenuationColor"),
    ] {
        let scene = gltf_cube(d, &jade_extensions(colour, thickness));
        let out = bake_gltf(&scene, &d.join("out.prt"), &[]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(3), "{stderr}");
        for needle in ["cube.gltf", "material 'jade'", problem] {
            assert!(stderr.contains(needle), "{needle}: {stderr}");
        }
        assert!(!d.join("out.prt").exists());
    }
    let scene = gltf_cube(d, &jade_extensions(serde_json::json!([0.7, 0.8, 0.3]), 1.0));
    for extra in [&["--shard", "0/2"][..], &["--mode", "unshadowed"][..]] {
        let out = bake_gltf(&scene, &d.join("out.prt"), extra);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{extra:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(!d.join("out.prt").exists());
    }
}
