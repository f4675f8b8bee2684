//! `prt-view SKINNED.glb FILE.ldprt --pose P`: the viewer's frame of a skinned tube's LDPRT
//! bake against `prt-bake relight SKINNED.glb FILE.ldprt --pose P`'s PLY, drawn the same
//! way, at the start, middle and end of the tube's `bend` animation (0° → 90°).
//!
//! The reference is relight's per-vertex linear radiance (the PLY's float properties, albedo
//! included) on relight's posed positions, drawn by the same rasteriser: each vertex gets a
//! band-0-only transfer r / (albedo · L₀₀), so the renderer's vertex PRT reproduces r and the
//! fragment stage multiplies the albedo back. The viewer's image then differs from it only by
//! its own posing, lobe rotation and f32 sums, which are what is under test.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::Vec3;
use prt_baker::bake::ldprt::fit_bake;
use prt_baker::scene::Pose;
use prt_baker::support::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer};
use prt_baker::{BakeOptions, Mode, Scene};
use prt_viewer::lights::Lights;
use prt_viewer::{Bake, Camera, FrameInputs, View};

const SIZE: (u32, u32) = (320, 240);
const ORDER: usize = 4;
const POSES: [&str; 3] = ["bend@0", "bend@0.5", "bend@1"];
/// At least this fraction of the lit pixels must be within [`CODES`] of the reference.
const LIT_WITHIN: f64 = 0.99;
const CODES: u8 = 2;

fn glb() -> PathBuf {
    common::workspace().join("scenes/tube/tube-skinned.glb")
}

fn rig() -> PathBuf {
    common::workspace().join("viewer/src/default-rig.toml")
}

/// The tube baked in its rest pose (shadowed, order 4, 64 rays, seed 1) and fitted with 3
/// lobes, written as `bake --transfer ldprt` writes it.
fn bake_ldprt(folder: &Path) -> PathBuf {
    let scene = Scene::load_posed(&glb(), None, &Pose::Rest).unwrap().0;
    let tracer = EmbreeTracer::new(&scene, EmbreeOptions::default()).unwrap();
    let options = BakeOptions {
        order: ORDER,
        samples: 64,
        mode: Mode::Shadowed,
        seed: 1,
        ..BakeOptions::default()
    };
    let transfer = prt_baker::bake(&scene, Some(&tracer), &options, &Silent).unwrap();
    let mut file = fit_bake(&scene, &transfer, 3).unwrap();
    file.pose = Some("rest".into());
    let path = folder.join("tube.ldprt");
    std::fs::write(&path, file.to_bytes()).unwrap();
    path
}

/// The posed mesh in the viewer's z-up frame.
fn posed_z_up(pose: &Pose) -> Scene {
    let mut scene = Scene::load_posed(&glb(), None, pose).unwrap().0;
    let up = scene.up;
    prt_viewer::bake::turn_to_z_up(&mut scene, up);
    scene
}

/// relight's frame at `pose`, drawn by the viewer's renderer from its PLY.
fn reference(
    gpu: &prt_viewer::Gpu,
    ldprt: &Path,
    pose: &Pose,
    camera: Camera,
    folder: &Path,
) -> image::RgbaImage {
    let ply = folder.join(format!("{pose}.ply"));
    prt_baker::export::relight_ldprt::relight_ldprt(&glb(), pose, ldprt, &rig(), &ply, 0.0)
        .unwrap();
    let relit = common::read_ply(&ply);
    let mut scene = Scene::load_posed(&glb(), None, pose).unwrap().0;
    assert_eq!(relit.len(), scene.vertex_count());
    for (p, (q, _)) in scene.positions.iter_mut().zip(&relit) {
        assert!(p.distance(*q) < 1e-5, "relight's PLY holds the posed mesh");
        *p = *q;
    }
    let lights = Lights::load(Some(&rig()), ORDER).unwrap().for_up(scene.up);
    let inputs = FrameInputs::from_view(&View::new(camera, lights), None);
    let l00 = inputs.prt_light.rgb.each_ref().map(|c| c[0]);
    let file = common::band0_file(&scene, &relit, l00, ORDER);
    let bake = Bake::new(scene, file, Path::new("relight.prt")).unwrap();
    common::render(gpu, &bake, &inputs, SIZE)
}

