//! A CPCA-compressed bake exported to glTF (`export --glb` of a `prt-bake compress` file):
//! the `.glb` carries the cluster index and weights per vertex and the clusters' means and
//! components in its buffer (docs/reference/gltf.md, "Compressed transfer"). Rebuilt from the file alone,
//! that transfer dotted with the file's own light must give its COLOR_0.

mod common;

use common::{EXIT_BAD_COMMAND_LINE, Scratch};
use serde_json::Value;

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);
const RIG: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../viewer/src/default-rig.toml"
);

/// A `.glb`'s JSON and binary chunk.
fn glb(bytes: &[u8]) -> (Value, Vec<u8>) {
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as usize;
    let json_len = u32_at(12);
    let json = serde_json::from_slice(&bytes[20..20 + json_len]).expect("the JSON chunk");
    let bin = bytes[20 + json_len + 8..].to_vec();
    (json, bin)
}

/// The floats of float accessor `index`.
fn floats(json: &Value, bin: &[u8], index: &Value) -> Vec<f32> {
    let accessor = &json["accessors"][index.as_u64().unwrap() as usize];
    assert_eq!(accessor["componentType"], 5126, "a float accessor");
    let view = &json["bufferViews"][accessor["bufferView"].as_u64().unwrap() as usize];
    let start = view["byteOffset"].as_u64().unwrap() as usize;
    let len = view["byteLength"].as_u64().unwrap() as usize;
    bin[start..start + len]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

#[test]
fn compressed_glb_rebuilds_its_colour_from_clusters_and_weights() {
    let s = Scratch::new();
    s.bake(
        CORNELL,
        "ir.prt",
        &["--mode", "interreflected", "--samples", "256"],
    );
    s.run(&[
        "compress",
        "out/ir.prt",
        "-o",
        "out/k.prt",
        "--clusters",
        "16",
        "--pcs",
        "6",
    ])
    .success();
    let export = |file: &str, glb: &str| {
        s.run(&[
            "export", file, "--scene", CORNELL, "--glb", glb, "--lights", RIG,
        ])
        .success()
    };
    let run = export("out/k.prt", "out/k.glb");
    assert!(
        run.stdout
            .contains("CPCA transfer (16 clusters, 6 components)"),
        "{}",
        run.stdout
    );
    export("out/ir.prt", "out/ir.glb");
    let (json, bin) = glb(&s.read("out/k.glb"));
    let prt = &json["asset"]["extras"]["prt"];
    let cpca = &prt["cpca"];
    let (k, m, d) = (
        cpca["clusters"].as_u64().unwrap() as usize,
        cpca["pcs"].as_u64().unwrap() as usize,
        cpca["dim"].as_u64().unwrap() as usize,
    );
    assert_eq!((k, m, d), (16, 6, 48));
    let means = floats(&json, &bin, &cpca["means"]);
    let bases = floats(&json, &bin, &cpca["bases"]);
    assert_eq!((means.len(), bases.len()), (k * d, k * m * d));
    let light: Vec<Vec<f64>> =
        serde_json::from_value(prt["light"]["coefficients"].clone()).unwrap();
    let mut checked = 0;
    let mut worst = 0.0f64;
    for mesh in json["meshes"].as_array().unwrap() {
        let attributes = &mesh["primitives"][0]["attributes"];
        // The transfer is two attributes, not twelve: room for TANGENT and TEXCOORD_1.
        let prt_attributes = attributes
            .as_object()
            .unwrap()
            .keys()
            .filter(|name| name.starts_with("_PRT"))
            .count();
        assert_eq!(
            prt_attributes, 3,
            "_PRT_CLUSTER, _PRT_W0 and _PRT_W1 (M = 6)"
        );
        let cluster = floats(&json, &bin, &attributes["_PRT_CLUSTER"]);
        let w = [
            floats(&json, &bin, &attributes["_PRT_W0"]),
            floats(&json, &bin, &attributes["_PRT_W1"]),
        ];
        let colour = floats(&json, &bin, &attributes["COLOR_0"]);
        for (v, &c) in cluster.iter().enumerate() {
            let c = c as usize;
            assert!(c < k);
            for channel in 0..3 {
                let mut t = 0.0f64;
                for j in 0..16 {
                    let mut x = f64::from(means[c * d + channel * 16 + j]);
                    for i in 0..m {
                        let weight = f64::from(w[i / 4][4 * v + i % 4]);
                        x += weight * f64::from(bases[(c * m + i) * d + channel * 16 + j]);
                    }
                    t += x * light[channel][j];
                }
                let error = (t.clamp(0.0, 1.0) - f64::from(colour[3 * v + channel])).abs();
                worst = worst.max(error);
                checked += 1;
            }
        }
    }
    assert!(checked > 3 * 2900, "{checked} values checked");
    assert!(
        worst < 1e-4,
        "rebuilt shading differs from COLOR_0 by {worst}"
    );
    // Far smaller than the float export of the same bake.
    let (compressed, float) = (s.read("out/k.glb").len(), s.read("out/ir.glb").len());
    assert!(compressed * 2 < float, "{compressed} bytes against {float}");
    // --quantize quantizes transfer, which a compressed export does not carry.
    s.run(&[
        "export",
        "out/k.prt",
        "--scene",
        CORNELL,
        "--glb",
        "out/q.glb",
        "--quantize",
        "8",
    ])
    .fails_with(EXIT_BAD_COMMAND_LINE, &["CPCA-compressed", "--quantize"]);
}

/// y_i(d), i < 4 (order 2), with the Condon–Shortley phase: the baker's basis.
fn sh_order2(d: [f64; 3]) -> [f64; 4] {
    let k0 = 0.5 * (1.0 / std::f64::consts::PI).sqrt();
    let k1 = (3.0 / (4.0 * std::f64::consts::PI)).sqrt();
    [k0, -k1 * d[1], k1 * d[2], -k1 * d[0]]
}

#[test]
fn a_compressed_matrix_glb_carries_turned_matrices_and_each_materials_lobe() {
    // The glossy torus (z-up) at order 2: its clusters' 4 × 4 matrices, turned to glTF's +Y up
    // as R·M·Rᵀ, rebuilt per vertex and lit by the file's own light (in its +Y-up frame) give
    // the diffuse term at the exported normal, which must be COLOR_0 (docs/reference/gltf.md, "Glossy
    // transfer"). Without the turn of the matrices, light and normals would disagree.
    let s = Scratch::new();
    let glossy = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/torus/glossy.scene");
    s.bake(
        glossy,
        "m.prt",
        &[
            "--transfer",
            "matrix",
            "--order",
            "2",
            "--samples",
            "64",
            "--clusters",
            "16",
            "--pcs",
            "4",
        ],
    );
    s.run(&[
        "export",
        "out/m.prt",
        "--scene",
        glossy,
        "--glb",
        "out/m.glb",
        "--lights",
        RIG,
    ])
    .success();
    let (json, bin) = glb(&s.read("out/m.glb"));
    let prt = &json["asset"]["extras"]["prt"];
    assert_eq!(prt["transfer"], "matrix");
    let cpca = &prt["cpca"];
    assert_eq!(cpca["transfer"], "matrix");
    let (k, m, d) = (
        cpca["clusters"].as_u64().unwrap() as usize,
        cpca["pcs"].as_u64().unwrap() as usize,
        cpca["dim"].as_u64().unwrap() as usize,
    );
    assert_eq!((k, m, d), (16, 4, 16), "grey 4 × 4 matrices");
    let diffuse_bands: Vec<f64> = serde_json::from_value(cpca["diffuse_bands"].clone()).unwrap();
    assert!((diffuse_bands[0] - 1.0).abs() < 1e-6 && (diffuse_bands[1] - 2.0 / 3.0).abs() < 1e-6);
    // The torus's material (MTL Ks 0.25, Ns 24) carries its lobe; the planes' do not.
    let lobes: Vec<&Value> = json["materials"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|m| m["extras"].get("prt_glossy"))
        .collect();
    assert_eq!(lobes.len(), 1, "{}", json["materials"]);
    assert_eq!(lobes[0]["exponent"], 24.0);
    assert_eq!(lobes[0]["ks"], serde_json::json!([0.25, 0.25, 0.25]));
    assert_eq!(lobes[0]["bands"].as_array().unwrap().len(), 2);

    let means = floats(&json, &bin, &cpca["means"]);
    let bases = floats(&json, &bin, &cpca["bases"]);
    let light: Vec<Vec<f64>> =
        serde_json::from_value(prt["light"]["coefficients"].clone()).unwrap();
    let mut worst = 0.0f64;
    let mut checked = 0;
    for mesh in json["meshes"].as_array().unwrap() {
        let attributes = &mesh["primitives"][0]["attributes"];
        let cluster = floats(&json, &bin, &attributes["_PRT_CLUSTER"]);
        let w = floats(&json, &bin, &attributes["_PRT_W0"]);
        let normals = floats(&json, &bin, &attributes["NORMAL"]);
        let colour = floats(&json, &bin, &attributes["COLOR_0"]);
        for (v, &c) in cluster.iter().enumerate() {
            let c = c as usize;
            let matrix: Vec<f64> = (0..16)
                .map(|e| {
                    let mut x = f64::from(means[c * d + e]);
                    for i in 0..m {
                        x += f64::from(w[4 * v + i]) * f64::from(bases[(c * m + i) * d + e]);
                    }
                    x
                })
                .collect();
            let n: Vec<f64> = normals[3 * v..3 * v + 3]
                .iter()
                .map(|&x| f64::from(x))
                .collect();
            let y = sh_order2([n[0], n[1], n[2]]);
            for channel in 0..3 {
                let mut shading = 0.0;
                for (i, yi) in y.iter().enumerate() {
                    let incident: f64 = (0..4).map(|j| matrix[i * 4 + j] * light[channel][j]).sum();
                    let band = if i == 0 { 0 } else { 1 };
                    shading += diffuse_bands[band] * incident * yi;
                }
                let error = (shading.clamp(0.0, 1.0) - f64::from(colour[3 * v + channel])).abs();
                worst = worst.max(error);
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 3 * 13_500);
    assert!(
        worst < 1e-4,
        "rebuilt diffuse shading differs from COLOR_0 by {worst}"
    );
}
