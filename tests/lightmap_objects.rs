//! Per-object lightmap UVs: scenes whose objects each have their own TEXCOORD_1
//! in [0, 1], as Blender's Smart UV Project and Unity lay them out, are packed per object
//! with a scale and offset (no texel shared between objects); an object whose UVs overlap
//! themselves is warned about and unwrapped alone; clean scene UVs stay the atlas as they
//! were. docs/guides/lightmaps.md, "Per-object lightmap UVs".

use glam::{Vec2, Vec3};
use prt_baker::bake::lightmap::objects::{check, from_scene_uvs, shared_texels};
use prt_baker::bake::lightmap::{self, Atlas, AtlasSource};
use prt_baker::formats::header::ObjectUvs;
use prt_baker::support::progress::Silent;
use prt_baker::{BakeOptions, CoefficientFile, Mode, Scene};
use prt_tests::*;

const CELLS: u32 = 6;

/// Per-vertex UVs of a [`grid`] of `CELLS`² cells: (i, j) / CELLS, through `map`.
fn grid_uvs(map: impl Fn(f32, f32) -> Vec2) -> Vec<Vec2> {
    let n = CELLS + 1;
    (0..n * n)
        .map(|k| map((k % n) as f32 / CELLS as f32, (k / n) as f32 / CELLS as f32))
        .collect()
}

/// A floor 4 × 4 and a wall 2 × 1 standing on it (z up), each with `floor_uvs` and
/// `wall_uvs` as its lightmap UVs.
fn floor_and_wall(floor_uvs: Vec<Vec2>, wall_uvs: Vec<Vec2>) -> Scene {
    let floor = grid(
        "floor",
        Vec3::new(-2.0, -2.0, 0.0),
        Vec3::X * 4.0,
        Vec3::Y * 4.0,
        CELLS,
    );
    let wall = grid(
        "wall",
        Vec3::new(-1.0, 0.5, 0.0),
        Vec3::X * 2.0,
        Vec3::Z * 1.0,
        CELLS,
    );
    let mut s = scene(vec![floor, wall]);
    s.lightmap_uvs = Some(floor_uvs.into_iter().chain(wall_uvs).collect());
    s
}

fn unit(u: f32, v: f32) -> Vec2 {
    Vec2::new(u, v)
}

fn world_area(scene: &Scene, t: usize) -> f32 {
    let p = scene.triangles[t].map(|v| scene.positions[v as usize]);
    (p[1] - p[0]).cross(p[2] - p[0]).length() / 2.0
}

fn uv_area(uv: [Vec2; 3]) -> f32 {
    (uv[1] - uv[0]).perp_dot(uv[2] - uv[0]).abs() / 2.0
}

