//! End-to-end tests of LDPRT (docs/guides/characters.md): `bake --transfer ldprt`, `inspect`'s
//! fit error, `relight` on the bent tube, bit-identical files for any thread count, and the
//! refusals: options that do not apply, another topology, a damaged file.

mod common;

use common::{EXIT_BAD_COMMAND_LINE, Scratch};

const TUBE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/tube/tube.obj");
const BENT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/tube/tube-bent.obj");
const CORNELL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/cornell/cornell.obj");
const RIG: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../viewer/src/default-rig.toml"
);

#[test]
fn an_ldprt_bake_inspects_and_relights_on_a_pose() {
    let s = Scratch::new();
    let run = s.bake(TUBE, "t.ldprt", &["--transfer", "ldprt", "--lobes", "2"]);
    assert!(run.stdout.contains("fitted 2 lobe(s)"), "{}", run.stdout);
    let inspect = s.run(&["inspect", "out/t.ldprt"]).success();
    let json: serde_json::Value = serde_json::from_str(&inspect.stdout).unwrap();
    assert_eq!(json["format"], "ldprt");
    assert_eq!(json["lobes"], 2);
    assert_eq!(json["vertex_count"], 2328);
    let mean = json["fit_error"]["mean"].as_f64().unwrap();
    let p99 = json["fit_error"]["p99"].as_f64().unwrap();
    assert!(mean > 0.0 && mean <= p99 && p99 < 0.2, "{mean} {p99}");

    let relit = s.run(&[
        "relight",
        BENT,
        "out/t.ldprt",
        "--lights",
        RIG,
        "-o",
        "out/bent.ply",
    ]);
    assert!(
        relit
            .success()
            .stdout
            .contains("relit 2328 vertices of an LDPRT bake")
    );

    s.bake(
        TUBE,
        "one.ldprt",
        &["--transfer", "ldprt", "--lobes", "2", "--threads", "1"],
    );
    assert_eq!(
        s.read("out/t.ldprt"),
        s.read("out/one.ldprt"),
        "thread count changed the file"
    );
}

/// A glTF `doubleSided` sheet (Blender's exporter marks materials so by default) baked with
/// `--double-sided off` has no back sheet in the file: `relight` and `export --glb` read the
/// mesh as the bake saw it, and with back sheets where the bake had them.
#[test]
fn a_double_sided_sheet_relights_as_it_was_baked() {
    const CARD: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/cutout/card.glb");
    let s = Scratch::new();
    for (name, sides) in [("off.ldprt", "off"), ("auto.ldprt", "auto")] {
        s.bake(
            CARD,
            name,
            &[
                "--transfer",
                "ldprt",
                "--lobes",
                "1",
                "--double-sided",
                sides,
            ],
        );
        let file = format!("out/{name}");
        let relit = s
            .run(&[
                "relight",
                CARD,
                &file,
                "--lights",
                RIG,
                "-o",
                "out/card.ply",
            ])
            .success();
        assert!(
            relit.stdout.contains("of an LDPRT bake"),
            "{}",
            relit.stdout
        );
        std::fs::remove_file(s.path("out/card.ply")).unwrap();
    }
    let off = s.read("out/off.ldprt").len();
    let auto = s.read("out/auto.ldprt").len();
    assert!(
        off < auto,
        "the back sheet is baked only by auto: {off} vs {auto} bytes"
    );
}

#[test]
fn ldprt_refusals() {
    let s = Scratch::new();
    for (extra, needle) in [
        (&["--lobes", "2"][..], "--lobes is for --transfer ldprt"),
        (
            &["--transfer", "ldprt", "--lobes", "9"][..],
            "outside 1..=8",
        ),
        (
            &["--transfer", "ldprt", "--lightmap", "16"][..],
            "per vertex",
        ),
        (
            &["--transfer", "ldprt", "--clusters", "4"][..],
            "not compressed",
        ),
    ] {
        let mut args = vec!["bake", TUBE, "-o", "out/x.ldprt", "--samples", "16"];
        args.extend(extra);
        s.run(&args).fails_with(EXIT_BAD_COMMAND_LINE, &[needle]);
    }
    s.assert_out_holds(&[]);

    s.bake(TUBE, "t.ldprt", &["--transfer", "ldprt", "--samples", "16"]);
    s.run(&[
        "relight",
        CORNELL,
        "out/t.ldprt",
        "--lights",
        RIG,
        "-o",
        "out/c.ply",
    ])
    .fails_with_bad_input(&["t.ldprt", "2328 vertices", "topology"]);
    let mut bytes = s.read("out/t.ldprt");
    bytes[200] ^= 0x40;
    s.write("damaged.ldprt", &bytes);
    s.run(&[
        "relight",
        BENT,
        "damaged.ldprt",
        "--lights",
        RIG,
        "-o",
        "out/d.ply",
    ])
    .fails_with_bad_input(&["damaged.ldprt", "checksum"]);
    s.run(&["inspect", "damaged.ldprt"])
        .fails_with_bad_input(&["checksum"]);
    s.assert_out_holds(&["t.ldprt"]);
}

