//! Lightmap (texel) bakes rendered per pixel: a contact shadow on a 4-vertex floor that the
//! per-vertex render cannot show, agreement with the per-vertex render where the texels sit
//! at the vertices, and the command line (screenshots, `--bench`) on a texel file.
//!
//! The floors are seen from below (the camera under the floor, looking up): the scene's
//! pipelines draw both faces, a floor's underside shows its top's transfer, and the depth
//! test hides everything above the floor, so every pixel checked is a floor pixel.

mod common;

use std::path::Path;
use std::process::Command;

use glam::{Vec2, Vec3};
use prt_baker::bake::lightmap::{self, Atlas};
use prt_baker::scene::{Material, Mesh};
use prt_baker::support::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer};
use prt_baker::{BakeOptions, CoefficientFile, Mode, Scene};
use prt_viewer::lights::Lights;
use prt_viewer::texel_transfer::TexelStorage;
use prt_viewer::{Bake, Camera, FrameInputs, View};

const SIZE: (u32, u32) = (192, 192);

/// A `cells`² grid over [−half, half]² at z = 0, facing +z; vertex (i, j) is j·(cells+1) + i.
fn floor(half: f32, cells: u32) -> Mesh {
    let mut positions = Vec::new();
    for j in 0..=cells {
        for i in 0..=cells {
            let f = |k: u32| -half + 2.0 * half * k as f32 / cells as f32;
            positions.push(Vec3::new(f(i), f(j), 0.0));
        }
    }
    let at = |i: u32, j: u32| j * (cells + 1) + i;
    let mut triangles = Vec::new();
    for j in 0..cells {
        for i in 0..cells {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    let count = positions.len();
    mesh("floor", positions, vec![Vec3::Z; count], triangles)
}

/// A UV sphere with outward normals.
fn sphere(centre: Vec3, radius: f32, rings: u32, segments: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for r in 0..=rings {
        let polar = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            let n = Vec3::new(
                polar.sin() * phi.cos(),
                polar.sin() * phi.sin(),
                -polar.cos(),
            );
            positions.push(centre + n * radius);
            normals.push(n);
        }
    }
    let at = |r: u32, s: u32| r * segments + s % segments;
    let mut triangles = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            if r > 0 {
                triangles.push([at(r, s), at(r, s + 1), at(r + 1, s + 1)]);
            }
            if r + 1 < rings {
                triangles.push([at(r, s), at(r + 1, s + 1), at(r + 1, s)]);
            }
        }
    }
    mesh("sphere", positions, normals, triangles)
}

/// A disk facing −z (toward a floor below it), tilted by z += 0.3·x.
fn tilted_disk(centre: Vec3, radius: f32, segments: u32) -> Mesh {
    let mut positions = vec![centre];
    for k in 0..segments {
        let phi = std::f32::consts::TAU * k as f32 / segments as f32;
        positions.push(centre + Vec3::new(phi.cos(), phi.sin(), 0.0) * radius);
    }
    for p in &mut positions {
        p.z += 0.3 * (p.x - centre.x);
    }
    let triangles = (0..segments)
        .map(|k| [0, 1 + (k + 1) % segments, 1 + k])
        .collect();
    let count = positions.len();
    mesh("disk", positions, vec![-Vec3::Z; count], triangles)
}

fn mesh(name: &str, positions: Vec<Vec3>, normals: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
    Mesh {
        name: name.into(),
        positions,
        normals: Some(normals),
        uvs: None,
        triangles,
        material: Material {
            kd: Vec3::splat(0.8),
            ..Material::default()
        },
    }
}

fn scene(meshes: Vec<Mesh>) -> Scene {
    Scene::from_meshes(Path::new("test-scene"), meshes, Vec::new()).expect("a valid scene")
}

fn options(order: usize, samples: u32) -> BakeOptions {
    BakeOptions {
        order,
        samples,
        mode: Mode::Shadowed,
        seed: 7,
        ..BakeOptions::default()
    }
}

/// The scene baked per texel of `atlas`, as `prt-bake bake --lightmap` does.
fn texel_bake(scene: &Scene, atlas: Atlas, options: &BakeOptions) -> Bake {
    let tracer = EmbreeTracer::new(scene, EmbreeOptions::default()).expect("Embree");
    let bake = lightmap::bake(scene, Some(&tracer), options, atlas, &Silent).expect("the bake");
    let file = CoefficientFile::from_lightmap_bake(scene, &bake);
    Bake::new(scene.clone(), file, Path::new("texels.prt")).expect("the viewer takes it")
}