/// Two objects each on [0, 1]: as one atlas every texel of the wall is the floor's too; packed
/// per object none is shared, each corner is its own UV × scale + offset, both objects get the
/// same texel density, and the bake's file stores the placements and reads them back.
#[test]
fn objects_with_their_own_unit_uvs_are_packed_without_sharing_a_texel() {
    let scene = floor_and_wall(grid_uvs(unit), grid_uvs(unit));
    let own = Atlas::from_vertex_uvs(&scene, scene.lightmap_uvs.as_ref().unwrap(), 64, 64)
        .expect("atlas");
    let before = check(&scene, &own.uv1, 64, 64);
    let shared_before = shared_texels(&scene, &own);
    eprintln!(
        "as one atlas: {} texel centres claimed by both objects, {shared_before} texels shared",
        before.shared_texels
    );
    // Texel centres that lie on a triangle's edge (within the edge tolerance) are claimed by
    // neither triangle: the diagonals of the grid's cells pass through 128 of them.
    assert!(
        before.shared_texels >= 64 * 64 * 95 / 100,
        "nearly every texel centre is claimed twice: {}",
        before.shared_texels
    );
    assert!(shared_before >= 64 * 64 - 1);
    assert!(before.objects.iter().all(|o| o.self_overlapped == 0));

    let (atlas, _, notes) =
        from_scene_uvs(&scene, scene.lightmap_uvs.as_ref().unwrap(), 64, false).expect("packed");
    assert_eq!(atlas.source, AtlasSource::PerObject);
    assert_eq!(
        shared_texels(&scene, &atlas),
        0,
        "packed objects share no texel"
    );
    assert!(
        notes
            .iter()
            .any(|n| n.contains(&format!("{} texels at 64²", before.shared_texels))),
        "the note counts the shared texels: {notes:?}"
    );
    assert_eq!(atlas.objects.len(), 2);
    let uvs = scene.lightmap_uvs.as_ref().unwrap();
    for (object, placement) in scene.objects.iter().zip(&atlas.objects) {
        assert_eq!(placement.uvs, ObjectUvs::Own);
        assert_eq!(placement.scale[0], placement.scale[1], "uniform scale");
        for t in object.triangles.clone() {
            for (k, v) in scene.triangles[t as usize].iter().enumerate() {
                let expected =
                    uvs[*v as usize] * Vec2::from(placement.scale) + Vec2::from(placement.offset);
                let got = atlas.uv1[t as usize][k];
                assert!(
                    (got - expected).abs().max_element() < 1e-6,
                    "{} triangle {t} corner {k}: {got} is not own × scale + offset {expected}",
                    object.name
                );
            }
        }
    }
    // The same texel density: world area per atlas area of the floor (16) and the wall (2).
    let density: Vec<f32> = scene
        .objects
        .iter()
        .map(|o| {
            let t = o.triangles.clone().map(|t| t as usize);
            let world: f32 = t.clone().map(|t| world_area(&scene, t)).sum();
            let uv: f32 = t.map(|t| uv_area(atlas.uv1[t])).sum();
            world / uv
        })
        .collect();
    eprintln!(
        "world area per atlas area: floor {:.2}, wall {:.2}; scales {:?}",
        density[0], density[1], atlas.objects
    );
    assert!(
        (density[0] / density[1] - 1.0).abs() < 0.1,
        "texel densities {density:?} differ"
    );

    // Baked (unshadowed: no tracer), stored and read back.
    let options = BakeOptions {
        order: 2,
        samples: 16,
        mode: Mode::Unshadowed,
        ..BakeOptions::default()
    };
    let bake = lightmap::bake(&scene, None, &options, atlas.clone(), &Silent).expect("bake");
    let valid = bake.texels.valid.iter().filter(|&&v| v).count();
    let mut object_of_texel = [0usize; 2];
    for (i, &t) in bake.texels.triangle.iter().enumerate() {
        if bake.texels.valid[i] {
            object_of_texel[usize::from(t >= scene.objects[1].triangles.start)] += 1;
        }
    }
    eprintln!(
        "baked texels: floor {}, wall {}",
        object_of_texel[0], object_of_texel[1]
    );
    assert!(
        object_of_texel.iter().all(|&n| n > 100),
        "{object_of_texel:?} of {valid}"
    );
    let file = CoefficientFile::from_lightmap_bake(&scene, &bake);
    let (bytes, _) = file.to_bytes();
    let read = CoefficientFile::from_bytes(&bytes).expect("reads back");
    let block = read.lightmap.as_ref().expect("a texel file");
    assert_eq!(block.source, AtlasSource::PerObject);
    assert_eq!(block.objects, atlas.objects, "placements read back");
    assert!(read.lightmap == file.lightmap && read.coefficients == file.coefficients);
    // An old reader's view: the atlas source is a code it refuses (2), and a cut section is
    // refused by this one.
    assert_eq!(u32::from_le_bytes(bytes[156..160].try_into().unwrap()), 2);
    let mut cut = bytes[..bytes.len() - 20].to_vec();
    let payload = u64::from_le_bytes(cut[72..80].try_into().unwrap()) - 20;
    cut[72..80].copy_from_slice(&payload.to_le_bytes());
    assert!(CoefficientFile::from_bytes(&cut).is_err());
}

