//! Instancing: a glTF mesh placed at many nodes that do not receive is traced
//! through instances. The oracles: a ground under 100 instanced trees (turned, scaled, some
//! mirrored) bakes as the flattened scene does, up to rounding, on both backends; closest
//! hits through instances are the flattened scene's (distance, world normal); Embree and
//! obvhs agree on instances; a million instances are refused by size, not by flattening.

mod common;

use common::*;
use glam::Vec3;
use prt_baker::CoefficientFile;
use prt_baker::bake::receiver_names::receives;
use prt_baker::math::sampling::{Pcg32, uniform_sphere};
use prt_baker::scene::{Instancing, Scene};
use prt_baker::trace::{self, Backend, Hit, Ray, TracerOptions};
use serde_json::{Value, json};

/// A cone of `segments` × `rings` quads (the forest script's tree, smaller).
fn tree(segments: u32, rings: u32) -> (Vec<[f32; 3]>, Vec<u32>) {
    let mut positions = Vec::new();
    for r in 0..=rings {
        let y = 0.2 + 2.0 * r as f32 / rings as f32;
        let radius = 0.6 * (1.0 - r as f32 / (rings + 1) as f32);
        for s in 0..segments {
            let a = std::f32::consts::TAU * s as f32 / segments as f32;
            positions.push([radius * a.cos(), y, radius * a.sin()]);
        }
    }
    let mut indices = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let (a, b) = (r * segments + s, r * segments + (s + 1) % segments);
            indices.extend([a, a + segments, b, b, a + segments, b + segments]);
        }
    }
    (positions, indices)
}

/// A `grid` × `grid` quad ground over [−extent, extent]² at y = 0.
fn ground(extent: f32, grid: u32) -> (Vec<[f32; 3]>, Vec<u32>) {
    let mut positions = Vec::new();
    for j in 0..=grid {
        for i in 0..=grid {
            let at = |k: u32| extent * (2.0 * k as f32 / grid as f32 - 1.0);
            positions.push([at(i), 0.0, at(j)]);
        }
    }
    let mut indices = Vec::new();
    for j in 0..grid {
        for i in 0..grid {
            let a = j * (grid + 1) + i;
            indices.extend([a, a + grid + 1, a + 1, a + 1, a + grid + 1, a + grid + 2]);
        }
    }
    (positions, indices)
}

