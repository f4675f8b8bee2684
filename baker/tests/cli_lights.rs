//! End-to-end tests of `prt-bake light` and `prt-bake relight` (conventions in `common/`): the
//! JSON and PLY they write, and the errors a user sees for a bad rig or a mismatched bake.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use prt_baker::export::relight::{display_colour, vertex_radiance};
use prt_baker::light::Rig;
use prt_baker::math::sh;
use prt_baker::{CoefficientFile, Scene};

/// A 1×1 floor facing +z, as two triangles: 4 vertices.
const FLOOR: &str = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n";
const FLOOR_VERTICES: usize = 4;
const FLOOR_TRIANGLES: usize = 2;

/// An example rig with every directional key, verbatim.
const DIRECTIONAL_RIG: &str = r#"[[light]]
kind = "directional"            # constant | directional | sun | sphere | hemisphere | environment
direction = [0.3, 0.4, 0.866]   # world-space vector pointing toward the light
color = [1.0, 0.5, 0.25]        # linear RGB
intensity = 2.0                 # directional/sun: irradiance E on a surface facing the light;
                                # constant/hemisphere: radiance L
"#;

/// Runs `prt-bake relight SCENE out/floor.prt --lights RIG -o out/relit.ply` and `extra`.
fn relight(s: &Scratch, scene: &str, rig: &str, extra: &[&str]) -> Run {
    let mut args = vec![
        "relight",
        scene,
        "out/floor.prt",
        "--lights",
        rig,
        "-o",
        "out/relit.ply",
    ];
    args.extend(extra);
    s.run(&args)
}

fn read_json(s: &Scratch, name: &str) -> serde_json::Value {
    serde_json::from_slice(&s.read(name)).expect("the output is JSON")
}

/// The coefficients of a `prt-bake light` JSON as three f64 vectors.
fn channels(json: &serde_json::Value) -> Vec<Vec<f64>> {
    json["coefficients"]
        .as_array()
        .expect("coefficients is an array")
        .iter()
        .map(|c| {
            c.as_array()
                .expect("a channel is an array")
                .iter()
                .map(|x| x.as_f64().expect("a number"))
                .collect()
        })
        .collect()
}

/// A directional light's JSON is intensity · colour · y(direction), by the thesis's formulas.
#[test]
fn light_writes_the_issue_rig_as_json() {
    let s = Scratch::new();
    s.write("rig.toml", DIRECTIONAL_RIG);
    let run = s
        .run(&["light", "rig.toml", "--order", "5", "-o", "out/light.json"])
        .success();
    assert_eq!(run.stdout, "");
    s.assert_out_holds(&["light.json"]);
    let json = read_json(&s, "out/light.json");
    assert_eq!(json["order"], 5);
    assert!(
        json["convention"]
            .as_str()
            .unwrap()
            .contains("Condon-Shortley"),
        "{}",
        json["convention"]
    );
    let coefficients = channels(&json);
    assert_eq!(coefficients.len(), 3);
    let (theta, phi) = sh::angles(DVec3::new(0.3, 0.4, 0.866));
    for (channel, colour) in coefficients.iter().zip([1.0, 0.5, 0.25]) {
        assert_eq!(channel.len(), 25);
        for (j, c) in channel.iter().enumerate() {
            let (l, m) = sh::band_and_m(j);
            let want = 2.0 * colour * sh::eval_slow(l, m, theta, phi);
            // The thesis's trigonometric path and the recurrence differ by rounding only.
            assert!((c - want).abs() < 1e-12, "{j}: {c} vs {want}");
        }
    }
}