/// An object whose UVs fold onto themselves (u > 0.75 mapped to 1.5 − u: with 6 columns of
/// cells, the last one lies over the fourth, 1/6 of the UV area over a union of 4/6) is warned about, naming it and the overlapped fraction, and unwrapped alone;
/// the clean floor keeps its own UVs; nothing is shared. `strict` refuses the scene instead,
/// naming the object. An object without lightmap UVs is unwrapped too.
#[test]
fn an_object_overlapping_itself_gets_a_warning_and_an_atlas_of_its_own() {
    let folded = grid_uvs(|u, v| Vec2::new(if u <= 0.75 { u } else { 1.5 - u }, v));
    let scene = floor_and_wall(grid_uvs(unit), folded);
    let uvs = scene.lightmap_uvs.clone().unwrap();
    let own = Atlas::from_vertex_uvs(&scene, &uvs, 96, 96).expect("atlas");
    let c = check(&scene, &own.uv1, 96, 96);
    eprintln!("check: {c:?}");
    assert!(c.objects[1].overlaps_itself() && !c.objects[0].overlaps_itself());
    let fraction = c.objects[1].overlap_fraction();
    assert!(
        (0.2..0.3).contains(&fraction),
        "a quarter of the wall's texels overlap: {fraction}"
    );

    let (atlas, _, notes) = from_scene_uvs(&scene, &uvs, 96, false).expect("packed");
    eprintln!("notes: {notes:#?}");
    let warning = notes
        .iter()
        .find(|n| n.starts_with("warning:"))
        .expect("a warning");
    assert!(
        warning.contains("'wall'") && warning.contains(&format!("{:.1} %", 100.0 * fraction)),
        "{warning}"
    );
    assert_eq!(atlas.source, AtlasSource::PerObject);
    assert_eq!(atlas.objects[0].uvs, ObjectUvs::Own);
    assert_eq!(atlas.objects[1].uvs, ObjectUvs::GeneratedOverlapping);
    assert_eq!(shared_texels(&scene, &atlas), 0);
    let after = check(&scene, &atlas.uv1, 96, 96);
    assert!(
        after.objects.iter().all(|o| o.self_overlapped == 0),
        "the generated atlas does not overlap itself: {after:?}"
    );
    // Every triangle of positive area is in the atlas.
    assert!(atlas.uv1.iter().all(|t| t.iter().all(|p| p.x >= 0.0)));

    let refused = from_scene_uvs(&scene, &uvs, 96, true).expect_err("strict refuses");
    let message = refused.to_string();
    assert!(
        message.contains("'wall'") && message.contains("--strict-uvs"),
        "{message}"
    );
    assert!(refused.is_bad_input(), "exit 3");

    // No lightmap UVs on the wall (a glTF primitive without TEXCOORD_1 reads as zeros).
    let zeros = vec![Vec2::ZERO; ((CELLS + 1) * (CELLS + 1)) as usize];
    let scene = floor_and_wall(grid_uvs(unit), zeros);
    let (atlas, _, notes) =
        from_scene_uvs(&scene, scene.lightmap_uvs.as_ref().unwrap(), 64, true).expect("packed");
    assert_eq!(atlas.objects[1].uvs, ObjectUvs::GeneratedMissing);
    assert!(
        notes
            .iter()
            .any(|n| n.contains("no lightmap UVs") && n.contains("'wall'"))
    );
    assert_eq!(shared_texels(&scene, &atlas), 0);
}

/// Scene UVs laid out as one atlas (the floor in the left half, the wall in the right) are
/// the atlas unchanged: the same atlas as before the check existed, hence the same file.
#[test]
fn clean_scene_uvs_stay_the_atlas() {
    let scene = floor_and_wall(
        grid_uvs(|u, v| Vec2::new(u * 0.49, v)),
        grid_uvs(|u, v| Vec2::new(0.51 + u * 0.49, v * 0.5)),
    );
    let uvs = scene.lightmap_uvs.clone().unwrap();
    let (atlas, c, notes) = from_scene_uvs(&scene, &uvs, 64, true).expect("atlas");
    assert!(c.is_clean() && notes.is_empty(), "{c:?} {notes:?}");
    assert_eq!(atlas, Atlas::from_vertex_uvs(&scene, &uvs, 64, 64).unwrap());
    assert_eq!(atlas.source, AtlasSource::SceneUvs);
    assert!(atlas.objects.is_empty());
}

/// A glTF mesh: name, positions, TEXCOORD_1 in glTF's convention, triangle indices.
type GltfMesh<'a> = (&'a str, Vec<Vec3>, Vec<Vec2>, Vec<u32>);

