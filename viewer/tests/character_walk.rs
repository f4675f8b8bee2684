//! `prt-view ROOM ROOM.prt --probes PROBES.prt --character walker.glb --character-ldprt
//! walker.ldprt --pose walk@T`: the bpy-made character (scenes/cornell/walker.glb) walking
//! across the Cornell room, lit by the room's probes at its posed position and self-shadowed
//! by its LDPRT lobes, against `prt-bake relight walker.glb walker.ldprt --pose walk@T
//! --probes PROBES.prt`'s PLY at three times of the walk (docs/guides/characters.md).
//!
//! The reference draws the same room bake with, in the character's place, relight's posed
//! vertices (turned to z-up) carrying relight's radiance: a rigid mover (the renderer's own
//! mover pipeline, tested by tests/probe_scene.rs) whose band-0-only transfer
//! r / (albedo · L_in,00) gives back exactly r. The viewer's image differs from it only by
//! its own choice of pose for the time, its posing, the probe light at its position and its
//! f32 sums. Compared over the character's pixels (those where either image differs from
//! the room drawn alone).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::Vec3;
use prt_baker::bake::ldprt::fit_bake;
use prt_baker::bake::probes::{self, ProbeSpec};
use prt_baker::export::relight_ldprt_probes::{CharacterPlacement, relight_ldprt_probes};
use prt_baker::scene::Pose;
use prt_baker::support::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer};
use prt_baker::{BakeOptions, CoefficientFile, Mode, Scene};
use prt_viewer::lights::Lights;
use prt_viewer::moving::{Mover, Probes};
use prt_viewer::{Bake, Camera, FrameInputs, Renderer, View};

const SIZE: (u32, u32) = (320, 300);
const ORDER: usize = 4;
const TIMES: [f32; 3] = [0.5, 2.0, 3.5];
const CAMERA: &str = "0,-2.6,0.8,90,-8";
/// At least this fraction of the character's pixels must be within [`CODES`] of relight's.
const WITHIN: f64 = 0.99;
const CODES: u8 = 2;
/// A sun through the open front and a sky.
const RIG: &str = common::ROOM_RIG;

fn walker() -> PathBuf {
    common::workspace().join("scenes/cornell/walker.glb")
}

fn room() -> PathBuf {
    common::workspace().join("scenes/cornell/cornell.scene")
}

/// The files `prt-view` reads: the room's interreflected vertex bake, its 4 × 4 × 4 probes
/// (256 rays each) and the walker's rest-pose LDPRT bake (3 lobes, 64 rays), all order 4.
struct Files {
    room: PathBuf,
    probes: PathBuf,
    ldprt: PathBuf,
    rig: PathBuf,
}

fn bake_files(folder: &Path) -> (Files, Bake) {
    let scene = Scene::load(&room()).unwrap();
    let tracer = EmbreeTracer::new(&scene, EmbreeOptions::default()).unwrap();
    let options = |samples| BakeOptions {
        order: ORDER,
        samples,
        mode: Mode::Interreflected,
        bounces: 1,
        seed: 1,
        ..BakeOptions::default()
    };
    let transfer = prt_baker::bake(&scene, Some(&tracer), &options(64), &Silent).unwrap();
    let mut room_file = CoefficientFile::from_bake(&scene, &transfer);
    let files = Files {
        room: folder.join("room.prt"),
        probes: folder.join("probes.prt"),
        ldprt: folder.join("walker.ldprt"),
        rig: folder.join("rig.toml"),
    };
    room_file.write(&files.room).unwrap();
    let block = ProbeSpec::parse("grid:4,4,4")
        .unwrap()
        .probes(&scene)
        .unwrap();
    let probe_transfer = probes::bake(
        &scene,
        Some(&tracer),
        &options(256),
        &block.positions,
        &Silent,
    )
    .unwrap();
    CoefficientFile::from_probe_bake(&scene, &probe_transfer, Some(&tracer), block)
        .write(&files.probes)
        .unwrap();
    let character = Scene::load_posed(&walker(), None, &Pose::Rest).unwrap().0;
    let tracer = EmbreeTracer::new(&character, EmbreeOptions::default()).unwrap();
    let shadowed = BakeOptions {
        mode: Mode::Shadowed,
        bounces: 0,
        ..options(64)
    };
    let t = prt_baker::bake(&character, Some(&tracer), &shadowed, &Silent).unwrap();
    let mut ldprt = fit_bake(&character, &t, 3).unwrap();
    ldprt.pose = Some("rest".into());
    std::fs::write(&files.ldprt, ldprt.to_bytes()).unwrap();
    std::fs::write(&files.rig, RIG).unwrap();
    let bake = Bake::new(scene, room_file, &files.room).unwrap();
    (files, bake)
}