/// Writes `forest.gltf` (and its `.bin`): a ground and `n` placements of one tree mesh, each
/// turned, scaled unevenly, every third one mirrored; as `n` nodes under a node "Forest", or
/// with `gpu`, as EXT_mesh_gpu_instancing instances of one node under a "Forest" moved by
/// +0.5 in x (the instances by −0.5: the same world placements). `extra` nodes are appended
/// as roots.
fn write_forest(s: &Scratch, n: usize, gpu: bool, extra: &[Value]) {
    let mut blob: Vec<u8> = Vec::new();
    let mut accessors = Vec::new();
    let mut views = Vec::new();
    let mut meshes = Vec::new();
    for (positions, indices) in [ground(9.0, 16), tree(12, 8)] {
        views.push(
            json!({"buffer": 0, "byteOffset": blob.len(), "byteLength": 12 * positions.len()}),
        );
        blob.extend(positions.iter().flatten().flat_map(|x| x.to_le_bytes()));
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
        accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5126,
            "count": positions.len(), "type": "VEC3", "min": lo, "max": hi}));
        views.push(json!({"buffer": 0, "byteOffset": blob.len(), "byteLength": 4 * indices.len()}));
        blob.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
        accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5125,
            "count": indices.len(), "type": "SCALAR"}));
        meshes.push(
            json!({"primitives": [{"attributes": {"POSITION": accessors.len() - 2},
            "indices": accessors.len() - 1}]}),
        );
    }
    let side = (n as f32).sqrt().ceil() as usize;
    let placements: Vec<([f32; 3], [f32; 4], [f32; 3])> = (0..n)
        .map(|k| {
            let (x, z) = (
                (k % side) as f32 * 1.5 - side as f32 * 0.75,
                (k / side) as f32 * 1.5 - side as f32 * 0.75,
            );
            let angle = k as f32 * 0.7;
            let mirror = if k % 3 == 0 { -1.0 } else { 1.0 };
            (
                [x, 0.0, z],
                [0.0, (angle / 2.0).sin(), 0.0, (angle / 2.0).cos()],
                [
                    mirror * (0.8 + 0.05 * (k % 5) as f32),
                    1.0 + 0.1 * (k % 3) as f32,
                    0.9,
                ],
            )
        })
        .collect();
    let mut nodes = vec![json!({"name": "Ground", "mesh": 0})];
    if gpu {
        let mut attributes = serde_json::Map::new();
        for (name, width) in [("TRANSLATION", 3), ("ROTATION", 4), ("SCALE", 3)] {
            let values: Vec<f32> = placements
                .iter()
                .flat_map(|(t, r, s)| match width {
                    4 => r.to_vec(),
                    _ if name == "SCALE" => s.to_vec(),
                    _ => vec![t[0] - 0.5, t[1], t[2]],
                })
                .collect();
            views.push(
                json!({"buffer": 0, "byteOffset": blob.len(), "byteLength": 4 * values.len()}),
            );
            blob.extend(values.iter().flat_map(|x| x.to_le_bytes()));
            let kind = if width == 4 { "VEC4" } else { "VEC3" };
            accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5126,
                "count": n, "type": kind}));
            attributes.insert(name.into(), json!(accessors.len() - 1));
        }
        nodes.push(json!({"name": "Forest", "children": [2], "translation": [0.5, 0.0, 0.0]}));
        nodes.push(json!({"name": "trees", "mesh": 1,
            "extensions": {"EXT_mesh_gpu_instancing": {"attributes": attributes}}}));
    } else {
        nodes.push(json!({"name": "Forest", "children": (2..n + 2).collect::<Vec<_>>()}));
        for (k, (t, r, s)) in placements.iter().enumerate() {
            nodes.push(json!({"name": format!("tree{k}"), "mesh": 1,
                "translation": t, "rotation": r, "scale": s}));
        }
    }
    let mut roots = vec![0, 1];
    for node in extra {
        roots.push(nodes.len());
        nodes.push(node.clone());
    }
    let mut document = json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": roots}],
        "nodes": nodes, "meshes": meshes, "accessors": accessors, "bufferViews": views,
        "buffers": [{"byteLength": blob.len(), "uri": "forest.bin"}],
    });
    if gpu {
        document["extensionsUsed"] = json!(["EXT_mesh_gpu_instancing"]);
    }
    s.write("forest.bin", &blob);
    s.write("forest.gltf", serde_json::to_vec(&document).unwrap());
}

/// Relative L2 distance between two bakes' coefficients (all rows, all channels).
fn relative_distance(a: &CoefficientFile, b: &CoefficientFile) -> f64 {
    assert_eq!(a.header.vertex_count, b.header.vertex_count);
    let (mut diff, mut norm) = (0.0f64, 0.0f64);
    for v in 0..a.header.vertex_count as usize {
        for c in 0..a.header.channels as usize {
            for (x, y) in a.vertex(v, c).iter().zip(b.vertex(v, c)) {
                diff += f64::from(x - y).powi(2);
                norm += f64::from(*y).powi(2);
            }
        }
    }
    (diff / norm).sqrt()
}