/// `light --up y` turns the rig into a y-up scene's frame, (x, y, z) ↦ (x, z, −y), as
/// `relight` and the viewer do, so its JSON can be dotted with a y-up bake's transfer.
#[test]
fn light_turns_the_rig_to_a_y_up_scene() {
    let s = Scratch::new();
    s.write("rig.toml", DIRECTIONAL_RIG);
    s.run(&[
        "light",
        "rig.toml",
        "--order",
        "3",
        "--up",
        "y",
        "-o",
        "out/l.json",
    ])
    .success();
    let coefficients = channels(&read_json(&s, "out/l.json"));
    let (theta, phi) = sh::angles(DVec3::new(0.3, 0.866, -0.4));
    for (channel, colour) in coefficients.iter().zip([1.0, 0.5, 0.25]) {
        for (j, c) in channel.iter().enumerate() {
            let (l, m) = sh::band_and_m(j);
            let want = 2.0 * colour * sh::eval_slow(l, m, theta, phi);
            assert!((c - want).abs() < 1e-9, "{j}: {c} vs {want}");
        }
    }
}

#[test]
fn light_sums_a_constant_sky_into_the_dc_term() {
    let s = Scratch::new();
    s.write(
        "rig.toml",
        "[[light]]\nkind = \"constant\"\ncolor = [0.5, 1, 2]\nintensity = 3\n\n[[light]]\nkind = \"constant\"\n",
    );
    s.run(&["light", "rig.toml", "--order", "2", "-o", "out/l.json"])
        .success();
    let coefficients = channels(&read_json(&s, "out/l.json"));
    let root_4pi = (4.0 * std::f64::consts::PI).sqrt();
    for (channel, radiance) in coefficients.iter().zip([2.5, 4.0, 7.0]) {
        assert!((channel[0] - radiance * root_4pi).abs() < 1e-12);
        assert!(channel[1..].iter().all(|c| *c == 0.0), "{channel:?}");
    }
}

#[test]
fn rig_errors_name_the_file_line_and_key() {
    let s = Scratch::new();
    s.write(
        "typo.toml",
        "[[light]]\nkind = \"sun\"\ndirection = [0, 0, 1]\n\n[[light]]\nkind = \"constant\"\nintensty = 2\n",
    );
    s.write(
        "type.toml",
        "[[light]]\nkind = \"directional\"\ndirection = \"up\"\n",
    );
    s.write(
        "map.toml",
        "# sky\n[[light]]\nkind = \"environment\"\npath = \"nothere.exr\"\n",
    );
    s.write("floor.obj", FLOOR);
    s.bake("floor.obj", "floor.prt", &["--mode", "unshadowed"]);
    for (rig, needles) in [
        (
            "typo.toml",
            &["typo.toml:7: ", "light 2, key `intensty`", "unknown key"][..],
        ),
        (
            "type.toml",
            &["type.toml:3: ", "key `direction`", "found a string"],
        ),
        ("map.toml", &["map.toml:4: ", "key `path`", "nothere.exr"]),
        ("nothere.toml", &["nothere.toml: ", "No such file"]),
    ] {
        s.run(&["light", rig, "-o", "out/l.json"])
            .fails_with_bad_input(needles);
        relight(&s, "floor.obj", rig, &[]).fails_with_bad_input(needles);
    }
    s.assert_out_holds(&["floor.prt"]);
}

#[test]
fn bad_light_options_are_refused() {
    let s = Scratch::new();
    s.write("rig.toml", DIRECTIONAL_RIG);
    s.run(&["light", "rig.toml", "--order", "0", "-o", "out/l.json"])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["--order 0 is outside 1..="]);
    s.run(&["light", "rig.toml", "-o", "nothere/l.json"])
        .fails_with_bad_input(&["nothere/l.json: ", "folder nothere does not exist"]);
    s.assert_out_holds(&[]);
}

/// A binary little-endian PLY as `relight` writes it.
struct Ply {
    header: String,
    positions: Vec<[f32; 3]>,
    colours: Vec<[u8; 3]>,
    radiance: Vec<[f32; 3]>,
    faces: Vec<[u32; 3]>,
}