/// `scenes/tube/tube-bent.obj` as a glTF 2.0 file (one node, positions and indices in a
/// data URI; no normals, so the reader computes them as the OBJ reader does). The vertices
/// are in the order the OBJ reader gives them (first use in the faces), the bake's order.
fn bent_gltf() -> String {
    let obj = prt_baker::Scene::load(std::path::Path::new(BENT)).unwrap();
    let positions: Vec<f32> = obj.positions.iter().flat_map(|p| p.to_array()).collect();
    let indices: Vec<u32> = obj.triangles.iter().flatten().copied().collect();
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for p in positions.chunks_exact(3) {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let mut bytes: Vec<u8> = positions.iter().flat_map(|x| x.to_le_bytes()).collect();
    let position_bytes = bytes.len();
    bytes.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "tube", "mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": positions.len() / 3,
             "type": "VEC3", "min": lo, "max": hi},
            {"bufferView": 1, "componentType": 5125, "count": indices.len(), "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": position_bytes},
            {"buffer": 0, "byteOffset": position_bytes, "byteLength": bytes.len() - position_bytes}
        ],
        "buffers": [{"byteLength": bytes.len(),
                     "uri": format!("data:application/octet-stream;base64,{}", common::base64(&bytes))}]
    })
    .to_string()
}

#[test]
fn a_posed_gltf_relights_as_the_posed_obj() {
    let s = Scratch::new();
    s.bake(TUBE, "t.ldprt", &["--transfer", "ldprt", "--lobes", "2"]);
    s.write("bent.gltf", bent_gltf());
    let largest = |run: common::Run| {
        let at = run.stdout.find("largest radiance").expect("a summary line");
        run.stdout[at..]
            .split_whitespace()
            .nth(2)
            .unwrap()
            .to_string()
    };
    let gltf = s.run(&[
        "relight",
        "bent.gltf",
        "out/t.ldprt",
        "--lights",
        RIG,
        "-o",
        "out/g.ply",
    ]);
    let obj = s.run(&[
        "relight",
        BENT,
        "out/t.ldprt",
        "--lights",
        RIG,
        "-o",
        "out/o.ply",
    ]);
    assert_eq!(largest(gltf.success()), largest(obj.success()));
}

const SKINNED: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/tube/tube-skinned.glb"
);

/// A skinned glTF from the command line: a bake in a named pose records it, `relight
/// --pose` lights the lobes on another pose, and poses that are not there are refused.
#[test]
fn skinned_gltf_bakes_and_relights_in_named_poses() {
    let s = Scratch::new();
    let ldprt = ["--transfer", "ldprt", "--samples", "32"];
    s.bake(SKINNED, "rest.ldprt", &ldprt);
    let inspect = s.run(&["inspect", "out/rest.ldprt"]).success();
    assert!(
        inspect.stdout.contains("\"pose\": \"rest\""),
        "{}",
        inspect.stdout
    );
    let mut posed = ldprt.to_vec();
    posed.extend(["--pose", "bend#1"]);
    s.bake(SKINNED, "half.ldprt", &posed);
    let inspect = s.run(&["inspect", "out/half.ldprt"]).success();
    assert!(
        inspect.stdout.contains("\"pose\": \"bend#1\""),
        "{}",
        inspect.stdout
    );
    let relit = s
        .run(&[
            "relight",
            SKINNED,
            "out/rest.ldprt",
            "--pose",
            "bend@1",
            "--lights",
            RIG,
            "-o",
            "out/b.ply",
        ])
        .success();
    assert!(relit.stdout.contains("(bend@1)"), "{}", relit.stdout);
    s.run(&[
        "relight",
        SKINNED,
        "out/rest.ldprt",
        "--pose",
        "walk@1",
        "--lights",
        RIG,
        "-o",
        "out/w.ply",
    ])
    .fails_with_bad_input(&["tube-skinned.glb", "no animation 'walk'"]);
    s.run(&[
        "relight",
        SKINNED,
        "out/rest.ldprt",
        "--pose",
        "bend",
        "--lights",
        RIG,
        "-o",
        "out/w.ply",
    ])
    .fails_with(EXIT_BAD_COMMAND_LINE, &["ANIM@SECONDS"]);
    s.run(&[
        "bake",
        TUBE,
        "-o",
        "out/x.ldprt",
        "--pose",
        "bend@1",
        "--samples",
        "16",
    ])
    .fails_with_bad_input(&["tube.obj", "only glTF files have skins"]);
    s.assert_out_holds(&["b.ply", "half.ldprt", "rest.ldprt"]);
}