/// The ground's shadowed transfer under 100 instanced trees is the flattened scene's, up to
/// rounding (same seed, so the same rays: only rays that graze a tree may differ), with
/// Embree and with obvhs; and the two backends agree on the instanced scene. The trees shade
/// the ground: a bake that ignored them would be far from the flattened one.
#[test]
fn a_ground_under_instanced_trees_bakes_as_the_flattened_scene() {
    let s = Scratch::new();
    write_forest(&s, 100, false, &[]);
    let mut backends = vec!["obvhs"];
    if cfg!(feature = "embree") {
        backends.push("embree");
    }
    let read = |name: &str| CoefficientFile::read(&s.path(&format!("out/{name}"))).unwrap();
    let args = |backend: &'static str, instances: &'static str| {
        vec![
            "--receivers",
            "Ground",
            "--backend",
            backend,
            "--instances",
            instances,
        ]
    };
    for &backend in &backends {
        s.bake(
            "forest.gltf",
            &format!("flat-{backend}.prt"),
            &args(backend, "off"),
        );
        let run = s.bake(
            "forest.gltf",
            &format!("inst-{backend}.prt"),
            &args(backend, "on"),
        );
        assert!(
            run.stderr
                .contains("100 placements of 1 meshes traced as instances"),
            "{}",
            run.stderr
        );
        // `auto` leaves a scene this small flat.
        let auto = s.bake("forest.gltf", "auto.prt", &args(backend, "auto"));
        assert!(!auto.stderr.contains("instances"), "{}", auto.stderr);
        let (flat, inst) = (
            read(&format!("flat-{backend}.prt")),
            read(&format!("inst-{backend}.prt")),
        );
        let distance = relative_distance(&inst, &flat);
        eprintln!("{backend}: instanced vs flattened {distance:.2e}");
        assert!(
            distance < 1e-3,
            "{backend}: instanced vs flattened {distance}"
        );
        s.bake(
            "forest.gltf",
            &format!("bare-{backend}.prt"),
            &[
                "--receivers",
                "Ground",
                "--backend",
                backend,
                "--mode",
                "unshadowed",
            ],
        );
        let shadowless = relative_distance(&read(&format!("bare-{backend}.prt")), &flat);
        eprintln!("{backend}: unshadowed vs flattened {shadowless:.2e}");
        assert!(
            shadowless > 0.05,
            "{backend}: the trees barely shade the ground ({shadowless})"
        );
    }
    if backends.len() == 2 {
        let distance = relative_distance(&read("inst-obvhs.prt"), &read("inst-embree.prt"));
        eprintln!("obvhs vs Embree on instances: {distance:.2e}");
        assert!(distance < 1e-3, "obvhs vs Embree on instances: {distance}");
    }
    // The readers load the scene as the instanced bake traced it (its fingerprint says so):
    // the export reads the instanced file as it reads the flat one.
    for name in ["inst-obvhs", "flat-obvhs"] {
        s.run(&[
            "export",
            &format!("out/{name}.prt"),
            "--scene",
            "forest.gltf",
            "--gltf",
            &format!("out/{name}.glb"),
            "--npz",
            &format!("out/{name}.npz"),
        ])
        .success();
    }
}

/// Closest hits through instances: the same distance and world-space geometric normal as
/// the flattened scene's hit, for rays from above the forest, on both backends.
#[test]
fn closest_hits_through_instances_are_the_flattened_scenes() {
    let s = Scratch::new();
    write_forest(&s, 25, false, &[]);
    let path = s.path("forest.gltf");
    let flat = Scene::load(&path).unwrap();
    let receives = receives(&["Ground".into()]);
    let instancing = Instancing {
        receives: &receives,
        min_triangles: 0,
    };
    let (instanced, _) = Scene::load_instanced(&path, Some(&instancing)).unwrap();
    assert_eq!(instanced.instances.placements.len(), 25);
    assert_eq!(instanced.objects.len(), 1);
    let mut rng = Pcg32::new(5, 0);
    let rays: Vec<Ray> = (0..4000)
        .map(|_| {
            let origin = Vec3::new(
                rng.next_f32() * 8.0 - 4.0,
                1.0 + rng.next_f32() * 2.0,
                rng.next_f32() * 8.0 - 4.0,
            );
            Ray {
                origin,
                dir: uniform_sphere(rng.next_f32(), rng.next_f32()),
                tfar: f32::INFINITY,
            }
        })
        .collect();
    let mut backends = vec![Backend::Obvhs];
    if cfg!(feature = "embree") {
        backends.push(Backend::Embree);
    }
    for backend in backends {
        let options = TracerOptions {
            threads: Some(1),
            robust: backend == Backend::Embree,
            ..TracerOptions::default()
        };
        let (a, b) = (
            trace::build(backend, &flat, options).unwrap(),
            trace::build(backend, &instanced, options).unwrap(),
        );
        let mut expected: Vec<Option<Hit>> = vec![None; rays.len()];
        let mut found = expected.clone();
        a.intersect(&rays, &mut expected);
        b.intersect(&rays, &mut found);
        let mut blocked = vec![false; rays.len()];
        b.occluded(&rays, &mut blocked);
        let (mut on_trees, mut mismatches) = (0, 0);
        for ((e, f), &o) in expected.iter().zip(&found).zip(&blocked) {
            assert_eq!(
                f.is_some(),
                o,
                "{backend:?}: occlusion disagrees with the closest hit"
            );
            match (e, f) {
                (Some(e), Some(f)) => {
                    let same_t = (e.t - f.t).abs() <= 1e-4 * e.t.max(1.0);
                    let same_n = e.ng.normalize().dot(f.ng.normalize()) > 0.999;
                    mismatches += usize::from(!(same_t && same_n));
                    on_trees += usize::from(f.instance.is_some());
                    assert_eq!(
                        f.instance.is_some(),
                        e.triangle >= flat.objects[0].triangles.end
                    );
                }
                (None, None) => {}
                _ => mismatches += 1,
            }
        }
        eprintln!("{backend:?}: {on_trees} tree hits, {mismatches} mismatches");
        assert!(on_trees > 200, "{backend:?}: {on_trees} hits on trees");
        assert!(
            mismatches <= 2,
            "{backend:?}: {mismatches} hits differ from the flattened scene's"
        );
    }
}