fn inputs(files: &Files, bake: &Bake) -> FrameInputs {
    let lights = Lights::load(Some(&files.rig), ORDER)
        .unwrap()
        .for_up(bake.up());
    let camera = Camera::parse(CAMERA, 1.0).unwrap();
    FrameInputs::from_view(&View::new(camera, lights), None)
}

/// The room drawn with relight's character at `pose` in it (or alone), probes hidden.
fn reference(
    gpu: &prt_viewer::Gpu,
    (files, bake): (&Files, &Bake),
    pose: Option<&Pose>,
    folder: &Path,
) -> image::RgbaImage {
    let inputs = inputs(files, bake);
    let probes = Probes::load(&files.probes).unwrap();
    let mut renderer = Renderer::new(
        &gpu.device,
        &gpu.queue,
        bake,
        prt_viewer::offscreen::FORMAT,
        SIZE,
    )
    .unwrap();
    let mover = pose.map(|pose| relit_mover(files, &probes, pose, &inputs, folder));
    renderer
        .set_probe_scene(&gpu.device, probes, mover)
        .unwrap();
    renderer.probe_scene_mut().unwrap().show_probes = false;
    prt_viewer::offscreen::render_image(&gpu.device, &gpu.queue, &mut renderer, &inputs).unwrap()
}

/// relight's posed, lit character as a rigid mover standing at the origin whose band-0
/// transfer reproduces relight's radiance under the probes' light there.
fn relit_mover(
    files: &Files,
    probes: &Probes,
    pose: &Pose,
    inputs: &FrameInputs,
    folder: &Path,
) -> Mover {
    let ply = folder.join(format!("{pose}.ply"));
    let placement = CharacterPlacement {
        probes: &files.probes,
        position: None,
    };
    relight_ldprt_probes(
        (&walker(), pose),
        (&files.ldprt, &files.rig),
        &placement,
        &ply,
        0.0,
    )
    .unwrap();
    let relit = common::read_ply(&ply);
    let mut scene = Scene::load_posed(&walker(), None, pose).unwrap().0;
    assert_eq!(relit.len(), scene.vertex_count());
    for (p, (q, _)) in scene.positions.iter_mut().zip(&relit) {
        assert!(p.distance(*q) < 1e-5, "relight's PLY holds the posed mesh");
        *p = *q;
    }
    let up = scene.up;
    prt_viewer::bake::turn_to_z_up(&mut scene, up);
    scene.up = prt_baker::scene::Up::Z;
    let l00 = probes
        .field()
        .incident(Vec3::ZERO, &inputs.prt_light, true)
        .rgb
        .map(|c| c[0]);
    let file = common::band0_file(&scene, &relit, l00, ORDER);
    Mover::new(scene, file, vec![Vec3::ZERO], 0.0, Path::new("relight.ply")).unwrap()
}

/// `prt-view`'s headless screenshot of the room with the character at `pose`.
fn viewer(files: &Files, pose: &Pose, folder: &Path) -> image::RgbaImage {
    let png = folder.join(format!("{pose}.png"));
    let out = Command::new(env!("CARGO_BIN_EXE_prt-view"))
        .arg(room())
        .arg(&files.room)
        .arg("--probes")
        .arg(&files.probes)
        .arg("--hide-probes")
        .arg("--character")
        .arg(walker())
        .arg("--character-ldprt")
        .arg(&files.ldprt)
        .args(["--pose", &pose.to_string(), "--lights"])
        .arg(&files.rig)
        .args(["--camera", CAMERA])
        .args(["--size", &format!("{}x{}", SIZE.0, SIZE.1)])
        .args(["--headless", "--screenshot"])
        .arg(&png)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    image::open(&png).unwrap().to_rgba8()
}