/// A `.glb` of `meshes` under `nodes` (glTF JSON).
fn glb(meshes: &[GltfMesh], nodes: serde_json::Value) -> Vec<u8> {
    use serde_json::json;
    let (mut bin, mut views, mut accessors, mut json_meshes) = (vec![], vec![], vec![], vec![]);
    let mut add = |bytes: Vec<u8>, count: usize, kind: &str, component: u32, bin: &mut Vec<u8>| {
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        bin.extend(bytes);
        accessors.push(json!({"bufferView": views.len() - 1, "count": count, "type": kind, "componentType": component}));
        if kind == "VEC3" {
            accessors.last_mut().unwrap()["min"] = json!([-10.0, -10.0, -10.0]);
            accessors.last_mut().unwrap()["max"] = json!([10.0, 10.0, 10.0]);
        }
        accessors.len() - 1
    };
    for (name, positions, uv1, indices) in meshes {
        let p = positions
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes);
        let p = add(p.collect(), positions.len(), "VEC3", 5126, &mut bin);
        let t = uv1
            .iter()
            .flat_map(|t| t.to_array())
            .flat_map(f32::to_le_bytes);
        let t = add(t.collect(), uv1.len(), "VEC2", 5126, &mut bin);
        let i = indices.iter().flat_map(|i| i.to_le_bytes());
        let i = add(i.collect(), indices.len(), "SCALAR", 5125, &mut bin);
        json_meshes.push(json!({"name": name, "primitives": [{"attributes": {"POSITION": p, "TEXCOORD_1": t}, "indices": i}]}));
    }
    let document = json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": nodes,
        "meshes": json_meshes, "accessors": accessors, "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}],
    });
    prt_tests::glb(&serde_json::to_vec(&document).unwrap(), &bin)
}

/// Positions, TEXCOORD_1 (glTF's v) and indices of a y-up grid with lightmap UVs in [0, 1].
fn gltf_grid(origin: Vec3, u: Vec3, v: Vec3) -> (Vec<Vec3>, Vec<Vec2>, Vec<u32>) {
    let g = grid("g", origin, u, v, CELLS);
    let uvs = grid_uvs(|u, v| Vec2::new(u, 1.0 - v));
    (
        g.positions,
        uvs,
        g.triangles.iter().flatten().copied().collect(),
    )
}

/// Blender's layout in a `.glb`: a node "Floor" (its mesh is "Plane") with a child node
/// without a name (mesh "Box"), each with TEXCOORD_1 on [0, 1]. The objects are named after
/// their nodes (the mesh where the node has no name); the bake packs them per object; the
/// exported `.glb` keeps the node names, its TEXCOORD_1 is each object's own TEXCOORD_1 ×
/// scale + offset in glTF's convention, and each node's extras give that scale and offset.
#[test]
fn gltf_objects_keep_their_node_names_and_placements_through_the_export() {
    use serde_json::json;
    let dir = tempfile::tempdir().unwrap();
    let (fp, ft, fi) = gltf_grid(Vec3::new(-2.0, 0.0, 2.0), Vec3::X * 4.0, Vec3::Z * -4.0);
    let (bp, bt, bi) = gltf_grid(Vec3::new(-1.0, 0.0, 0.0), Vec3::X * 2.0, Vec3::Y);
    let nodes = json!([{"name": "Floor", "mesh": 0, "children": [1]}, {"mesh": 1}]);
    let path = dir.path().join("scene.glb");
    let sources = [("Plane", fp, ft, fi), ("Box", bp, bt, bi)];
    std::fs::write(&path, glb(&sources, nodes)).unwrap();
    let scene = Scene::load(&path).expect("the glb");
    let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["Floor", "Box"], "node names, else mesh names");

    let uvs = scene.lightmap_uvs.clone().expect("TEXCOORD_1");
    let (atlas, _, _) = from_scene_uvs(&scene, &uvs, 64, false).expect("packed");
    assert_eq!(atlas.source, AtlasSource::PerObject);
    let options = BakeOptions {
        order: 2,
        samples: 16,
        mode: Mode::Unshadowed,
        ..BakeOptions::default()
    };
    let bake = lightmap::bake(&scene, None, &options, atlas.clone(), &Silent).expect("bake");
    let prt = dir.path().join("scene.prt");
    CoefficientFile::from_lightmap_bake(&scene, &bake)
        .write(&prt)
        .unwrap();
    let out = dir.path().join("out.glb");
    prt_baker::export::gltf::export_glb(&prt, &path, &out, None).expect("export");

    let bytes = std::fs::read(&out).unwrap();
    let length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&bytes[20..20 + length]).unwrap();
    let bin = &bytes[20 + length + 8..];
    let floats = |accessor: usize| -> Vec<f32> {
        let a = &doc["accessors"][accessor];
        let view = &doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        let start = view["byteOffset"].as_u64().unwrap_or(0) as usize
            + a["byteOffset"].as_u64().unwrap_or(0) as usize;
        let n = a["count"].as_u64().unwrap() as usize * if a["type"] == "VEC3" { 3 } else { 2 };
        (0..n)
            .map(|k| f32::from_le_bytes(bin[start + 4 * k..start + 4 * k + 4].try_into().unwrap()))
            .collect()
    };
    for (k, (name, positions, uv1, _)) in sources.iter().enumerate() {
        let node = &doc["nodes"][k];
        assert_eq!(node["name"], ["Floor", "Box"][k]);
        let so: Vec<f32> = node["extras"]["prt_lightmap_scale_offset"]
            .as_array()
            .unwrap_or_else(|| panic!("{name}: no placement in {node}"))
            .iter()
            .map(|x| x.as_f64().unwrap() as f32)
            .collect();
        let p = atlas.objects[k];
        assert_eq!(so[..3], [p.scale[0], p.scale[1], p.offset[0]]);
        assert!((so[3] - (1.0 - p.scale[1] - p.offset[1])).abs() < 1e-6);
        let attributes =
            &doc["meshes"][node["mesh"].as_u64().unwrap() as usize]["primitives"][0]["attributes"];
        let written_p = floats(attributes["POSITION"].as_u64().unwrap() as usize);
        let written_t = floats(attributes["TEXCOORD_1"].as_u64().unwrap() as usize);
        for (q, t) in written_p.chunks(3).zip(written_t.chunks(2)) {
            let source = positions
                .iter()
                .position(|s| (*s - Vec3::from_slice(q)).length() < 1e-5)
                .expect("a source vertex");
            let expected = uv1[source] * Vec2::new(so[0], so[1]) + Vec2::new(so[2], so[3]);
            assert!(
                (Vec2::from_slice(t) - expected).abs().max_element() < 1e-5,
                "{name}: TEXCOORD_1 {t:?} is not own {} × scale + offset = {expected}",
                uv1[source]
            );
        }
    }
}

