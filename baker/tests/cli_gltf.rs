//! glTF in and out, and the up axis, end to end through the `prt-bake` binary:
//! * a glTF whose node hierarchy (rotation, non-uniform scale, a mirror, translation) places
//!   its meshes bakes to the transfer of the same world geometry given as OBJ;
//! * the y-up glTF that `export --gltf` makes of a z-up OBJ bakes and relights, under the same
//!   rig, to the OBJ's radiance (rigs are relative to the scene's up axis), and its `_PRT_k`
//!   attributes are the OBJ bake's transfer turned to y-up;
//! * the errors and warnings a user meets (unknown format, required extension, points, an
//!   edited file), and the npz's `triangles` and `uv`.

mod common;

use std::path::Path;

use common::*;
use glam::{Mat3, Mat4, Quat, Vec3};
use prt_baker::light::Rig;
use prt_baker::scene::Up;
use prt_baker::{CoefficientFile, Scene};
use serde_json::{Value, json};

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);

/// A sun and a sky: directional detail the up axis must turn, and a hemisphere whose zenith
/// must be the scene's up.
const RIG: &str = r#"
[[light]]
kind = "sun"
theta = 40
phi = 30
color = [1.0, 0.9, 0.8]
intensity = 3.0

[[light]]
kind = "hemisphere"
color = [0.2, 0.25, 0.35]
ground_color = [0.05, 0.04, 0.03]
"#;

/// A parsed `.glb`: its JSON and binary chunk.
struct Glb {
    json: Value,
    bin: Vec<u8>,
}

impl Glb {
    fn parse(bytes: &[u8]) -> Glb {
        assert_eq!(&bytes[..4], b"glTF");
        assert_eq!(u32::from_le_bytes(bytes[4..8].try_into().unwrap()), 2);
        assert_eq!(
            u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
            bytes.len()
        );
        let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        assert_eq!(&bytes[16..20], b"JSON");
        let json = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
        let bin_at = 20 + json_len;
        assert_eq!(&bytes[bin_at + 4..bin_at + 8], b"BIN\0");
        Glb {
            json,
            bin: bytes[bin_at + 8..].to_vec(),
        }
    }

    /// The floats of a (tightly packed) float accessor.
    fn floats(&self, accessor: &Value) -> Vec<f32> {
        let index = accessor.as_u64().unwrap() as usize;
        let accessor = &self.json["accessors"][index];
        assert_eq!(accessor["componentType"], 5126);
        let view = &self.json["bufferViews"][accessor["bufferView"].as_u64().unwrap() as usize];
        let start = view["byteOffset"].as_u64().unwrap_or(0) as usize
            + accessor["byteOffset"].as_u64().unwrap_or(0) as usize;
        let components = match accessor["type"].as_str().unwrap() {
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            other => panic!("unexpected accessor type {other}"),
        };
        let count = accessor["count"].as_u64().unwrap() as usize * components;
        (0..count)
            .map(|i| {
                let at = start + 4 * i;
                f32::from_le_bytes(self.bin[at..at + 4].try_into().unwrap())
            })
            .collect()
    }

    /// An attribute over all meshes (one primitive each), concatenated in mesh order.
    fn attribute(&self, name: &str) -> Vec<f32> {
        self.json["meshes"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|mesh| self.floats(&mesh["primitives"][0]["attributes"][name]))
            .collect()
    }
}

/// The mean of |a − b| over every channel of every vertex, relative to the mean of |a|.
fn relative_mean_difference(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    assert_eq!(a.len(), b.len());
    let (mut diff, mut size) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        for c in 0..3 {
            diff += f64::from((x[c] - y[c]).abs());
            size += f64::from(x[c].abs());
        }
    }
    diff / size
}

#[test]
fn y_up_gltf_export_of_a_z_up_obj_bakes_and_relights_the_same() {
    let s = Scratch::new();
    s.write("rig.toml", RIG);
    s.bake(CORNELL, "z.prt", &["--samples", "512", "--seed", "3"]);
    let export = s
        .run(&[
            "export",
            "out/z.prt",
            "--scene",
            CORNELL,
            "--gltf",
            "out/cornell.glb",
        ])
        .success();
    assert!(
        export.stdout.starts_with("wrote out/cornell.glb (")
            && export
                .stdout
                .contains("transfer in 4 VEC4 attributes _PRT_0.._PRT_3")
            && export.stdout.contains("turned from z-up to glTF's y-up"),
        "{}",
        export.stdout
    );

    // The glTF holds the OBJ's vertices, in order, turned by (x, y, z) -> (x, z, -y).
    let obj = Scene::load(Path::new(CORNELL)).unwrap();
    let gltf = Scene::load(&s.path("out/cornell.glb")).unwrap();
    assert_eq!(gltf.up, Up::Y);
    assert_eq!(gltf.vertex_count(), obj.vertex_count());
    assert_eq!(gltf.triangles, obj.triangles);
    for (p, q) in obj.positions.iter().zip(&gltf.positions) {
        assert!(
            (Vec3::new(p.x, p.z, -p.y) - *q).length() < 1e-6,
            "{p} -> {q}"
        );
    }
    for (n, m) in obj.normals.iter().zip(&gltf.normals) {
        assert!(
            (Vec3::new(n.x, n.z, -n.y) - *m).length() < 1e-5,
            "{n} -> {m}"
        );
    }

    // The _PRT attributes are the OBJ bake's transfer turned to y-up: lit by the rig turned
    // to y-up they give what the OBJ's transfer gives under the rig, to rounding.
    let z_file = CoefficientFile::read(&s.path("out/z.prt")).unwrap();
    let glb = Glb::parse(&s.read("out/cornell.glb"));
    let light_z = Rig::load(&s.path("rig.toml")).unwrap().project(4);
    let light_y = light_z.in_scene_frame(Up::Y);
    let prt: Vec<Vec<f32>> = (0..4)
        .map(|k| glb.attribute(&format!("_PRT_{k}")))
        .collect();
    for v in 0..obj.vertex_count() {
        let from_gltf: f64 = (0..16)
            .map(|j| f64::from(prt[j / 4][4 * v + j % 4]) * light_y.rgb[0][j])
            .sum();
        let from_obj: f64 = z_file
            .vertex(v, 0)
            .iter()
            .zip(&light_z.rgb[0])
            .map(|(t, l)| f64::from(*t) * l)
            .sum();
        assert!(
            (from_gltf - from_obj).abs() < 1e-4 * (1.0 + from_obj.abs()),
            "vertex {v}: {from_gltf} from the glTF, {from_obj} from the OBJ"
        );
    }

    // Baked again from the glTF (y-up by default) and relit by the same rig: the OBJ's
    // radiance, up to the bakes' noise (the rays differ: each vertex's sample frame turns).
    s.bake(
        "out/cornell.glb",
        "y.prt",
        &["--samples", "512", "--seed", "3"],
    );
    let inspect = |file: &str| -> Value {
        serde_json::from_str(&s.run(&["inspect", file]).success().stdout).unwrap()
    };
    assert_eq!(inspect("out/z.prt")["up"], "z");
    assert_eq!(inspect("out/y.prt")["up"], "y");
    for (scene, file, out) in [
        (CORNELL, "out/z.prt", "out/z.ply"),
        ("out/cornell.glb", "out/y.prt", "out/y.ply"),
    ] {
        s.run(&["relight", scene, file, "--lights", "rig.toml", "-o", out])
            .success();
    }
    let z = s.ply_radiance("out/z.ply");
    let y = s.ply_radiance("out/y.ply");
    let difference = relative_mean_difference(&z, &y);
    eprintln!("z-up OBJ vs y-up glTF: relit radiance differs by {difference:.5} (relative mean)");
    assert!(
        difference < 0.03,
        "relit radiance differs by {:.2} % on average between the z-up OBJ and the y-up glTF",
        100.0 * difference
    );

    // The same glTF baked as if it were z-up is lit from the side: the test can tell.
    s.bake(
        "out/cornell.glb",
        "wrong.prt",
        &["--samples", "512", "--seed", "3", "--up", "z"],
    );
    s.run(&[
        "relight",
        "out/cornell.glb",
        "out/wrong.prt",
        "--lights",
        "rig.toml",
        "-o",
        "out/wrong.ply",
    ])
    .success();
    let wrong = relative_mean_difference(&z, &s.ply_radiance("out/wrong.ply"));
    eprintln!("with the wrong up axis: {wrong:.5}");
    assert!(
        wrong > 0.1,
        "a wrong up axis changed the radiance by only {wrong}"
    );
}

