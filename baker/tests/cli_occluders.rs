//! End-to-end tests of moving occluders (docs/guides/occluders.md): `bake OBJ --occluder`
//! writes a sphere set (32 bytes for a ball), and `relight … --occluder OCC --at X,Y,Z …`
//! darkens a vertex bake and a lightmap bake near the occluders and leaves receivers out of
//! their reach as `relight` without them; the usage errors and a damaged occluder file.

mod common;

use common::{EXIT_BAD_COMMAND_LINE, EXIT_BAD_INPUT, Scratch};

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);
const RIG: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../viewer/src/default-rig.toml"
);

/// A UV sphere of radius 0.2 about the origin, as OBJ text.
fn ball_obj() -> String {
    let (rings, segments) = (12, 24);
    let mut text = String::from("o ball\n");
    for i in 0..=rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            let (x, y, z) = (
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            text.push_str(&format!("v {} {} {}\n", 0.2 * x, 0.2 * y, 0.2 * z));
        }
    }
    let at = |i: usize, j: usize| i * segments + j % segments + 1;
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            text.push_str(&format!("f {a} {b} {c}\nf {a} {c} {d}\n"));
        }
    }
    text
}

fn ball(s: &Scratch) {
    s.write("ball.obj", ball_obj());
    let run = s
        .run(&["bake", "ball.obj", "--occluder", "-o", "out/ball.occ"])
        .success();
    assert!(
        run.stdout.contains("fitted 1 sphere(s)") && run.stdout.contains("(32 bytes)"),
        "{}",
        run.stdout
    );
    let file = prt_baker::formats::occluder_file::OccluderFile::from_bytes(&s.read("out/ball.occ"))
        .unwrap();
    let sphere = file.spheres[0];
    assert!(
        sphere.centre.length() < 1e-4 && (sphere.radius - 0.2).abs() < 1e-4,
        "{sphere:?}"
    );
}

#[test]
fn two_occluders_darken_a_vertex_bake_near_them_only() {
    let s = Scratch::new();
    ball(&s);
    s.bake(CORNELL, "room.prt", &["--samples", "256"]);
    s.run(&[
        "relight",
        CORNELL,
        "out/room.prt",
        "--lights",
        RIG,
        "-o",
        "out/plain.ply",
    ])
    .success();
    let at = ["-0.5,-0.55,0.22", "0.55,0.5,0.22"];
    let run = s
        .run(&[
            "relight",
            CORNELL,
            "out/room.prt",
            "--lights",
            RIG,
            "--occluder",
            "out/ball.occ",
            "--at",
            at[0],
            "--occluder",
            "out/ball.occ",
            "--at",
            at[1],
            "--turn",
            "1,0,0,90",
            "-o",
            "out/shadowed.ply",
        ])
        .success();
    assert!(
        run.stdout.contains("through 2 occluder(s)"),
        "{}",
        run.stdout
    );
    let plain = s.ply_radiance("out/plain.ply");
    let shadowed = s.ply_radiance("out/shadowed.ply");
    let scene = prt_baker::Scene::load(std::path::Path::new(CORNELL)).unwrap();
    let centres = [
        glam::Vec3::new(-0.5, -0.55, 0.22),
        glam::Vec3::new(0.55, 0.5, 0.22),
    ];
    let (mut near, mut darker) = (0, 0.0f32);
    for (v, p) in scene.positions.iter().enumerate() {
        let distance = centres
            .iter()
            .map(|c| c.distance(*p))
            .fold(f32::MAX, f32::min);
        if distance > 10.0 * 0.2 + 1e-3 {
            assert_eq!(plain[v], shadowed[v], "vertex {v} out of reach changed");
        } else if distance < 0.6 && p.z < 1e-3 {
            near += 1;
            darker += plain[v][1] - shadowed[v][1];
        }
    }
    assert!(
        near > 100 && darker / near as f32 > 0.01,
        "{near} floor vertices near, mean darkening {}",
        darker / near as f32
    );
}

