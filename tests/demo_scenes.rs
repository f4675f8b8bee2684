//! The committed demo scenes are exactly what `gen-scenes` writes, and have the documented
//! sizes: the thesis's torus of 10,800 unique vertices on planes of 2,700.

use std::path::Path;

use glam::Vec3;
use prt_baker::Scene;

fn scenes_dir() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes"))
}

#[test]
fn committed_scene_files_equal_the_generator_output() {
    let dir = tempfile::tempdir().expect("temporary folder");
    prt_scenes::write_all(dir.path()).expect("generate scenes");
    for scene in ["torus", "tube", "cornell"] {
        let generated = dir.path().join(scene);
        let mut names: Vec<_> = std::fs::read_dir(&generated)
            .expect("generated folder")
            .map(|e| e.expect("entry").file_name())
            .collect();
        names.sort();
        assert!(!names.is_empty());
        for name in names {
            let fresh = std::fs::read(generated.join(&name)).expect("generated file");
            let committed =
                std::fs::read(scenes_dir().join(scene).join(&name)).unwrap_or_else(|err| {
                    panic!(
                        "scenes/{scene}/{} is not committed: {err}",
                        name.to_string_lossy()
                    )
                });
            assert!(
                fresh == committed,
                "scenes/{scene}/{} differs from the generator output: run `cargo run -p prt-scenes`",
                name.to_string_lossy()
            );
        }
    }
}

#[test]
fn torus_scene_has_the_theses_vertex_counts() {
    let scene = Scene::load(&scenes_dir().join("torus/torus.scene")).expect("torus scene loads");
    let count = |name: &str| {
        let o = scene
            .objects
            .iter()
            .find(|o| o.name == name)
            .unwrap_or_else(|| panic!("object {name}"));
        o.vertices.len()
    };
    assert_eq!(count("torus"), 10_800);
    assert_eq!(
        count("floor") + count("back_wall") + count("side_wall"),
        2_700
    );
    assert_eq!(scene.vertex_count(), 13_500);
    // Textured through the scene file: the torus's albedo varies, the planes show a checker.
    assert_eq!(scene.textures.len(), 2);
    let albedo = scene.vertex_albedo();
    let torus = &albedo[..10_800];
    let (lo, hi) = torus.iter().fold((f32::MAX, f32::MIN), |(lo, hi), a| {
        (lo.min(a.x), hi.max(a.x))
    });
    assert!(
        hi - lo > 0.1,
        "torus texture not applied: red in [{lo}, {hi}]"
    );
}

#[test]
fn cornell_scene_has_coloured_walls() {
    let scene =
        Scene::load(&scenes_dir().join("cornell/cornell.scene")).expect("cornell scene loads");
    let kd = |name: &str| {
        scene
            .materials
            .iter()
            .find(|m| m.name == name)
            .map(|m| m.kd)
            .expect("material")
    };
    assert!(kd("red").x > 5.0 * kd("red").y);
    assert!(kd("green").y > 2.0 * kd("green").x);
    let walls = ["floor", "back_wall", "left_wall", "right_wall"];
    for wall in walls {
        let o = scene.objects.iter().find(|o| o.name == wall).expect("wall");
        assert_eq!(o.vertices.len(), 24 * 24, "{wall}");
    }
    // Every wall faces the inside of the room (x and y in [-1, 1], floor at z = 0).
    let inward = [
        ("floor", Vec3::Z),
        ("back_wall", -Vec3::Y),
        ("left_wall", Vec3::X),
        ("right_wall", -Vec3::X),
    ];
    for (wall, normal) in inward {
        let o = scene.objects.iter().find(|o| o.name == wall).expect("wall");
        for v in o.vertices.clone() {
            assert_eq!(scene.normals[v as usize], normal, "{wall} vertex {v}");
        }
    }
}