/// The node hierarchy survives the export: groups without meshes are written as
/// group nodes, each object's node keeps its place under its parent, and nodes with nothing
/// below them are left out. Transforms are identities: the geometry is in world space.
#[test]
fn the_gltf_node_hierarchy_survives_the_export() {
    use serde_json::json;
    let dir = tempfile::tempdir().unwrap();
    let (fp, ft, fi) = gltf_grid(Vec3::new(-2.0, 0.0, 2.0), Vec3::X * 4.0, Vec3::Z * -4.0);
    let (bp, bt, bi) = gltf_grid(Vec3::new(-1.0, 0.0, 0.0), Vec3::X * 2.0, Vec3::Y);
    // Room ─ Floor (mesh 0)
    //      ─ Lamp ─ Shade (mesh 1)
    //             ─ Bulb (no mesh: left out)
    let nodes = json!([
        {"name": "Room", "children": [1, 2], "translation": [0.0, 1.0, 0.0]},
        {"name": "Floor", "mesh": 0},
        {"name": "Lamp", "children": [3, 4]},
        {"name": "Shade", "mesh": 1},
        {"name": "Bulb"},
    ]);
    let path = dir.path().join("room.glb");
    let sources = [("Plane", fp, ft, fi), ("Box", bp, bt, bi)];
    std::fs::write(&path, glb(&sources, nodes)).unwrap();
    let scene = Scene::load(&path).expect("the glb");
    let contents = prt_baker::export::gltf::Contents {
        file: None,
        light: None,
        up: scene.up,
    };
    let (bytes, _) = prt_baker::export::gltf::glb_bytes(&scene, &contents).expect("export");
    let length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&bytes[20..20 + length]).unwrap();
    let names: Vec<&str> = doc["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n["name"].as_str().unwrap())
        .collect();
    // Objects first (their indices are the objects'), then the groups.
    assert_eq!(names, ["Floor", "Shade", "Room", "Lamp"]);
    assert_eq!(doc["scenes"][0]["nodes"], json!([2]));
    assert_eq!(doc["nodes"][2]["children"], json!([0, 3]));
    assert_eq!(doc["nodes"][3]["children"], json!([1]));
    assert!(doc["nodes"][0].get("children").is_none());
    // World space: no node carries a transform.
    for node in doc["nodes"].as_array().unwrap() {
        for key in ["translation", "rotation", "scale", "matrix"] {
            assert!(node.get(key).is_none(), "{node}");
        }
    }
    // The exported file reads back as the same objects.
    let again = dir.path().join("again.glb");
    std::fs::write(&again, &bytes).unwrap();
    let reread = Scene::load(&again).expect("the export");
    let names: Vec<&str> = reread.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["Floor", "Shade"]);
    assert_eq!(reread.positions.len(), scene.positions.len());
}