/// A 4 × 4-cell floor over [−1, 1]² at z = 0 (normal +z) and a cube of 8 shared corners above
/// it: the world geometry of the hierarchy test.
/// Positions and triangles.
type Part = (Vec<Vec3>, Vec<[u32; 3]>);

fn floor_and_cube() -> (Part, Part) {
    let mut floor = Vec::new();
    let cells = 4;
    for j in 0..=cells {
        for i in 0..=cells {
            floor.push(Vec3::new(
                -1.0 + 2.0 * i as f32 / cells as f32,
                -1.0 + 2.0 * j as f32 / cells as f32,
                0.0,
            ));
        }
    }
    let mut floor_triangles = Vec::new();
    for j in 0..cells {
        for i in 0..cells {
            let a = j * (cells + 1) + i;
            let (b, c, d) = (a + 1, a + cells + 2, a + cells + 1);
            floor_triangles.push([a, b, c]);
            floor_triangles.push([a, c, d]);
        }
    }
    let cube: Vec<Vec3> = (0..8)
        .map(|k| {
            Vec3::new(
                if k & 1 == 0 { -0.3 } else { 0.3 },
                if k & 2 == 0 { -0.3 } else { 0.3 },
                if k & 4 == 0 { 0.2 } else { 0.8 },
            )
        })
        .collect();
    // Outward-facing: bottom, top, −y, +y, −x, +x.
    let cube_triangles = vec![
        [0, 2, 3],
        [0, 3, 1],
        [4, 5, 7],
        [4, 7, 6],
        [0, 1, 5],
        [0, 5, 4],
        [2, 6, 7],
        [2, 7, 3],
        [0, 4, 6],
        [0, 6, 2],
        [1, 3, 7],
        [1, 7, 5],
    ];
    ((floor, floor_triangles), (cube, cube_triangles))
}

/// One OBJ object: name, positions, triangles, one normal for all its vertices (or none).
struct ObjObject<'a>(&'a str, &'a [Vec3], &'a [[u32; 3]], Option<Vec3>);

fn obj_text(objects: &[ObjObject<'_>]) -> String {
    let mut text = String::new();
    let mut base = 1;
    for ObjObject(name, positions, triangles, normal) in objects {
        text += &format!("o {name}\n");
        for p in *positions {
            text += &format!("v {} {} {}\n", p.x, p.y, p.z);
        }
        if let Some(n) = normal {
            text += &format!("vn {} {} {}\n", n.x, n.y, n.z);
        }
        for t in *triangles {
            let [a, b, c] = t.map(|i| i + base);
            text += &match normal {
                Some(_) => format!("f {a}//{b0} {b}//{b0} {c}//{b0}\n", b0 = 1),
                None => format!("f {a} {b} {c}\n"),
            };
        }
        base += positions.len() as u32;
    }
    text
}

/// Little-endian bytes of floats or indices.
fn le<T: Copy, const N: usize>(values: &[T], bytes: impl Fn(T) -> [u8; N]) -> Vec<u8> {
    values.iter().flat_map(|v| bytes(*v)).collect()
}

/// A glTF document of meshes given in their nodes' local frames, and its binary buffer.
struct GltfBuilder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
}

impl GltfBuilder {
    fn new() -> GltfBuilder {
        GltfBuilder {
            bin: Vec::new(),
            views: Vec::new(),
            accessors: Vec::new(),
            meshes: Vec::new(),
        }
    }

    fn accessor(&mut self, bytes: Vec<u8>, component: u32, count: usize, kind: &str) -> usize {
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()}));
        self.bin.extend(bytes);
        self.accessors.push(json!({
            "bufferView": self.views.len() - 1, "componentType": component,
            "count": count, "type": kind,
        }));
        self.accessors.len() - 1
    }

    /// A mesh of one primitive; `mode` 4 = triangles, 0 = points.
    fn mesh(
        &mut self,
        name: &str,
        positions: &[Vec3],
        normals: Option<&[Vec3]>,
        indices: &[u32],
        mode: u32,
    ) {
        let flat: Vec<f32> = positions.iter().flat_map(|p| p.to_array()).collect();
        let position = self.accessor(le(&flat, f32::to_le_bytes), 5126, positions.len(), "VEC3");
        let (lo, hi) = positions
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(*p), hi.max(*p))
            });
        self.accessors[position]["min"] = json!(lo.to_array());
        self.accessors[position]["max"] = json!(hi.to_array());
        let mut attributes = json!({"POSITION": position});
        if let Some(normals) = normals {
            let flat: Vec<f32> = normals.iter().flat_map(|p| p.to_array()).collect();
            attributes["NORMAL"] =
                json!(self.accessor(le(&flat, f32::to_le_bytes), 5126, normals.len(), "VEC3"));
        }
        let indices = self.accessor(le(indices, u32::to_le_bytes), 5125, indices.len(), "SCALAR");
        self.meshes.push(json!({"name": name, "primitives": [{"attributes": attributes, "indices": indices, "mode": mode, "material": 0}]}));
    }

    fn document(&self, nodes: Value, buffer_uri: Option<String>) -> Value {
        let mut buffer = json!({"byteLength": self.bin.len()});
        if let Some(uri) = buffer_uri {
            buffer["uri"] = json!(uri);
        }
        json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": nodes,
            "meshes": self.meshes,
            "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.6, 0.7, 1.0]}}],
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [buffer],
        })
    }
}

fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut text = serde_json::to_vec(json).unwrap();
    while text.len() % 4 != 0 {
        text.push(b' ');
    }
    let mut bin = bin.to_vec();
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let mut bytes = b"glTF".to_vec();
    bytes.extend(2u32.to_le_bytes());
    bytes.extend(((12 + 8 + text.len() + 8 + bin.len()) as u32).to_le_bytes());
    bytes.extend((text.len() as u32).to_le_bytes());
    bytes.extend(b"JSON");
    bytes.extend(text);
    bytes.extend((bin.len() as u32).to_le_bytes());
    bytes.extend(b"BIN\0");
    bytes.extend(bin);
    bytes
}

#[test]
fn gltf_node_hierarchy_bakes_like_the_same_world_geometry_as_obj() {
    let s = Scratch::new();
    let ((floor, floor_triangles), (cube, cube_triangles)) = floor_and_cube();
    s.write(
        "world.obj",
        obj_text(&[
            ObjObject("floor", &floor, &floor_triangles, Some(Vec3::Z)),
            ObjObject("cube", &cube, &cube_triangles, None),
        ]),
    );

    // Root: translation, rotation and non-uniform scale as TRS. Child: a matrix with a mirror
    // (negative determinant), a turn and an offset.
    let root_t = Vec3::new(0.3, -0.2, 0.1);
    let root_r = Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
    let root_s = Vec3::new(1.5, 0.7, 1.2);
    let root = Mat4::from_scale_rotation_translation(root_s, root_r, root_t);
    let child = Mat4::from_translation(Vec3::new(0.1, 0.2, 0.3))
        * Mat4::from_rotation_z(0.4)
        * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    let cube_world = root * child;
    assert!(Mat3::from_mat4(cube_world).determinant() < 0.0);
    let local = |m: Mat4, points: &[Vec3]| -> Vec<Vec3> {
        let inverse = m.inverse();
        points
            .iter()
            .map(|p| inverse.transform_point3(*p))
            .collect()
    };
    let floor_local = local(root, &floor);
    let floor_normal_local = (Mat3::from_mat4(root).transpose() * Vec3::Z).normalize();
    let cube_local = local(cube_world, &cube);
    // Authored in the mirrored frame, the cube's faces wind the other way round.
    let cube_local_triangles: Vec<u32> = cube_triangles
        .iter()
        .flat_map(|[a, b, c]| [*a, *c, *b])
        .collect();
    let floor_indices: Vec<u32> = floor_triangles.iter().flatten().copied().collect();

    let mut b = GltfBuilder::new();
    b.mesh(
        "floor",
        &floor_local,
        Some(&vec![floor_normal_local; floor.len()]),
        &floor_indices,
        4,
    );
    b.mesh("cube", &cube_local, None, &cube_local_triangles, 4);
    let nodes = json!([
        {"name": "root", "mesh": 0, "children": [1],
         "translation": root_t.to_array(), "rotation": root_r.to_array(), "scale": root_s.to_array()},
        {"name": "child", "mesh": 1, "matrix": child.to_cols_array()},
    ]);
    // The same document three ways: external buffer, data URI, GLB.
    s.write("geometry.bin", &b.bin);
    s.write(
        "external.gltf",
        serde_json::to_vec(&b.document(nodes.clone(), Some("geometry.bin".into()))).unwrap(),
    );
    let data_uri = format!("data:application/octet-stream;base64,{}", base64(&b.bin));
    s.write(
        "embedded.gltf",
        serde_json::to_vec(&b.document(nodes.clone(), Some(data_uri))).unwrap(),
    );
    s.write("binary.glb", glb(&b.document(nodes, None), &b.bin));

    let obj = Scene::load(&s.path("world.obj")).unwrap();
    for name in ["external.gltf", "embedded.gltf", "binary.glb"] {
        let gltf = Scene::load(&s.path(name)).unwrap();
        assert_eq!(gltf.vertex_count(), obj.vertex_count(), "{name}");
        assert_eq!(gltf.triangles.len(), obj.triangles.len(), "{name}");
        assert_eq!(gltf.materials[0].kd, Vec3::new(0.5, 0.6, 0.7));
        // The OBJ reader orders a mesh's vertices as its faces first use them; match by
        // position. Positions agree to rounding; normals too, computed ones included (a
        // missed mirror would turn the cube's inside out).
        for (p, n) in obj.positions.iter().zip(&obj.normals) {
            let v = (0..gltf.vertex_count())
                .min_by(|&i, &j| {
                    (gltf.positions[i] - *p)
                        .length()
                        .total_cmp(&(gltf.positions[j] - *p).length())
                })
                .unwrap();
            assert!(
                (gltf.positions[v] - *p).length() < 1e-5,
                "{name}: {p} vs {}",
                gltf.positions[v]
            );
            assert!(
                (gltf.normals[v] - *n).length() < 1e-4,
                "{name}: normal at {p}: {n} vs {}",
                gltf.normals[v]
            );
        }
    }

    // The bakes agree vertex by vertex (same world geometry; rounding moves a few rays).
    s.bake("world.obj", "obj.prt", &["--samples", "256", "--aux", "ao"]);
    s.bake(
        "binary.glb",
        "gltf.prt",
        &["--samples", "256", "--aux", "ao"],
    );
    let obj_file = CoefficientFile::read(&s.path("out/obj.prt")).unwrap();
    let gltf_file = CoefficientFile::read(&s.path("out/gltf.prt")).unwrap();
    let gltf = Scene::load(&s.path("binary.glb")).unwrap();
    let (mut worst, mut sum) = (0.0f32, 0.0f32);
    for (i, p) in obj.positions.iter().enumerate() {
        let v = (0..gltf.vertex_count())
            .min_by(|&a, &b| {
                (gltf.positions[a] - *p)
                    .length()
                    .total_cmp(&(gltf.positions[b] - *p).length())
            })
            .unwrap();
        let a = obj_file.vertex(i, 0);
        let b = gltf_file.vertex(v, 0);
        for (x, y) in a.iter().zip(b) {
            worst = worst.max((x - y).abs());
            sum += (x - y).abs();
        }
        let (ao_obj, ao_gltf) = (
            obj_file.ao.as_ref().unwrap()[i],
            gltf_file.ao.as_ref().unwrap()[v],
        );
        assert!(
            (ao_obj - ao_gltf).abs() < 0.02,
            "AO at {p}: {ao_obj} vs {ao_gltf}"
        );
    }
    let mean = sum / (obj.vertex_count() * 16) as f32;
    eprintln!(
        "hierarchy glTF vs world OBJ: transfer differs by {mean:.2e} mean, {worst:.2e} worst"
    );
    assert!(
        mean < 4e-3 && worst < 0.08,
        "transfer differs: mean {mean}, worst {worst}"
    );
}

