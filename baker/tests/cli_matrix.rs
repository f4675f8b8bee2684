//! End-to-end tests of `prt-bake bake --transfer matrix` (docs/guides/glossy.md): the header's
//! transfer kind in `inspect`, the `transfer_matrix` array of `export --npz`, the commands
//! that refuse a matrix bake, and the options matrix bakes do not support.

mod common;

use std::io::Read;

use common::{EXIT_BAD_COMMAND_LINE, Scratch};

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);

/// The shape and data of array `name` of an npz export (little-endian float32).
fn npz_array(s: &Scratch, file: &str, name: &str) -> Option<(String, Vec<f32>)> {
    let zip_file = std::fs::File::open(s.path(file)).unwrap();
    let mut zip = zip::ZipArchive::new(zip_file).expect("a zip archive");
    let mut bytes = Vec::new();
    zip.by_name(&format!("{name}.npy"))
        .ok()?
        .read_to_end(&mut bytes)
        .unwrap();
    let header = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let text = String::from_utf8_lossy(&bytes[10..10 + header]).into_owned();
    let data = bytes[10 + header..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    Some((text, data))
}

/// `export --npz` of out/m.prt (a Cornell bake): its `transfer_matrix` array's header and values.
fn exported_matrices(s: &Scratch) -> (String, Vec<f32>) {
    s.run(&[
        "export",
        "out/m.prt",
        "--scene",
        CORNELL,
        "--npz",
        "out/m.npz",
    ])
    .success();
    npz_array(s, "out/m.npz", "transfer_matrix").expect("an array")
}

#[test]
fn a_matrix_bake_is_inspected_exported_and_refused_where_unsupported() {
    let s = Scratch::new();
    s.bake(CORNELL, "m.prt", &["--transfer", "matrix"]);
    s.bake(CORNELL, "v.prt", &[]);
    let inspect = |file: &str| -> serde_json::Value {
        serde_json::from_str(&s.run(&["inspect", file]).success().stdout).unwrap()
    };
    assert_eq!(inspect("out/m.prt")["transfer"], "matrix");
    // Vector files print what they always printed: no "transfer" key.
    assert!(inspect("out/v.prt").get("transfer").is_none());

    let (header, matrices) = exported_matrices(&s);
    assert!(header.contains("(2944, 1, 16, 16)"), "{header}");
    assert!(npz_array(&s, "out/m.npz", "transfer").is_none());
    // Symmetric, and M_00 = ∫ V y_0² within the hemisphere's 1/2.
    for m in matrices.chunks_exact(256) {
        assert!((0.0..=0.5 + 1e-6).contains(&m[0]), "{}", m[0]);
        for i in 0..16 {
            for j in 0..16 {
                assert_eq!(m[i * 16 + j], m[j * 16 + i]);
            }
        }
    }

    // glTF export takes a matrix bake only compressed (docs/reference/gltf.md, "Glossy transfer"), and
    // says how to compress it.
    let refusal = "an uncompressed transfer-matrix bake (256 floats per vertex";
    s.run(&[
        "export",
        "out/m.prt",
        "--scene",
        CORNELL,
        "--gltf",
        "out/m.glb",
    ])
    .fails_with_bad_input(&[refusal]);
    s.assert_out_holds(&["m.npz", "m.prt", "v.prt"]);
}

#[test]
fn an_interreflected_matrix_bake_has_a_matrix_per_channel() {
    // The Cornell room's red and green walls: three channels, each a full n² × n² matrix,
    // no longer symmetric (the bounced light is not), and the red wall's bounce tints it.
    let s = Scratch::new();
    s.bake(
        CORNELL,
        "m.prt",
        &[
            "--transfer",
            "matrix",
            "--mode",
            "interreflected",
            "--bounces",
            "2",
        ],
    );
    let inspect: serde_json::Value =
        serde_json::from_str(&s.run(&["inspect", "out/m.prt"]).success().stdout).unwrap();
    assert_eq!(inspect["transfer"], "matrix");
    assert_eq!(inspect["mode"], "interreflected");
    assert_eq!(inspect["bounces"], 2);
    assert_eq!(inspect["channels"], 3);
    let (header, matrices) = exported_matrices(&s);
    assert!(header.contains("(2944, 3, 16, 16)"), "{header}");
    let asymmetric = matrices
        .chunks_exact(256)
        .filter(|m| (0..16).any(|i| (0..16).any(|j| m[i * 16 + j] != m[j * 16 + i])))
        .count();
    assert!(asymmetric > 1000, "{asymmetric} asymmetric matrices");
    let tinted = matrices
        .chunks_exact(3 * 256)
        .filter(|rgb| rgb[0] != rgb[256] || rgb[256] != rgb[512])
        .count();
    assert!(tinted > 1000, "{tinted} vertices with coloured matrices");
    s.assert_out_holds(&["m.npz", "m.prt"]);
}

#[test]
fn unsupported_matrix_bakes_are_usage_errors() {
    let s = Scratch::new();
    let bake = |extra: &[&str]| {
        let mut args = vec![
            "bake",
            CORNELL,
            "-o",
            "out/x.prt",
            "--quiet",
            "--samples",
            "16",
        ];
        args.extend(extra);
        s.run(&args)
    };
    bake(&["--transfer", "matrix", "--lightmap", "32"]).fails_with(
        EXIT_BAD_COMMAND_LINE,
        &["--transfer matrix with --lightmap"],
    );
    bake(&["--transfer", "matrix", "--shard", "0/2"])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["--transfer matrix with --shard"]);
    bake(&["--transfer", "matrix", "--sampling", "thesis-random"])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["needs --sampling owen-sobol"]);
    s.assert_out_holds(&[]);
}