#[test]
fn an_occluder_darkens_a_lightmap_bake() {
    let s = Scratch::new();
    ball(&s);
    s.bake(CORNELL, "lm.prt", &["--lightmap", "64", "--samples", "64"]);
    s.run(&[
        "relight",
        CORNELL,
        "out/lm.prt",
        "--lights",
        RIG,
        "-o",
        "out/plain.png",
    ])
    .success();
    let run = s
        .run(&[
            "relight",
            CORNELL,
            "out/lm.prt",
            "--lights",
            RIG,
            "--occluder",
            "out/ball.occ",
            "--at",
            "-0.5,-0.55,0.22",
            "-o",
            "out/shadowed.png",
        ])
        .success();
    assert!(
        run.stdout.contains("texels") && run.stdout.contains("1 occluder(s)"),
        "{}",
        run.stdout
    );
    let plain = image::load_from_memory(&s.read("out/plain.png"))
        .unwrap()
        .to_rgb8();
    let shadowed = image::load_from_memory(&s.read("out/shadowed.png"))
        .unwrap()
        .to_rgb8();
    // Order-4 SH rings: where the ball blocks a negative lobe of the projected sun a texel
    // gains a little, as the bake with the ball in place does (tests/occluder_oracles.rs).
    let (mut darker, mut brighter) = (0, 0);
    for (a, b) in plain.pixels().zip(shadowed.pixels()) {
        match a[1].cmp(&b[1]) {
            std::cmp::Ordering::Greater if a[1] - b[1] > 8 => darker += 1,
            std::cmp::Ordering::Less if b[1] - a[1] > 8 => brighter += 1,
            _ => {}
        }
    }
    assert!(
        darker > 40 && brighter * 4 < darker,
        "{darker} texels darker, {brighter} brighter"
    );
}

#[test]
fn occluder_usage_errors_and_a_damaged_file() {
    let s = Scratch::new();
    ball(&s);
    s.bake(CORNELL, "room.prt", &["--samples", "16"]);
    let base = [
        "relight",
        CORNELL,
        "out/room.prt",
        "--lights",
        RIG,
        "-o",
        "out/x.ply",
    ];
    let with = |extra: &[&str]| {
        let mut args = base.to_vec();
        args.extend(extra);
        s.run(&args)
    };
    with(&[
        "--occluder",
        "out/ball.occ",
        "--occluder",
        "out/ball.occ",
        "--at",
        "0,0,1",
    ])
    .fails_with(EXIT_BAD_COMMAND_LINE, &["2 --occluder need 2 --at"]);
    let group = ["--occluder", "out/ball.occ", "--at", "0,0,1"];
    let turn = ["--turn", "0,0,1,30"];
    with(&[&turn[..], &group[..]].concat()).fails_with(
        EXIT_BAD_COMMAND_LINE,
        &["each --turn follows its own --occluder"],
    );
    with(&[&group[..], &turn[..], &turn[..]].concat())
        .fails_with(EXIT_BAD_COMMAND_LINE, &["at most one a group"]);
    with(&["--at", "0,0,1"]).fails_with(EXIT_BAD_COMMAND_LINE, &["give --probes or --occluder"]);
    s.write("bad.occ", b"\x89PRTOCC\n\x01\0\0\0\x01\0\0\0short");
    with(&["--occluder", "bad.occ", "--at", "0,0,1"])
        .fails_with(EXIT_BAD_INPUT, &["bad.occ", "spheres make 32"]);
    // prepare-lightmap shares the bake's options: an occluder is not a texel bake's.
    s.run(&["prepare-lightmap", CORNELL, "--occluder", "-o", "out/p.occ"])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["not prepare-lightmap"]);
    s.run(&["bake", CORNELL, "--spheres", "3", "-o", "out/s.prt"])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["--occluder"]);
    s.assert_out_holds(&["ball.occ", "room.prt"]);
}