/// Over the pixels where `a` or `b` differs from `room` (the character's): the fraction
/// within [`CODES`] of each other, and how many.
fn character_within(
    a: &image::RgbaImage,
    b: &image::RgbaImage,
    room: &image::RgbaImage,
) -> (f64, usize) {
    let (mut count, mut close) = (0usize, 0usize);
    for ((p, q), r) in a.pixels().zip(b.pixels()).zip(room.pixels()) {
        if p == r && q == r {
            continue;
        }
        count += 1;
        close += usize::from((0..3).all(|c| p[c].abs_diff(q[c]) <= CODES));
    }
    (close as f64 / count.max(1) as f64, count)
}

#[test]
fn prt_view_walks_the_character_through_the_probes_as_relight_lights_it() {
    let Some(gpu) = common::gpu() else { return };
    let folder = tempfile::tempdir().unwrap();
    let (files, bake) = bake_files(folder.path());
    let alone = reference(&gpu, (&files, &bake), None, folder.path());
    let mut shots = Vec::new();
    for t in TIMES {
        let pose: Pose = format!("walk@{t}").parse().unwrap();
        let want = reference(&gpu, (&files, &bake), Some(&pose), folder.path());
        let got = viewer(&files, &pose, folder.path());
        let (fraction, count) = character_within(&got, &want, &alone);
        let d = common::difference(&got, &want, CODES);
        eprintln!(
            "{pose}: {count} character pixels, {:.3} % within {CODES} codes (image: largest {}, mean {:.4})",
            100.0 * fraction,
            d.max,
            d.mean
        );
        assert!(
            count > 1500,
            "{pose}: the character is in view ({count} pixels)"
        );
        assert!(
            fraction >= WITHIN,
            "{pose}: only {:.2} % of the character's pixels within {CODES} codes of relight",
            100.0 * fraction
        );
        shots.push(got);
    }
    // It walks: the first and last frames show it in different places.
    let (same, _) = character_within(&shots[0], &shots[2], &alone);
    assert!(same < 0.5, "walk@0.5 and walk@3.5 look alike ({same:.3})");
}

/// --character needs --probes and --character-ldprt (a usage error, exit 2).
#[test]
fn character_needs_probes_and_its_bake() {
    let folder = tempfile::tempdir().unwrap();
    let glb = walker();
    for extra in [
        &["--character-ldprt", "x.ldprt"][..],
        &["--probes", "p.prt"][..],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_prt-view"))
            .arg(room())
            .arg(&glb)
            .arg("--character")
            .arg(&glb)
            .args(extra)
            .args(["--headless", "--screenshot"])
            .arg(folder.path().join("never.png"))
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{extra:?}");
    }
}

/// The window plays the walk (under Xvfb, as tests/window.rs runs windows): 30 frames, the
/// character posed and lit through the probes each.
#[test]
fn the_window_plays_the_walk() {
    let folder = tempfile::tempdir().unwrap();
    let (files, _) = bake_files(folder.path());
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1024x768x24"])
        .arg(env!("CARGO_BIN_EXE_prt-view"))
        .arg(room())
        .arg(&files.room)
        .arg("--probes")
        .arg(&files.probes)
        .arg("--character")
        .arg(walker())
        .arg("--character-ldprt")
        .arg(&files.ldprt)
        .args(["--size", "320x180", "--frames", "30"])
        .output()
        .expect("xvfb-run starts (scripts/install-deps.sh installs it)");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success()
            && stdout.contains("30 frames")
            && !stderr.contains("the character at"),
        "{stdout}{stderr}"
    );
}