/// Many instances of one mesh: each costs its transform, not a copy of the mesh, so the
/// memory check counts instances (and refuses them under a small --max-memory, naming
/// them) rather than flattened triangles. (200,000 rather than the 10⁶ a production forest has, to keep
/// `make test` fast: writing and parsing the JSON is what takes the time; docs/guides/production-assets.md
/// has the 10⁶ run.)
#[test]
fn many_instances_are_counted_as_instances() {
    let s = Scratch::new();
    let count = 200_000;
    let extra: Vec<Value> = (0..count)
        .map(|_| json!({"mesh": 1, "translation": [0.0, 0.0, 50.0]}))
        .collect();
    write_forest(&s, 2, false, &extra);
    let run = s.run(&[
        "bake",
        "forest.gltf",
        "-o",
        "out/x.prt",
        "--receivers",
        "Ground",
        "--instances",
        "on",
        "--max-memory",
        "50",
    ]);
    run.fails_with_bad_input(&["forest.gltf", "(200002 instanced)", "memory limit"]);
    assert!(!s.path("out/x.prt").exists());
}

/// EXT_mesh_gpu_instancing: one node's 100 instances (under a moved parent) bake the ground
/// as 100 nodes at the same places do, flattened and instanced; a file whose instance
/// accessor points outside its buffer is refused with the node and accessor named.
#[test]
fn gpu_instancing_places_the_mesh_at_each_instance() {
    let s = Scratch::new();
    write_forest(&s, 100, false, &[]);
    s.bake(
        "forest.gltf",
        "nodes.prt",
        &["--receivers", "Ground", "--instances", "off"],
    );
    write_forest(&s, 100, true, &[]);
    let read = |name: &str| CoefficientFile::read(&s.path(&format!("out/{name}"))).unwrap();
    for instances in ["off", "on"] {
        let name = format!("gpu-{instances}.prt");
        let run = s.bake(
            "forest.gltf",
            &name,
            &["--receivers", "Ground", "--instances", instances],
        );
        assert!(!run.stderr.contains("warning"), "{}", run.stderr);
        let distance = relative_distance(&read(&name), &read("nodes.prt"));
        eprintln!("EXT_mesh_gpu_instancing, --instances {instances}: {distance:.2e}");
        assert!(distance < 1e-3, "--instances {instances}: {distance}");
    }
    let mut document: Value = serde_json::from_slice(&s.read("forest.gltf")).unwrap();
    let rotation =
        document["nodes"][2]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["ROTATION"]
            .clone();
    document["accessors"][rotation.as_u64().unwrap() as usize]["byteOffset"] = json!(1 << 20);
    s.write("forest.gltf", serde_json::to_vec(&document).unwrap());
    let run = s.run(&[
        "bake",
        "forest.gltf",
        "-o",
        "out/bad.prt",
        "--receivers",
        "Ground",
    ]);
    run.fails_with_bad_input(&[
        "forest.gltf",
        "node 2: EXT_mesh_gpu_instancing: ROTATION",
        "outside",
    ]);
}