/// `prt-view`'s headless screenshot at `pose`.
fn viewer(ldprt: &Path, pose: &Pose, camera: &Camera, folder: &Path) -> image::RgbaImage {
    let png = folder.join(format!("{pose}.png"));
    let out = Command::new(env!("CARGO_BIN_EXE_prt-view"))
        .arg(glb())
        .arg(ldprt)
        .args(["--pose", &pose.to_string(), "--lights"])
        .arg(rig())
        .args(["--camera", &camera.to_argument()])
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

/// The fraction of lit pixels (not the background, in either image) within [`CODES`].
fn lit_within(a: &image::RgbaImage, b: &image::RgbaImage) -> (f64, usize) {
    let background = *b.get_pixel(0, 0);
    let (mut lit, mut close) = (0usize, 0usize);
    for (p, q) in a.pixels().zip(b.pixels()) {
        if *p == background && *q == background {
            continue;
        }
        lit += 1;
        close += usize::from((0..3).all(|c| p[c].abs_diff(q[c]) <= CODES));
    }
    (close as f64 / lit.max(1) as f64, lit)
}

#[test]
fn prt_view_plays_a_skinned_ldprt_bake_as_relight_poses_it() {
    let Some(gpu) = common::gpu() else { return };
    let folder = tempfile::tempdir().unwrap();
    let ldprt = bake_ldprt(folder.path());
    let poses: Vec<Pose> = POSES.iter().map(|p| p.parse().unwrap()).collect();
    // One camera that sees the tube in every pose.
    let points: Vec<Vec3> = poses.iter().flat_map(|p| posed_z_up(p).positions).collect();
    let framing = Camera::framing(&points, SIZE.0 as f32 / SIZE.1 as f32);
    // As prt-view reads it back from --camera (rounded).
    let camera = Camera::parse(&framing.to_argument(), framing.scale).unwrap();
    let mut images = Vec::new();
    for pose in &poses {
        let want = reference(&gpu, &ldprt, pose, camera, folder.path());
        let got = viewer(&ldprt, pose, &camera, folder.path());
        let (fraction, lit) = lit_within(&got, &want);
        let d = common::difference(&got, &want, CODES);
        eprintln!(
            "{pose}: {lit} lit pixels, {:.3} % within {CODES} codes (largest {}, mean {:.4})",
            100.0 * fraction,
            d.max,
            d.mean
        );
        assert!(
            lit > 5000,
            "{pose}: the tube fills the frame ({lit} pixels)"
        );
        assert!(
            fraction >= LIT_WITHIN,
            "{pose}: only {:.2} % of lit pixels within {CODES} codes of relight",
            100.0 * fraction
        );
        images.push(got);
    }
    // The per-frame CPU cost the module documentation quotes (posing and lobe rotation).
    let (skinned, _) = prt_viewer::skinned::Skinned::load(&glb(), &ldprt, None).unwrap();
    let started = std::time::Instant::now();
    for k in 0..20 {
        skinned
            .posed(&skinned.pose_at(f64::from(k) * 0.05))
            .unwrap();
    }
    eprintln!(
        "posing and turning the lobes: {:.2} ms a frame",
        started.elapsed().as_secs_f64() * 1e3 / 20.0
    );
    // The animation shows: the bent tube's frame is not the straight one's.
    let (same, _) = lit_within(&images[0], &images[2]);
    assert!(same < 0.5, "bend@0 and bend@1 look alike ({same:.3})");
}

/// `--pose` is for LDPRT files (exit 3 for another file) and must parse (exit 2).
#[test]
fn pose_is_refused_for_other_files_and_when_malformed() {
    let run = |file: &Path, pose: &str| {
        Command::new(env!("CARGO_BIN_EXE_prt-view"))
            .arg(glb())
            .arg(file)
            .args(["--pose", pose, "--headless", "--screenshot"])
            .arg(std::env::temp_dir().join("prt-view-never-written.png"))
            .output()
            .unwrap()
    };
    let other = run(&rig(), "bend@0");
    assert_eq!(other.status.code(), Some(3));
    let stderr = String::from_utf8_lossy(&other.stderr);
    assert!(stderr.contains("--pose is for LDPRT files"), "{stderr}");
    assert_eq!(run(&rig(), "bend@x").status.code(), Some(2));
}

/// The window plays the animation (under Xvfb, as tests/window.rs runs windows): 40 frames
/// posed and lit each, with the light turned by keys meanwhile.
#[test]
fn the_window_plays_the_animation() {
    let folder = tempfile::tempdir().unwrap();
    let ldprt = bake_ldprt(folder.path());
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1024x768x24"])
        .arg(env!("CARGO_BIN_EXE_prt-view"))
        .arg(glb())
        .arg(&ldprt)
        .args(["--size", "320x180", "--frames", "40", "--keys", "Q,Q,W,W"])
        .output()
        .expect("xvfb-run starts (scripts/install-deps.sh installs it)");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("40 frames"),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