#[test]
fn gltf_errors_and_warnings_name_the_file_and_the_problem() {
    let s = Scratch::new();
    s.write("mesh.ply", "ply\nformat ascii 1.0\nend_header\n");
    s.run(&["bake", "mesh.ply", "-o", "out/x.prt"])
        .fails_with_bad_input(&[
            "mesh.ply: unknown scene format .ply",
            "Wavefront OBJ (.obj), glTF 2.0 (.gltf, .glb)",
        ]);

    let ((floor, floor_triangles), _) = floor_and_cube();
    let indices: Vec<u32> = floor_triangles.iter().flatten().copied().collect();
    let mut b = GltfBuilder::new();
    b.mesh("floor", &floor, None, &indices, 4);
    b.mesh("dots", &floor, None, &[0, 1, 2], 0);
    let nodes = json!([{"mesh": 0, "children": [1]}, {"mesh": 1}]);
    let mut document = b.document(nodes, None);
    s.write("points.glb", glb(&document, &b.bin));
    let run = s.bake("points.glb", "points.prt", &[]);
    assert!(
        run.stderr
            .contains("warning: points.glb: mesh 'dots': skipped a primitive of Points"),
        "{}",
        run.stderr
    );

    document["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
    document["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
    s.write("draco.glb", glb(&document, &b.bin));
    s.run(&["bake", "draco.glb", "-o", "out/x.prt"])
        .fails_with_bad_input(&["draco.glb: requires glTF extension KHR_draco_mesh_compression"]);

    // An edited file (a material's colour: the geometry is the same) is another scene.
    let mut edited = b.document(json!([{"mesh": 0}]), None);
    s.write("scene.glb", glb(&edited, &b.bin));
    s.bake("scene.glb", "scene.prt", &[]);
    edited["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.9, 0.6, 0.7, 1.0]);
    s.write("scene.glb", glb(&edited, &b.bin));
    s.run(&[
        "export",
        "out/scene.prt",
        "--scene",
        "scene.glb",
        "--npz",
        "out/x.npz",
    ])
    .fails_with_bad_input(&["out/scene.prt: baked for another scene: fingerprint"]);
    s.assert_out_holds(&["points.prt", "scene.prt"]);
}

/// The names and raw payloads of an `.npz`'s arrays with their dtype and shape.
fn npz_arrays(path: &Path) -> std::collections::BTreeMap<String, (String, Vec<usize>, Vec<u8>)> {
    use std::io::Read;
    let mut archive = zip::ZipArchive::new(std::fs::File::open(path).unwrap()).unwrap();
    let mut arrays = std::collections::BTreeMap::new();
    for i in 0..archive.len() {
        let mut entry = archive.by_index(i).unwrap();
        let name = entry.name().unwrap().trim_end_matches(".npy").to_string();
        let mut bytes = Vec::new();
        entry.read_to_end(&mut bytes).unwrap();
        let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        let header = std::str::from_utf8(&bytes[10..10 + header_len]).unwrap();
        let descr = header.split('\'').nth(3).unwrap().to_string();
        let shape_text = header.split('(').nth(1).unwrap().split(')').next().unwrap();
        let shape = shape_text
            .split(',')
            .filter_map(|d| d.trim().parse().ok())
            .collect();
        arrays.insert(name, (descr, shape, bytes[10 + header_len..].to_vec()));
    }
    arrays
}

#[test]
fn npz_export_holds_triangles_and_uvs_and_says_what_it_wrote() {
    let s = Scratch::new();
    let torus = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/torus/torus.scene");
    s.bake(
        torus,
        "torus.prt",
        &["--mode", "unshadowed", "--order", "3"],
    );
    let run = s
        .run(&[
            "export",
            "out/torus.prt",
            "--scene",
            torus,
            "--npz",
            "out/torus.npz",
        ])
        .success();
    assert_eq!(
        run.stdout,
        "wrote out/torus.npz (NumPy arrays of out/torus.prt)\n"
    );
    let scene = Scene::load(Path::new(torus)).unwrap();
    let arrays = npz_arrays(&s.path("out/torus.npz"));
    let (descr, shape, bytes) = &arrays["triangles"];
    assert_eq!(
        (descr.as_str(), shape.as_slice()),
        ("<u4", &[scene.triangles.len(), 3][..])
    );
    let expected: Vec<u8> = scene
        .triangles
        .iter()
        .flatten()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    assert_eq!(bytes, &expected);
    let (descr, shape, bytes) = &arrays["uv"];
    assert_eq!(
        (descr.as_str(), shape.as_slice()),
        ("<f4", &[scene.vertex_count(), 2][..])
    );
    let expected: Vec<u8> = scene
        .uvs
        .iter()
        .flat_map(|uv| uv.to_array())
        .flat_map(f32::to_le_bytes)
        .collect();
    assert_eq!(bytes, &expected);
}

#[test]
fn exported_glb_keeps_materials_textures_and_uvs() {
    let s = Scratch::new();
    let torus = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/torus/torus.scene");
    s.bake(torus, "t.prt", &["--mode", "unshadowed", "--order", "1"]);
    s.run(&[
        "export",
        "out/t.prt",
        "--scene",
        torus,
        "--gltf",
        "out/t.glb",
    ])
    .success();
    let obj = Scene::load(Path::new(torus)).unwrap();
    let gltf = Scene::load(&s.path("out/t.glb")).unwrap();
    assert_eq!(gltf.textures.len(), obj.textures.len());
    for (a, b) in obj.textures.iter().zip(&gltf.textures) {
        assert_eq!((a.width, a.height), (b.width, b.height));
        assert!(
            a.srgb8 == b.srgb8,
            "texture pixels changed on the way through PNG"
        );
    }
    for (a, b) in obj.uvs.iter().zip(&gltf.uvs) {
        assert!((*a - *b).length() < 1e-6, "uv {a} became {b}");
    }
    let (a, b) = (obj.vertex_albedo(), gltf.vertex_albedo());
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0, f32::max);
    assert!(worst < 1e-3, "albedo differs by up to {worst}");
    // Order 1: one coefficient, padded to one VEC4 with zeros.
    let glb = Glb::parse(&s.read("out/t.glb"));
    let prt = glb.attribute("_PRT_0");
    assert_eq!(prt.len(), 4 * obj.vertex_count());
    assert!(
        prt.chunks_exact(4)
            .all(|c| c[1] == 0.0 && c[2] == 0.0 && c[3] == 0.0)
    );
}

#[test]
fn both_texture_coordinate_sets_are_read_and_exported() {
    let s = Scratch::new();
    let ((floor, floor_triangles), _) = floor_and_cube();
    let indices: Vec<u32> = floor_triangles.iter().flatten().copied().collect();
    let mut b = GltfBuilder::new();
    b.mesh("floor", &floor, None, &indices, 4);
    // TEXCOORD_0 = (x, y) and TEXCOORD_1 = (y, x) / 2 in glTF's top-down convention.
    let uv0: Vec<f32> = floor.iter().flat_map(|p| [p.x, p.y]).collect();
    let uv1: Vec<f32> = floor.iter().flat_map(|p| [p.y / 2.0, p.x / 2.0]).collect();
    for (set, uv) in [("TEXCOORD_0", uv0), ("TEXCOORD_1", uv1)] {
        let accessor = b.accessor(le(&uv, f32::to_le_bytes), 5126, floor.len(), "VEC2");
        b.meshes[0]["primitives"][0]["attributes"][set] = json!(accessor);
    }
    s.write(
        "uv.glb",
        glb(&b.document(json!([{"mesh": 0}]), None), &b.bin),
    );
    let scene = Scene::load(&s.path("uv.glb")).unwrap();
    let lightmap = scene.lightmap_uvs.as_ref().expect("TEXCOORD_1 is kept");
    for (v, p) in floor.iter().enumerate() {
        // Stored with v up from the image's bottom, as OBJ's.
        assert_eq!(scene.uvs[v], glam::Vec2::new(p.x, 1.0 - p.y));
        assert_eq!(lightmap[v], glam::Vec2::new(p.y / 2.0, 1.0 - p.x / 2.0));
    }
    s.bake("uv.glb", "uv.prt", &["--mode", "unshadowed"]);
    s.run(&[
        "export",
        "out/uv.prt",
        "--scene",
        "uv.glb",
        "--gltf",
        "out/uv-prt.glb",
    ])
    .success();
    let exported = Glb::parse(&s.read("out/uv-prt.glb"));
    let expected: Vec<f32> = floor.iter().flat_map(|p| [p.y / 2.0, p.x / 2.0]).collect();
    assert_eq!(exported.attribute("TEXCOORD_1"), expected);

    // A texel bake uses TEXCOORD_1 as its atlas; --texel-size asks for an unwrap instead.
    for (extra, atlas) in [
        (&[][..], "\"atlas\": \"scene-uvs\""),
        (&["--texel-size", "0.5"][..], "\"atlas\": \"generated\""),
    ] {
        let mut args = vec!["--mode", "unshadowed", "--lightmap", "16"];
        args.extend_from_slice(extra);
        s.bake("uv.glb", "uv-texels.prt", &args);
        let inspect = s.run(&["inspect", "out/uv-texels.prt"]).success();
        assert!(inspect.stdout.contains(atlas), "{}", inspect.stdout);
    }
}

/// A glTF image whose header declares more pixels than `--max-memory` allows is refused
/// before it is decoded, naming the file and the image: embedded, in a `data:` URI, or beside
/// the file (its uri percent-encoded); the same file bakes under the default limit.
#[test]
fn gltf_images_are_checked_against_the_memory_limit() {
    let s = Scratch::new();
    // 4096² grey pixels: a small PNG that decodes to 16 M pixels (256 MiB at 16 bytes each).
    let mut png = Vec::new();
    image::GrayImage::new(4096, 4096)
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let ((floor, floor_triangles), _) = floor_and_cube();
    let indices: Vec<u32> = floor_triangles.iter().flatten().copied().collect();
    let mut b = GltfBuilder::new();
    b.mesh("floor", &floor, None, &indices, 4);
    let uvs: Vec<f32> = floor.iter().flat_map(|p| [p.x, p.y]).collect();
    let uv = b.accessor(le(&uvs, f32::to_le_bytes), 5126, floor.len(), "VEC2");
    b.meshes[0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uv);
    let image_view = b.views.len();
    b.views
        .push(json!({"buffer": 0, "byteOffset": b.bin.len(), "byteLength": png.len()}));
    b.bin.extend(&png);
    let mut document = b.document(json!([{"mesh": 0}]), None);
    document["textures"] = json!([{"source": 0}]);
    document["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
    document["images"] = json!([{"bufferView": image_view, "mimeType": "image/png"}]);
    s.write("embedded.glb", glb(&document, &b.bin));
    let limited = |scene: &str| {
        s.run(&[
            "--max-memory",
            "64",
            "bake",
            scene,
            "-o",
            "out/x.prt",
            "--mode",
            "unshadowed",
        ])
    };
    limited("embedded.glb").fails_with_bad_input(&[
        "embedded.glb#image0",
        "decoding its declared 4096×4096 pixels needs 256.0 MiB",
    ]);

    document["images"] = json!([{"uri": "big.png"}]);
    s.write("beside.glb", glb(&document, &b.bin));
    std::fs::write(s.path("big.png"), &png).unwrap();
    limited("beside.glb").fails_with_bad_input(&["beside.glb#image0", "4096×4096"]);
    // The file name as a uri: percent-encoded, as gltf reads it.
    document["images"] = json!([{"uri": "big%20image.png"}]);
    s.write("encoded.glb", glb(&document, &b.bin));
    std::fs::write(s.path("big image.png"), &png).unwrap();
    limited("encoded.glb").fails_with_bad_input(&["encoded.glb#image0", "4096×4096"]);
    let uri = format!("data:image/png;base64,{}", base64(&png));
    document["images"] = json!([{ "uri": uri }]);
    s.write("data-uri.glb", glb(&document, &b.bin));
    limited("data-uri.glb").fails_with_bad_input(&["data-uri.glb#image0", "4096×4096"]);
    s.assert_out_holds(&[]);
    s.bake("embedded.glb", "x.prt", &["--mode", "unshadowed"]);
    s.bake("data-uri.glb", "y.prt", &["--mode", "unshadowed"]);
}

/// A buffer or image uri that does not percent-decode to UTF-8 is bad input (gltf 1.4 itself
/// would panic on it), named with the file.
#[test]
fn gltf_uris_that_do_not_percent_decode_are_bad_input() {
    let s = Scratch::new();
    let ((floor, floor_triangles), _) = floor_and_cube();
    let indices: Vec<u32> = floor_triangles.iter().flatten().copied().collect();
    let mut b = GltfBuilder::new();
    b.mesh("floor", &floor, None, &indices, 4);
    let mut document = b.document(json!([{"mesh": 0}]), None);
    s.write("floor.bin", &b.bin);
    document["buffers"][0]["uri"] = json!("%FF.bin");
    s.write("buffer.gltf", serde_json::to_vec(&document).unwrap());
    s.run(&["bake", "buffer.gltf", "-o", "out/x.prt"])
        .fails_with_bad_input(&[
            "buffer.gltf",
            "buffer 0's uri \"%FF.bin\" is not percent-encoded UTF-8",
        ]);
    document["buffers"][0]["uri"] = json!("floor.bin");
    document["images"] = json!([{"uri": "%C3%28.png"}]);
    s.write("image.gltf", serde_json::to_vec(&document).unwrap());
    s.run(&["bake", "image.gltf", "-o", "out/x.prt"])
        .fails_with_bad_input(&["image.gltf", "image 0's uri"]);
    s.assert_out_holds(&[]);
}

// ---------------------------------------------------------------------------------------
// Hostile assets (docs/explanation/robustness.md): hierarchies that loop or nest deep, and paths inside
// an input that name devices, FIFOs or files outside the asset's folder.

/// Runs `prt-bake` in the scratch folder, failing the test if it runs past 10 s: the cases
/// below used to hang (a device read to its end) or abort (a stack overflow).
fn run_within_seconds(s: &Scratch, args: &[&str]) -> Run {
    use std::process::{Command, Stdio};
    use std::time::{Duration, Instant};
    let mut child = Command::new(env!("CARGO_BIN_EXE_prt-bake"))
        .args(args)
        .current_dir(s.path("."))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start prt-bake");
    let start = Instant::now();
    while child.try_wait().expect("wait for prt-bake").is_none() {
        if start.elapsed() > Duration::from_secs(10) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("prt-bake {} ran for over 10 s", args.join(" "));
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let output = child.wait_with_output().expect("read prt-bake's output");
    Run {
        args: args.join(" "),
        code: output.status.code(),
        stdout: String::from_utf8(output.stdout).expect("stdout is UTF-8"),
        stderr: String::from_utf8(output.stderr).expect("stderr is UTF-8"),
    }
}

/// The floor as a glTF document and its buffer's bytes (the buffer without a uri: a `.glb`'s).
fn floor_gltf(nodes: Value) -> (Value, Vec<u8>) {
    let ((floor, floor_triangles), _) = floor_and_cube();
    let indices: Vec<u32> = floor_triangles.iter().flatten().copied().collect();
    let mut b = GltfBuilder::new();
    b.mesh("floor", &floor, None, &indices, 4);
    (b.document(nodes, None), b.bin)
}

fn make_fifo(path: &Path) {
    use std::os::unix::ffi::OsStrExt;
    let name = std::ffi::CString::new(path.as_os_str().as_bytes()).unwrap();
    // SAFETY: a plain system call on a NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(name.as_ptr(), 0o644) }, 0, "mkfifo");
}

#[test]
fn gltf_node_cycles_are_bad_input_naming_the_node() {
    let s = Scratch::new();
    let cases = [
        (
            json!([{"mesh": 0, "children": [0]}]),
            "self.glb: invalid glTF: node 0 is its own child (a cycle)",
        ),
        (
            json!([{"mesh": 0, "children": [1]}, {"children": [0]}]),
            "self.glb: invalid glTF: node 0 is its own ancestor (a cycle: 0 → 1 → 0)",
        ),
        (
            json!([{"mesh": 0, "children": [1, 2]}, {"children": [2]}, {}]),
            "self.glb: invalid glTF: node 2 is a child of both node 0 and node 1",
        ),
    ];
    for (nodes, message) in cases {
        let (document, bin) = floor_gltf(nodes);
        s.write("self.glb", glb(&document, &bin));
        run_within_seconds(&s, &["bake", "self.glb", "-o", "out/x.prt"])
            .fails_with_bad_input(&[message]);
    }
    s.assert_out_holds(&[]);
}

/// Nesting is walked without recursion: 20,000 levels bake (the recursive walk overflowed
/// the stack), and only a depth past the reader's bound is refused.
#[test]
fn a_deep_gltf_hierarchy_bakes_and_an_absurd_one_is_refused() {
    let s = Scratch::new();
    let chain = |depth: usize| {
        let mut nodes: Vec<Value> = (1..depth)
            .map(|child| json!({"children": [child], "translation": [0.0, 0.0, 1e-4]}))
            .collect();
        nodes.push(json!({"mesh": 0}));
        Value::Array(nodes)
    };
    let (document, bin) = floor_gltf(chain(20_000));
    s.write("deep.glb", glb(&document, &bin));
    run_within_seconds(&s, &["bake", "deep.glb", "-o", "out/deep.prt", "--quiet"]).success();
    let deep = Scene::load(&s.path("deep.glb")).unwrap();
    // Every level's translation applied once.
    let z = deep.positions.iter().map(|p| p.z).fold(f32::NAN, f32::max);
    assert!((z - 2.0).abs() < 0.01, "{z}");

    let (document, bin) = floor_gltf(chain(100_001));
    s.write("deeper.glb", glb(&document, &bin));
    run_within_seconds(&s, &["bake", "deeper.glb", "-o", "out/x.prt"]).fails_with_bad_input(&[
        "deeper.glb: node 100000 is nested 100001 levels deep, deeper than the 100000",
    ]);
    s.assert_out_holds(&["deep.prt"]);
}

/// A glTF's buffer and image uris may only name regular files inside its folder: devices,
/// FIFOs, directories, escapes (`..`, percent-encoded, symbolic links) and absolute paths are
/// refused in a second, naming the file and the uri, and nothing is written;
/// `--allow-outside-uris` lets a regular file elsewhere be read, never a device.
#[test]
fn gltf_uris_naming_devices_or_files_outside_the_folder_are_refused() {
    let s = Scratch::new();
    std::fs::create_dir(s.path("asset")).unwrap();
    let (mut document, bin) = floor_gltf(json!([{"mesh": 0}]));
    s.write("asset/floor.bin", &bin);
    s.write("secret.bin", &bin);
    make_fifo(&s.path("asset/fifo.bin"));
    std::os::unix::fs::symlink(s.path("secret.bin"), s.path("asset/link.bin")).unwrap();
    std::fs::create_dir(s.path("asset/folder.bin")).unwrap();
    let outside = "--allow-outside-uris allows it";
    let cases: [(&str, &[&str]); 10] = [
        (
            "/dev/zero",
            &["buffer 0's uri \"/dev/zero\" is an absolute path", outside],
        ),
        (
            "file:///dev/zero",
            &["buffer 0's uri \"file:///dev/zero\" is an absolute path"],
        ),
        (
            "../../../../../../../../dev/zero",
            &["resolves to /dev/zero, outside the asset's folder", outside],
        ),
        (
            "../secret.bin",
            &["buffer 0's uri \"../secret.bin\" resolves to", outside],
        ),
        (
            "%2E%2E/secret.bin",
            &["buffer 0's uri \"%2E%2E/secret.bin\" resolves to"],
        ),
        ("%2Fdev%2Fzero", &["is an absolute path"]),
        (
            "link.bin",
            &["buffer 0's uri \"link.bin\" resolves to", outside],
        ),
        (
            "fifo.bin",
            &["a FIFO (named pipe); only regular files are read"],
        ),
        ("folder.bin", &["a directory; only regular files are read"]),
        ("/etc/passwd", &["is an absolute path"]),
    ];
    for (uri, needles) in cases {
        document["buffers"][0]["uri"] = json!(uri);
        s.write("asset/s.gltf", serde_json::to_vec(&document).unwrap());
        let run = run_within_seconds(&s, &["bake", "asset/s.gltf", "-o", "out/x.prt"]);
        run.fails_with_bad_input(&["asset/s.gltf: "]);
        run.fails_with_bad_input(needles);
    }

    // The option lets a regular file elsewhere be read, not a device or a FIFO.
    document["buffers"][0]["uri"] = json!("../secret.bin");
    s.write("asset/s.gltf", serde_json::to_vec(&document).unwrap());
    let allow = ["bake", "asset/s.gltf", "-o", "out/x.prt", "--quiet"];
    run_within_seconds(&s, &[&allow[..], &["--allow-outside-uris"]].concat()).success();
    for (uri, kind) in [("/dev/zero", "a character device"), ("fifo.bin", "a FIFO")] {
        document["buffers"][0]["uri"] = json!(uri);
        s.write("asset/s.gltf", serde_json::to_vec(&document).unwrap());
        run_within_seconds(&s, &[&allow[..], &["--allow-outside-uris"]].concat())
            .fails_with_bad_input(&[kind, "only regular files are read"]);
    }

    // A buffer file shorter than its byteLength, and a byteLength over --max-memory.
    document["buffers"][0]["uri"] = json!("floor.bin");
    document["buffers"][0]["byteLength"] = json!(bin.len() + 4);
    s.write("asset/s.gltf", serde_json::to_vec(&document).unwrap());
    run_within_seconds(&s, &["bake", "asset/s.gltf", "-o", "out/y.prt"]).fails_with_bad_input(&[
        &format!(
            "buffer 0 has {} bytes, fewer than its byteLength of {}",
            bin.len(),
            bin.len() + 4
        ),
    ]);
    document["buffers"][0]["byteLength"] = json!(1u64 << 40);
    s.write("asset/s.gltf", serde_json::to_vec(&document).unwrap());
    run_within_seconds(&s, &["bake", "asset/s.gltf", "-o", "out/y.prt"]).fails_with_bad_input(&[
        "asset/s.gltf#buffer0: its declared byteLength of 1099511627776 needs 1.0 TiB, over the memory limit",
    ]);

    // Image uris: the same rules, for export too.
    document["buffers"][0]["byteLength"] = json!(bin.len());
    document["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
    document["textures"] = json!([{"source": 0}]);
    for (uri, needle) in [
        (
            "/dev/zero",
            "image 0's uri \"/dev/zero\" is an absolute path",
        ),
        (
            "../secret.png",
            "image 0's uri \"../secret.png\" resolves to",
        ),
        ("fifo.bin", "image 0's uri \"fifo.bin\" names"),
    ] {
        s.write("secret.png", b"not a png");
        document["images"] = json!([{"uri": uri, "mimeType": "image/png"}]);
        s.write("asset/s.gltf", serde_json::to_vec(&document).unwrap());
        run_within_seconds(&s, &["bake", "asset/s.gltf", "-o", "out/y.prt"])
            .fails_with_bad_input(&["asset/s.gltf: ", needle]);
        run_within_seconds(
            &s,
            &[
                "export",
                "out/x.prt",
                "--scene",
                "asset/s.gltf",
                "--npz",
                "out/y.npz",
            ],
        )
        .fails_with_bad_input(&["asset/s.gltf: ", needle]);
    }
    s.assert_out_holds(&["x.prt"]);
}

/// The same rules for the paths of OBJ (`mtllib`), MTL (`map_Kd`), scene files and light
/// rigs (environment maps), in every command that reads them.
#[test]
fn obj_mtl_scene_and_rig_paths_follow_the_same_rules() {
    let s = Scratch::new();
    std::fs::create_dir(s.path("asset")).unwrap();
    s.write("outside.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    s.write("outside.mtl", "newmtl m\nKd 1 1 1\n");
    make_fifo(&s.path("asset/fifo.tga"));
    let triangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let cases: [(&str, &str, &[&str]); 8] = [
        (
            "asset/a.obj",
            &format!("mtllib ../outside.mtl\n{triangle}f 1 2 3\n"),
            &[
                "asset/a.obj:1: material library \"../outside.mtl\" resolves to",
                "--allow-outside-uris",
            ],
        ),
        (
            "asset/a.obj",
            &format!("mtllib /dev/zero\n{triangle}f 1 2 3\n"),
            &["asset/a.obj:1: material library \"/dev/zero\" is an absolute path"],
        ),
        (
            "asset/a.mtl",
            "newmtl m\nmap_Kd /dev/zero\n",
            &["asset/a.mtl:2: texture \"/dev/zero\" is an absolute path"],
        ),
        (
            "asset/a.mtl",
            "newmtl m\nmap_Kd ../../../../../../../../dev/zero\n",
            &["resolves to /dev/zero"],
        ),
        (
            "asset/a.mtl",
            "newmtl m\nmap_Kd fifo.tga\n",
            &["asset/a.mtl:2: texture \"fifo.tga\" names", "a FIFO"],
        ),
        (
            "asset/a.scene",
            "\"../outside.obj\"\n",
            &["asset/a.scene:1: object \"../outside.obj\" resolves to"],
        ),
        (
            "asset/a.scene",
            "\"/dev/zero\"\n",
            &["asset/a.scene:1: object \"/dev/zero\" is an absolute path"],
        ),
        (
            "asset/a.scene",
            "\"b.obj\" \"fifo.tga\"\n",
            &["asset/a.scene:1: texture \"fifo.tga\" names", "a FIFO"],
        ),
    ];
    s.write(
        "asset/b.obj",
        format!("mtllib a.mtl\n{triangle}usemtl m\nf 1 2 3\n"),
    );
    s.write("asset/a.mtl", "newmtl m\nKd 1 1 1\n");
    for (file, text, needles) in cases {
        s.write(file, text);
        let scene = if file.ends_with(".mtl") {
            "asset/b.obj"
        } else {
            file
        };
        run_within_seconds(&s, &["bake", scene, "-o", "out/x.prt"]).fails_with_bad_input(needles);
        s.write("asset/a.mtl", "newmtl m\nKd 1 1 1\n");
    }
    // With the option, the scene file's object outside its folder bakes.
    s.write("asset/a.scene", "\"../outside.obj\"\n");
    let bake = ["bake", "asset/a.scene", "-o", "out/x.prt", "--quiet"];
    run_within_seconds(&s, &[&bake[..], &["--allow-outside-uris"]].concat()).success();

    // A rig's environment map, through `light` and `relight`.
    s.write("outside.hdr", b"not an hdr");
    s.write(
        "asset/rig.toml",
        "[[light]]\nkind = \"environment\"\npath = \"../outside.hdr\"\n",
    );
    let light = ["light", "asset/rig.toml", "-o", "out/l.json"];
    let refused = [
        "asset/rig.toml:3: light 1, key `path`: environment map \"../outside.hdr\" resolves to",
        "--allow-outside-uris allows it",
    ];
    run_within_seconds(&s, &light).fails_with_bad_input(&refused);
    run_within_seconds(
        &s,
        &[
            "relight",
            "asset/b.obj",
            "out/x.prt",
            "--lights",
            "asset/rig.toml",
            "-o",
            "out/r.ply",
        ],
    )
    .fails_with_bad_input(&refused);
    // Allowed, the map is read (and is no HDR).
    run_within_seconds(&s, &[&light[..], &["--allow-outside-uris"]].concat()).fails_with_bad_input(
        &[
            "cannot use ../outside.hdr",
            "cannot decode the environment map",
        ],
    );
    s.write(
        "asset/rig.toml",
        "[[light]]\nkind = \"environment\"\npath = \"/dev/zero\"\n",
    );
    run_within_seconds(&s, &[&light[..], &["--allow-outside-uris"]].concat())
        .fails_with_bad_input(&["asset/rig.toml:3: light 1, key `path`: environment map \"/dev/zero\" names /dev/zero, a character device"]);
    s.assert_out_holds(&["x.prt"]);
}

/// Hostile alpha inputs: a cutoff outside [0, 1], a missing or corrupt base colour
/// (alpha) texture in glTF, a missing or corrupt OBJ `map_d`: each a bad-input error that
/// names the file and the problem, never a crash or an opaque bake.
#[test]
fn unusable_alpha_inputs_are_bad_input() {
    let s = Scratch::new();
    let ((floor, floor_triangles), _) = floor_and_cube();
    let indices: Vec<u32> = floor_triangles.iter().flatten().copied().collect();
    let mut b = GltfBuilder::new();
    b.mesh("floor", &floor, None, &indices, 4);
    let base = b.document(json!([{"mesh": 0}]), None);
    let with_material = |material: Value, images: Option<Value>| {
        let mut document = base.clone();
        document["materials"] = json!([material]);
        if let Some(images) = images {
            document["images"] = images;
            document["textures"] = json!([{"source": 0}]);
        }
        glb(&document, &b.bin)
    };
    for cutoff in [1.5, -0.25] {
        let material = json!({"name": "leaf", "alphaMode": "MASK", "alphaCutoff": cutoff});
        s.write("cutoff.glb", with_material(material, None));
        s.run(&["bake", "cutoff.glb", "-o", "out/x.prt"])
            .fails_with_bad_input(&[
                "cutoff.glb",
                "material 'leaf'",
                &format!("alphaCutoff {cutoff} is outside [0, 1]"),
            ]);
    }
    let textured = json!({"name": "leaf", "alphaMode": "MASK",
        "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}});
    s.write(
        "missing.glb",
        with_material(textured.clone(), Some(json!([{"uri": "leaf.png"}]))),
    );
    s.run(&["bake", "missing.glb", "-o", "out/x.prt"])
        .fails_with_bad_input(&["missing.glb", "leaf.png"]);
    s.write("junk.png", b"\x89PNG\r\n\x1a\nnot really a png");
    s.write(
        "corrupt.glb",
        with_material(textured, Some(json!([{"uri": "junk.png"}]))),
    );
    s.run(&["bake", "corrupt.glb", "-o", "out/x.prt"])
        .fails_with_bad_input(&["corrupt.glb", "image 0", "decoding Png"]);

    let obj = "mtllib leaf.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl leaf\nf 1/1 2/2 3/3\n";
    s.write("leaf.obj", obj);
    s.write("leaf.mtl", "newmtl leaf\nKd 0.5 0.5 0.5\nmap_d gone.png\n");
    s.run(&["bake", "leaf.obj", "-o", "out/x.prt"])
        .fails_with_bad_input(&["leaf.mtl:3", "gone.png"]);
    s.write("leaf.mtl", "newmtl leaf\nKd 0.5 0.5 0.5\nmap_d junk.png\n");
    s.run(&["bake", "leaf.obj", "-o", "out/x.prt"])
        .fails_with_bad_input(&["leaf.mtl:3", "junk.png"]);
    s.assert_out_holds(&[]);
}