/// Texel bakes instance too: the ground's lightmap (`--lightmap 32 --receivers Ground`,
/// shadowed, the leak test's closest hits included) under 100 trees is bit for bit the same
/// with `--instances on` and `off`, on Embree and on obvhs (same texels, same streams, same
/// hits); the trees are not in the atlas either way. The instanced file records the scene
/// it traced, and `export` loads the scene that way: its images are the flat file's.
#[test]
fn a_grounds_lightmap_under_instanced_trees_is_the_flattened_scenes() {
    let s = Scratch::new();
    write_forest(&s, 100, false, &[]);
    let mut backends = vec!["obvhs"];
    if cfg!(feature = "embree") {
        backends.push("embree");
    }
    let read = |name: &str| CoefficientFile::read(&s.path(&format!("out/{name}"))).unwrap();
    for &backend in &backends {
        for instances in ["on", "off"] {
            let run = s.bake(
                "forest.gltf",
                &format!("{backend}-{instances}.prt"),
                &[
                    "--lightmap",
                    "32",
                    "--samples",
                    "16",
                    "--aux",
                    "ao",
                    "--receivers",
                    "Ground",
                    "--backend",
                    backend,
                    "--instances",
                    instances,
                ],
            );
            assert_eq!(
                run.stderr
                    .contains("100 placements of 1 meshes traced as instances"),
                instances == "on",
                "{}",
                run.stderr
            );
        }
        let (on, off) = (
            read(&format!("{backend}-on.prt")),
            read(&format!("{backend}-off.prt")),
        );
        let (l_on, l_off) = (
            on.lightmap.as_ref().unwrap(),
            off.lightmap.as_ref().unwrap(),
        );
        // The ground's 512 triangles come first in both; the flat scene's trees are out.
        assert_eq!(l_on.uv1.len(), 512);
        assert_eq!(l_on.uv1[..], l_off.uv1[..512]);
        assert!(
            l_off.uv1[512..]
                .iter()
                .flatten()
                .all(|c| *c == glam::Vec2::splat(-1.0))
        );
        assert_eq!(
            l_on.valid, l_off.valid,
            "{backend}: texels left out as leaking"
        );
        assert!(l_on.valid.iter().any(|&v| v));
        assert_eq!(on.coefficients, off.coefficients, "{backend}");
        assert_eq!(on.ao, off.ao, "{backend}");
        // The trees shade the ground: some texel sees under 90 % of the sky.
        let ao = on.ao.as_ref().unwrap();
        assert!(
            (0..ao.len()).any(|t| l_on.valid[t] && ao[t] < 0.9),
            "{backend}: no shadow"
        );
    }
    // The readers load the scene as the bake traced it (the fingerprint says which): the
    // instanced file exports the same lightmap images as the flat one, and its npz too.
    for instances in ["on", "off"] {
        for (flag, out) in [("--exr", "exr"), ("--npz", "npz")] {
            s.run(&[
                "export",
                &format!("out/obvhs-{instances}.prt"),
                "--scene",
                "forest.gltf",
                flag,
                &format!("out/{instances}.{out}"),
            ])
            .success();
        }
    }
    // --exr writes a folder of images.
    let images = |folder: &str| {
        let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(s.path(folder))
            .unwrap()
            .map(|e| e.unwrap().path())
            .map(|p| {
                (
                    p.file_name().unwrap().to_string_lossy().into_owned(),
                    std::fs::read(&p).unwrap(),
                )
            })
            .collect();
        files.sort();
        files
    };
    let (on, off) = (images("out/on.exr"), images("out/off.exr"));
    assert!(on.len() > 1);
    // The manifest names the source file (and its header): the images must be the same.
    for (a, b) in on.iter().zip(&off).filter(|(a, _)| a.0 != "manifest.json") {
        assert!(
            a.0 == b.0 && a.1 == b.1,
            "{} differs from the flat file's {}",
            a.0,
            b.0
        );
    }
}