/// The scene baked per vertex.
fn vertex_bake(scene: &Scene, options: &BakeOptions) -> Bake {
    let tracer = EmbreeTracer::new(scene, EmbreeOptions::default()).expect("Embree");
    let transfer = prt_baker::bake(scene, Some(&tracer), options, &Silent).expect("the bake");
    let file = CoefficientFile::from_bake(scene, &transfer);
    Bake::new(scene.clone(), file, Path::new("vertices.prt")).expect("the viewer takes it")
}

fn rig(folder: &Path, text: &str, order: usize) -> Lights {
    let path = folder.join("rig.toml");
    std::fs::write(&path, text).unwrap();
    Lights::load(Some(&path), order).expect("the rig loads")
}

/// PRT frame inputs: the camera under the floor at `below`, looking up at the origin.
fn inputs(lights: Lights, below: Vec3, scale: f32) -> FrameInputs {
    let view = View::new(Camera::looking_at(below, Vec3::ZERO, scale), lights);
    FrameInputs::from_view(&view, None)
}

/// The pixel where world point `p` lands, if inside the image.
fn pixel(inputs: &FrameInputs, p: Vec3) -> Option<(u32, u32)> {
    let (w, h) = SIZE;
    let c = inputs.camera.view_projection(w as f32 / h as f32) * p.extend(1.0);
    let ndc = c.truncate().truncate() / c.w;
    let x = (0.5 * (ndc.x + 1.0) * w as f32).floor();
    let y = (0.5 * (1.0 - ndc.y) * h as f32).floor();
    (c.w > 0.0 && x >= 0.0 && y >= 0.0 && x < w as f32 && y < h as f32)
        .then_some((x as u32, y as u32))
}