fn parse_ply(bytes: &[u8]) -> Ply {
    let end = b"end_header\n";
    let header_len = bytes
        .windows(end.len())
        .position(|w| w == end)
        .expect("end_header")
        + end.len();
    let header = String::from_utf8(bytes[..header_len].to_vec()).unwrap();
    let count = |element: &str| -> usize {
        let prefix = format!("element {element} ");
        header
            .lines()
            .find_map(|l| l.strip_prefix(&prefix))
            .unwrap_or_else(|| panic!("no {element} count in {header}"))
            .parse()
            .unwrap()
    };
    let (v, f) = (count("vertex"), count("face"));
    let mut at = header_len;
    let mut take = |n: usize| {
        let slice = &bytes[at..at + n];
        at += n;
        slice
    };
    let f32s = |b: &[u8]| -> [f32; 3] {
        std::array::from_fn(|i| f32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap()))
    };
    let mut ply = Ply {
        header: header.clone(),
        positions: Vec::new(),
        colours: Vec::new(),
        radiance: Vec::new(),
        faces: Vec::new(),
    };
    for _ in 0..v {
        ply.positions.push(f32s(take(12)));
        take(12); // normal
        ply.colours.push(take(3).try_into().unwrap());
        ply.radiance.push(f32s(take(12)));
    }
    for _ in 0..f {
        assert_eq!(take(1), [3], "faces are triangles");
        let b = take(12);
        ply.faces.push(std::array::from_fn(|i| {
            u32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap())
        }));
    }
    assert_eq!(at, bytes.len(), "bytes after the last face");
    ply
}

#[test]
fn relight_writes_a_ply_of_the_library_radiance() {
    let s = Scratch::new();
    s.write("floor.obj", FLOOR);
    s.write("rig.toml", DIRECTIONAL_RIG);
    s.bake("floor.obj", "floor.prt", &["--order", "3"]);
    let run = relight(&s, "floor.obj", "rig.toml", &["--exposure", "-0.5"]).success();
    assert!(
        run.stdout.starts_with(&format!(
            "relit {FLOOR_VERTICES} vertices with 1 light(s) at order 3"
        )),
        "{}",
        run.stdout
    );
    s.assert_out_holds(&["floor.prt", "relit.ply"]);

    let ply = parse_ply(&s.read("out/relit.ply"));
    assert!(
        ply.header
            .starts_with("ply\nformat binary_little_endian 1.0\n")
    );
    for property in [
        "property float x\n",
        "property float nz\n",
        "property uchar red\n",
        "property float radiance_b\n",
        "property list uchar uint vertex_indices\n",
    ] {
        assert!(
            ply.header.contains(property),
            "{property} missing:\n{}",
            ply.header
        );
    }
    let scene = Scene::load(&s.path("floor.obj")).unwrap();
    let file = CoefficientFile::read(&s.path("out/floor.prt")).unwrap();
    let light = Rig::load(&s.path("rig.toml")).unwrap().project(3);
    let want = vertex_radiance(&file, &scene.vertex_albedo(), &light);
    assert_eq!(ply.radiance, want);
    assert_eq!(
        ply.positions,
        scene
            .positions
            .iter()
            .map(|p| p.to_array())
            .collect::<Vec<_>>()
    );
    assert_eq!(ply.faces.len(), FLOOR_TRIANGLES);
    assert_eq!(ply.faces, scene.triangles);
    for (colour, radiance) in ply.colours.iter().zip(&want) {
        assert_eq!(*colour, display_colour(*radiance, -0.5));
    }
    // Lit from above through a floor facing up: every channel bright, red the brightest.
    let albedo = Vec3::splat(0.8);
    for r in &ply.radiance {
        assert!(r[0] > r[1] && r[1] > r[2] && r[2] > 0.0, "{r:?}");
        assert!(r[0] < albedo.x * 2.0, "{r:?}");
    }
}

#[test]
fn relight_refuses_a_bake_of_another_scene() {
    let s = Scratch::new();
    s.write("floor.obj", FLOOR);
    s.write("moved.obj", FLOOR.replace("v 1 1 0", "v 1 2 0"));
    s.write("rig.toml", DIRECTIONAL_RIG);
    s.bake("floor.obj", "floor.prt", &["--mode", "unshadowed"]);
    relight(&s, "moved.obj", "rig.toml", &[])
        .fails_with_bad_input(&["out/floor.prt: ", "baked for another scene: fingerprint"]);
    relight(&s, "floor.obj", "rig.toml", &["--exposure", "nan"])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["--exposure must be finite"]);
    s.assert_out_holds(&["floor.prt"]);
}