/// Linear radiance (× exposure) of a pixel's green channel, decoded from sRGB.
fn linear(image: &image::RgbaImage, (x, y): (u32, u32)) -> f64 {
    let s = f64::from(image.get_pixel(x, y)[1]) / 255.0;
    if s <= 0.04045 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// The mean linear radiance of the floor pixels at `points` (those in the image; at least
/// `minimum` of them).
fn mean_at(image: &image::RgbaImage, inputs: &FrameInputs, points: &[Vec3], minimum: usize) -> f64 {
    let values: Vec<f64> = points
        .iter()
        .filter_map(|p| pixel(inputs, *p))
        .map(|q| linear(image, q))
        .collect();
    assert!(values.len() >= minimum, "{} points in view", values.len());
    values.iter().sum::<f64>() / values.len() as f64
}

/// Floor points on rings of these radii about the origin, 16 per ring (and the origin).
fn rings(radii: &[f32]) -> Vec<Vec3> {
    let mut points = vec![Vec3::ZERO];
    for r in radii {
        for k in 0..16 {
            let phi = std::f32::consts::TAU * k as f32 / 16.0;
            points.push(Vec3::new(phi.cos(), phi.sin(), 0.0) * *r);
        }
    }
    points
}

#[test]
fn a_texel_bake_shows_a_contact_shadow_on_a_four_vertex_floor() {
    // A unit sphere resting on an 8×8 floor of 4 vertices, lit by a white sky of radiance 1.
    // Per vertex the floor's corners are all lit, so its pixels are uniform; per texel
    // (96², as `--lightmap 96`) the pixels within 0.3 of the contact point are far darker
    // than those beyond 3. (The baker's own test measures 0.22 × on the texels themselves.)
    let Some(gpu) = common::gpu() else { return };
    let folder = tempfile::tempdir().unwrap();
    let scene = scene(vec![floor(4.0, 1), sphere(Vec3::Z, 1.0, 8, 16)]);
    let options = options(4, 1024);
    let texels = texel_bake(&scene, Atlas::generate(&scene, 96, None).unwrap(), &options);
    let vertices = vertex_bake(&scene, &options);
    let sky = "[[light]]\nkind = \"constant\"\n";
    let frame = inputs(rig(folder.path(), sky, 4), Vec3::new(0.0, -2.0, -7.0), 6.0);
    let texel_image = common::render(&gpu, &texels, &frame, SIZE);
    let vertex_image = common::render(&gpu, &vertices, &frame, SIZE);
    let (near, far) = (rings(&[0.1, 0.2, 0.3]), rings(&[3.0, 3.3]));
    let ratio = |image: &image::RgbaImage| {
        let (n, f) = (
            mean_at(image, &frame, &near, 40),
            mean_at(image, &frame, &far, 16),
        );
        eprintln!("near {n:.4}, far {f:.4}, ratio {:.3}", n / f);
        assert!(f > 0.7, "the far floor is lit (0.8 × sky): {f}");
        n / f
    };
    let per_texel = ratio(&texel_image);
    let per_vertex = ratio(&vertex_image);
    if std::env::var_os("PRT_SAVE_IMAGES").is_some() {
        texel_image
            .save(common::workspace().join("target/tmp-lightmap-texel.png"))
            .unwrap();
        vertex_image
            .save(common::workspace().join("target/tmp-lightmap-vertex.png"))
            .unwrap();
    }
    assert!(per_texel < 0.35, "per texel: near / far = {per_texel}");
    assert!(per_vertex > 0.95, "per vertex: near / far = {per_vertex}");
}

#[test]
fn texel_and_vertex_renders_agree_where_texels_sit_at_the_vertices() {
    // A 16×16-cell floor whose lightmap UVs put its 17² vertices at the centres of a 17²
    // lightmap's texels, under a tilted, off-centre disk, lit by a sun and a dim sky. With
    // one seed, texel k and vertex k share their ray directions, so their transfer is equal
    // (the baker's test), and the two renders differ only in how a cell is filled between
    // its corners: bilinearly per pixel, or linearly over each of its two triangles.
    let Some(gpu) = common::gpu() else { return };
    let folder = tempfile::tempdir().unwrap();
    let (scene, options, texels) = dense_floor_under_a_disk();
    let vertices = vertex_bake(&scene, &options);
    let frame = dense_floor_frame(folder.path(), DENSE_FLOOR_LIGHT);
    let texel_image = common::render(&gpu, &texels, &frame, SIZE);
    let vertex_image = common::render(&gpu, &vertices, &frame, SIZE);
    if std::env::var_os("PRT_SAVE_IMAGES").is_some() {
        texel_image
            .save(common::workspace().join("target/tmp-agree-texel.png"))
            .unwrap();
        vertex_image
            .save(common::workspace().join("target/tmp-agree-vertex.png"))
            .unwrap();
    }
    // The shadow is in view: the floor's darkest pixel is under half its brightest.
    let floor_pixels: Vec<f64> = dense_floor_pixels(&frame)
        .into_iter()
        .map(|q| linear(&vertex_image, q))
        .collect();
    let lo = floor_pixels.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = floor_pixels.iter().copied().fold(0.0, f64::max);
    assert!(floor_pixels.len() > 400 && lo < 0.5 * hi, "{lo} {hi}");
    let d = common::difference(&texel_image, &vertex_image, 3);
    eprintln!(
        "texel vs vertex render: mean {:.3} codes, max {}, {:.3} % of pixels off by > 3 (floor {lo:.3}..{hi:.3})",
        d.mean,
        d.max,
        100.0 * d.outliers
    );
    assert!(d.mean <= 0.5 && d.outliers <= 0.01, "{d:?}");
}

/// A 16×16-cell floor [−1, 1]² whose 17² vertices sit at the centres of a 17² lightmap's
/// texels (texel k is vertex k), under a tilted, off-centre disk left out of the atlas; the
/// scene, the options (order 3, 1,024 rays, seed 7) and its texel bake.
fn dense_floor_under_a_disk() -> (Scene, BakeOptions, Bake) {
    let cells = 16;
    let scene = scene(vec![
        floor(1.0, cells),
        tilted_disk(Vec3::new(0.3, -0.2, 0.6), 0.7, 64),
    ]);
    let side = cells + 1;
    let uvs: Vec<Vec2> = (0..scene.vertex_count() as u32)
        .map(|v| match v < side * side {
            true => (Vec2::new((v % side) as f32, (v / side) as f32) + 0.5) / side as f32,
            false => Vec2::splat(-1.0),
        })
        .collect();
    let atlas = Atlas::from_vertex_uvs(&scene, &uvs, side, side).unwrap();
    let options = options(3, 1024);
    let texels = texel_bake(&scene, atlas, &options);
    (scene, options, texels)
}

/// A sun and a dim sky for the dense floor.
const DENSE_FLOOR_LIGHT: &str = "[[light]]\nkind = \"sun\"\ndirection = [0.3, 0.2, 1.0]\nintensity = 2.0\n\n\
                                 [[light]]\nkind = \"constant\"\nintensity = 0.2\n";

/// The dense floor's frame under `light`, seen from below.
fn dense_floor_frame(folder: &Path, light: &str) -> FrameInputs {
    inputs(rig(folder, light, 3), Vec3::new(0.0, -0.6, -3.2), 2.0)
}

/// The pixels of a 21² grid of points on the dense floor (those in view).
fn dense_floor_pixels(frame: &FrameInputs) -> Vec<(u32, u32)> {
    (0..=20)
        .flat_map(|i| (0..=20).map(move |j| (i, j)))
        .filter_map(|(i, j)| {
            let p = Vec3::new(-0.95 + 0.095 * i as f32, -0.95 + 0.095 * j as f32, 0.0);
            pixel(frame, p)
        })
        .collect()
}

#[test]
fn rgb_texel_transfer_shades_each_channel_with_its_own_light() {
    // The texel path's three-channel branch (the baker writes grey texel files today; RGB
    // ones once interreflected texel bakes exist): the dense floor's grey transfer T put in
    // channel c alone (the others zero), under a coloured light, must render channel c as
    // the grey file does and the other two black. A mix-up of channels or of the light's
    // colours shows.
    let Some(gpu) = common::gpu() else { return };
    let folder = tempfile::tempdir().unwrap();
    let (_, _, grey) = dense_floor_under_a_disk();
    let light = "[[light]]\nkind = \"sun\"\ndirection = [0.3, 0.2, 1.0]\ncolor = [1.0, 0.5, 0.25]\nintensity = 2.0\n\n\
                 [[light]]\nkind = \"constant\"\ncolor = [0.1, 0.3, 0.2]\n";
    let frame = dense_floor_frame(folder.path(), light);
    let grey_image = common::render(&gpu, &grey, &frame, SIZE);
    let pixels = dense_floor_pixels(&frame);
    let n2 = grey.order() * grey.order();
    for c in 0..3 {
        let mut rgb = grey.clone();
        rgb.file.header.channels = 3;
        rgb.file.coefficients = grey
            .file
            .coefficients
            .chunks_exact(n2)
            .flat_map(|t| {
                (0..3).flat_map(move |k| t.iter().map(move |x| if k == c { *x } else { 0.0 }))
            })
            .collect();
        let image = common::render(&gpu, &rgb, &frame, SIZE);
        let mut worst = 0u8;
        for &(x, y) in &pixels {
            let (got, want) = (image.get_pixel(x, y), grey_image.get_pixel(x, y));
            for k in 0..3 {
                let expected = if k == c { want[k] } else { 0 };
                worst = worst.max(got[k].abs_diff(expected));
            }
        }
        eprintln!(
            "channel {c} alone: worst difference {worst} codes over {} floor pixels",
            pixels.len()
        );
        assert!(
            pixels.len() > 400 && worst <= 1,
            "channel {c}: {worst} codes"
        );
    }
}

/// A floor quad and a box standing on it, as OBJ text.
const FLOOR_AND_BOX_OBJ: &str = "\
o floor
v -2 -2 0
v 2 -2 0
v 2 2 0
v -2 2 0
vn 0 0 1
f 1//1 2//1 3//1
f 1//1 3//1 4//1
o box
v -0.5 -0.5 0
v 0.5 -0.5 0
v 0.5 0.5 0
v -0.5 0.5 0
v -0.5 -0.5 1
v 0.5 -0.5 1
v 0.5 0.5 1
v -0.5 0.5 1
f 9 10 11
f 9 11 12
f 5 6 10
f 5 10 9
f 6 7 11
f 6 11 10
f 7 8 12
f 7 12 11
f 8 5 9
f 8 9 12
";

/// The box on a floor, as OBJ, and its 32² lightmap bake (order 3, 64 rays) written beside
/// it, as `prt-bake bake box.obj -o box-lm.prt --lightmap 32` writes it.
fn box_texel_file(folder: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let obj = folder.join("box.obj");
    std::fs::write(&obj, FLOOR_AND_BOX_OBJ).unwrap();
    let scene = Scene::load(&obj).unwrap();
    let atlas = Atlas::generate(&scene, 32, None).unwrap();
    let mut bake = texel_bake(&scene, atlas, &options(3, 64));
    let file = folder.join("box-lm.prt");
    bake.file.write(&file).unwrap();
    (obj, file)
}

fn prt_view() -> Command {
    Command::new(env!("CARGO_BIN_EXE_prt-view"))
}

#[test]
fn the_command_line_shows_and_benchmarks_a_texel_file() {
    // A 32² lightmap bake of a box on a floor, written to disk as `prt-bake bake --lightmap
    // 32` writes it: screenshots in both modes, `--bench` prints its table, and the file is
    // refused for another scene (exit 3).
    let folder = tempfile::tempdir().unwrap();
    let (obj, file) = box_texel_file(folder.path());
    let run = |args: &[&str]| {
        let output = prt_view().arg(&obj).arg(&file).args(args).output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        (
            output.status.code(),
            String::from_utf8_lossy(&output.stdout).into_owned(),
            stderr,
        )
    };
    for mode in ["prt", "phong"] {
        let png = folder.path().join(format!("{mode}.png"));
        let (code, _, stderr) = run(&[
            "--headless",
            "--screenshot",
            png.to_str().unwrap(),
            "--size",
            "96x64",
            "--mode",
            mode,
        ]);
        if stderr.contains("no graphics adapter") {
            eprintln!("SKIPPED: {stderr}");
            return;
        }
        assert_eq!(code, Some(0), "{stderr}");
        let image = image::open(&png).unwrap();
        assert_eq!((image.width(), image.height()), (96, 64));
    }
    let (code, stdout, stderr) = run(&["--bench", "--size", "96x64", "--bench-frames", "8"]);
    assert_eq!(code, Some(0), "{stderr}");
    eprintln!("{stdout}");
    assert!(
        stdout.contains("a 32×32 lightmap (PRT per pixel)"),
        "{stdout}"
    );
    for model in ["Blinn-Phong", "PRT"] {
        let row = stdout
            .lines()
            .find(|l| l.starts_with(&format!("| {model} |")))
            .unwrap_or_else(|| panic!("no {model} row: {stdout}"));
        let fps: Vec<f64> = row
            .split('|')
            .filter_map(|cell| cell.trim().parse().ok())
            .collect();
        assert!(fps.len() == 2 && fps.iter().all(|f| *f > 0.0), "{row}");
    }
    let torus = common::demo_scene_path();
    let output = prt_view()
        .arg(&torus)
        .arg(&file)
        .args(["--headless", "--screenshot"])
        .arg(folder.path().join("x.png"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("baked for a scene with"), "{stderr}");
    assert!(!folder.path().join("x.png").exists());
}

#[test]
fn the_window_runs_every_control_on_a_texel_file() {
    // As window.rs does for a vertex bake, under a virtual X server (Xvfb).
    let xvfb = Command::new("sh")
        .args(["-c", "command -v xvfb-run"])
        .output()
        .expect("sh runs");
    assert!(
        xvfb.status.success(),
        "xvfb-run is missing: run scripts/install-deps.sh (make test does)"
    );
    let folder = tempfile::tempdir().unwrap();
    let (obj, file) = box_texel_file(folder.path());
    let keys = "F1,Q,A,W,E,2,1,T,N,L,Up,Down,Left,Right,F2";
    let output = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1024x768x24"])
        .arg(env!("CARGO_BIN_EXE_prt-view"))
        .arg(&obj)
        .arg(&file)
        .args(["--size", "320x180", "--frames", "40", "--keys", keys])
        .output()
        .expect("xvfb-run starts");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("prt-view: 40 frames in"), "{stdout}");
}

/// The radiance map a PRT frame of `frame` left, texel by texel (row-major), RGB.
fn radiance_map(
    gpu: &prt_viewer::Gpu,
    bake: &Bake,
    frame: &FrameInputs,
    storage: TexelStorage,
) -> (Vec<[f32; 3]>, image::RgbaImage) {
    let mut renderer = prt_viewer::Renderer::with_texel_storage(
        &gpu.device,
        &gpu.queue,
        bake,
        prt_viewer::offscreen::FORMAT,
        SIZE,
        storage,
    )
    .expect("the renderer takes the bake");
    let image = prt_viewer::offscreen::render_image(&gpu.device, &gpu.queue, &mut renderer, frame)
        .expect("the frame reads back");
    let texture = renderer
        .texel_radiance()
        .expect("a texel bake has a radiance map");
    let bytes = prt_viewer::offscreen::read_texture(&gpu.device, &gpu.queue, texture, 8).unwrap();
    let halves: Vec<u16> = bytes
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .collect();
    let texels = halves
        .chunks_exact(4)
        .map(|t| {
            [
                common::from_f16(t[0]),
                common::from_f16(t[1]),
                common::from_f16(t[2]),
            ]
        })
        .collect();
    (texels, image)
}

#[test]
fn the_radiance_map_is_relight_s_lightmap_radiance_in_both_storages() {
    // Per-pixel PRT samples a radiance map that a pass fills once per frame: Σ_j T_j·L_j per
    // texel and channel, in half floats. Against `relight`'s lightmap radiance (f64 sums of
    // the file's f32 coefficients), every texel must agree to the half float's rounding,
    // 2⁻¹⁰ of itself (one unit in the last place: lavapipe truncates to half rather than
    // rounding to nearest), plus 10⁻⁵ of the largest value for f32 sums: with the transfer in the
    // storage buffer and in the texture array, order 3 (an odd order pads each channel) RGB
    // transfer whose channels hold different coefficients (channel c's T_j is the grey file's
    // T_{(j + 2c) mod 9}, times 1, −0.5, 2), under a coloured sun and sky. The two storages
    // also render the same screenshot.
    let Some(gpu) = common::gpu() else { return };
    let folder = tempfile::tempdir().unwrap();
    let (_, _, grey) = dense_floor_under_a_disk();
    let n2 = grey.order() * grey.order();
    let mut rgb = grey.clone();
    rgb.file.header.channels = 3;
    rgb.file.coefficients = grey
        .file
        .coefficients
        .chunks_exact(n2)
        .flat_map(|t| {
            (0..3).flat_map(move |c| {
                let scale = [1.0, -0.5, 2.0][c];
                (0..n2).map(move |j| scale * t[(j + 2 * c) % n2])
            })
        })
        .collect();
    let light = "[[light]]\nkind = \"sun\"\ndirection = [0.3, 0.2, 1.0]\ncolor = [1.0, 0.5, 0.25]\nintensity = 2.0\n\n\
                 [[light]]\nkind = \"constant\"\ncolor = [0.1, 0.3, 0.2]\n";
    let frame = dense_floor_frame(folder.path(), light);
    let want = prt_baker::export::relight::lightmap_radiance(&rgb.file, &frame.prt_light);
    let largest = want.iter().flatten().fold(0.0f32, |m, x| m.max(x.abs()));
    let mut images = Vec::new();
    for storage in [TexelStorage::Fit, TexelStorage::Array] {
        let (got, image) = radiance_map(&gpu, &rgb, &frame, storage);
        assert_eq!(got.len(), want.len(), "one value per texel");
        let (mut worst, mut at) = (0.0f32, (0.0, 0.0));
        for (g, w) in got.iter().flatten().zip(want.iter().flatten()) {
            let bound = 2f32.powi(-10) * w.abs() + 1e-5 * largest;
            if (g - w).abs() / bound > worst {
                (worst, at) = ((g - w).abs() / bound, (*g, *w));
            }
        }
        eprintln!(
            "{storage:?}: {} texels, largest radiance {largest:.3}, worst error {worst:.3} of the bound (got {}, want {})",
            got.len(),
            at.0,
            at.1
        );
        assert!(worst <= 1.0, "{storage:?}: {worst} × the bound");
        images.push(image);
    }
    let difference = common::difference(&images[0], &images[1], 0);
    eprintln!("buffer against array: {difference:?}");
    assert_eq!(difference.max, 0, "the two storages render alike");
}
