//! A rigid object moving through the Cornell room's transfer probes (docs/guides/probes.md): at four places on its path (in the short box's shadow, by the red wall,
//! in the sun, by the green wall; the ball faces along the path, so each is turned) the viewer's mover, lit through an 8 × 8 × 8 probe grid,
//! against the same object lit by a probe baked exactly where it stands (a 1 × 1 × 1 grid
//! around the point) — per vertex on the CPU, and in rendered frames. And the probe spheres'
//! per-pixel SH evaluation against the CPU's.

mod common;

use std::path::Path;

use glam::{DQuat, Vec3};
use prt_baker::bake::probes::{self, ProbeSpec};
use prt_baker::export::probe_field::{ProbeField, rigid_radiance};
use prt_baker::light::LightCoefficients;
use prt_baker::support::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer};
use prt_baker::{BakeOptions, CoefficientFile, Mode, Scene};
use prt_viewer::lights::Lights;
use prt_viewer::moving::{Mover, Probes};
use prt_viewer::{Bake, Camera, FrameInputs, View};

const ORDER: usize = 3;
/// Where the test stops the object: its path's vertices.
const STOPS: [(&str, [f32; 3]); 4] = [
    ("shadow", [0.35, 0.4, 0.2]),
    ("red wall", [-0.75, -0.5, 0.8]),
    ("sun", [0.0, -0.3, 1.0]),
    ("green wall", [0.75, -0.5, 0.8]),
];
/// A sun through the open front and a sky.
const RIG: &str = common::ROOM_RIG;

fn cornell() -> Scene {
    Scene::load(&common::workspace().join("scenes/cornell/cornell.scene")).expect("Cornell")
}

/// The Cornell room's interreflected probes at `spec` (1,024 rays each, seed 1).
fn probe_bake(scene: &Scene, spec: &str) -> CoefficientFile {
    let tracer = EmbreeTracer::new(scene, EmbreeOptions::default()).expect("Embree");
    let options = BakeOptions {
        order: ORDER,
        samples: 1024,
        mode: Mode::Interreflected,
        bounces: 1,
        seed: 1,
        ..BakeOptions::default()
    };
    let block = ProbeSpec::parse(spec).unwrap().probes(scene).unwrap();
    let transfer = probes::bake(scene, Some(&tracer), &options, &block.positions, &Silent)
        .expect("the probe bake");
    CoefficientFile::from_probe_bake(scene, &transfer, Some(&tracer), block)
}

/// A probe baked exactly at `p`: the single cell centre of a tiny box around it.
fn exact_probe(scene: &Scene, p: Vec3) -> CoefficientFile {
    let (lo, hi) = (p - 0.001, p + 0.001);
    probe_bake(
        scene,
        &format!(
            "grid:1,1,1:{},{},{},{},{},{}",
            lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
        ),
    )
}

/// A grey ball (radius 0.12, Kd 0.8), baked alone with shadows (order 3).
fn ball(folder: &Path) -> Bake {
    let (nu, nv) = (12, 8);
    let mut text = String::from("mtllib ball.mtl\nusemtl grey\n");
    let mut normals = Vec::new();
    for j in 0..=nv {
        for i in 0..=nu {
            let (t, p) = (
                std::f32::consts::PI * j as f32 / nv as f32,
                std::f32::consts::TAU * i as f32 / nu as f32,
            );
            normals.push(Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos()));
        }
    }
    for n in &normals {
        let v = 0.12 * *n;
        text += &format!("v {} {} {}\nvn {} {} {}\n", v.x, v.y, v.z, n.x, n.y, n.z);
    }
    for j in 0..nv {
        for i in 0..nu {
            let a = j * (nu + 1) + i + 1;
            if j > 0 {
                text += &format!(
                    "f {a}//{a} {}//{} {}//{}\n",
                    a + nu + 1,
                    a + nu + 1,
                    a + 1,
                    a + 1
                );
            }
            if j < nv - 1 {
                let (b, c, d) = (a + 1, a + nu + 1, a + nu + 2);
                text += &format!("f {b}//{b} {c}//{c} {d}//{d}\n");
            }
        }
    }
    std::fs::write(folder.join("ball.obj"), text).unwrap();
    std::fs::write(folder.join("ball.mtl"), "newmtl grey\nKd 0.8 0.8 0.8\n").unwrap();
    common::bake(
        &folder.join("ball.obj"),
        BakeOptions {
            order: ORDER,
            samples: 256,
            mode: Mode::Shadowed,
            seed: 1,
            ..BakeOptions::default()
        },
    )
}

/// What the tests share, made once: the bakes, the ball on its path, the lights.
struct Fixture {
    _folder: tempfile::TempDir,
    grid: CoefficientFile,
    /// A probe baked exactly at each stop.
    exact: Vec<CoefficientFile>,
    ball: Bake,
    mover: Mover,
    lights: Lights,
    /// The room's own bake, for the renderer.
    room: Bake,
}

fn fixture() -> &'static Fixture {
    static FIXTURE: std::sync::OnceLock<Fixture> = std::sync::OnceLock::new();
    FIXTURE.get_or_init(Fixture::new)
}

impl Fixture {
    fn new() -> Fixture {
        let folder = tempfile::tempdir().unwrap();
        let cornell = cornell();
        let grid = probe_bake(&cornell, "grid:8,8,8");
        let ball = ball(folder.path());
        let path = STOPS.iter().map(|(_, p)| Vec3::from_array(*p)).collect();
        let mover = Mover::new(
            ball.scene.clone(),
            ball.file.clone(),
            path,
            0.5,
            Path::new("ball.prt"),
        )
        .expect("the ball moves");
        std::fs::write(folder.path().join("rig.toml"), RIG).unwrap();
        let lights = Lights::load(Some(&folder.path().join("rig.toml")), ORDER).unwrap();
        let mut fixture = Fixture {
            _folder: folder,
            grid,
            exact: Vec::new(),
            ball,
            mover,
            lights,
            room: cornell_bake(),
        };
        fixture.exact = (0..STOPS.len())
            .map(|k| exact_probe(&cornell, fixture.placement(k).0))
            .collect();
        fixture
    }

    fn probes(&self, file: &CoefficientFile) -> Probes {
        Probes::new(file.clone(), Path::new("probes.prt")).expect("a grid of probes")
    }

    /// Where the mover is at stop `k` (a vertex of its path: its position, facing along
    /// the segment that ends there, or the first one).
    fn placement(&self, k: usize) -> (Vec3, DQuat) {
        let along: f32 = STOPS
            .windows(2)
            .take(k)
            .map(|w| Vec3::from_array(w[0].1).distance(Vec3::from_array(w[1].1)))
            .sum();
        self.mover.placement(along)
    }

    fn light(&self) -> LightCoefficients {
        self.lights.prt()
    }
}

fn mean(radiance: &[[f32; 3]]) -> [f64; 3] {
    let mut sum = [0.0; 3];
    for r in radiance {
        for c in 0..3 {
            sum[c] += f64::from(r[c]) / radiance.len() as f64;
        }
    }
    sum
}

fn luminance([r, g, b]: [f64; 3]) -> f64 {
    0.2126 * r + 0.7152 * g + 0.0722 * b
}

#[test]
fn the_mover_matches_probes_baked_where_it_stands_and_takes_the_scenes_shadow_and_colour() {
    let f = fixture();
    let grid = f.probes(&f.grid);
    let light = f.light();
    let albedo = f.ball.scene.vertex_albedo();
    let mut means = Vec::new();
    for (k, (name, _)) in STOPS.iter().enumerate() {
        let placement = f.placement(k);
        assert!(
            k == 0 || placement.1.angle_between(DQuat::IDENTITY) > 0.1,
            "the path turns the ball"
        );
        let moved = f.mover.radiance(&grid, placement, &light);
        let exact_field = ProbeField::new(&f.exact[k]).unwrap();
        let exact = rigid_radiance(&f.ball.file, &albedo, &exact_field, placement, &light);
        let (m, e) = (mean(&moved), mean(&exact));
        // Per vertex: the largest difference in any channel, relative to the mean exact
        // radiance of that channel.
        let worst = moved
            .iter()
            .zip(&exact)
            .flat_map(|(a, b)| {
                (0..3).map(move |c| (f64::from(a[c]) - f64::from(b[c])).abs() / e[c])
            })
            .fold(0.0f64, f64::max);
        let total = (0..3)
            .map(|c| (m[c] - e[c]).abs() / e[c])
            .fold(0.0f64, f64::max);
        eprintln!(
            "{name}: mean radiance {m:.4?} from the grid, {e:.4?} exact: within {:.2} % (worst vertex {:.2} %)",
            100.0 * total,
            100.0 * worst
        );
        assert!(total < 0.03, "{name}: mean radiance off by {total}");
        assert!(worst < 0.08, "{name}: a vertex off by {worst}");
        means.push(m);
    }
    let darkened = luminance(means[0]) / luminance(means[2]);
    let red = means[1][0] / means[1][1];
    let green = means[3][0] / means[3][1];
    eprintln!(
        "shadow/sun luminance {darkened:.3}; red/green {red:.3} by the red wall, {green:.3} by the green wall"
    );
    assert!(darkened < 0.5, "the shadow darkens the ball: {darkened}");
    assert!(red > 1.1 && green < 1.0, "colour bleeding: {red}, {green}");
}

/// sRGB code to linear.
fn linear(code: u8) -> f64 {
    let c = f64::from(code) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The mean linear colour of the `half`-pixel square around the image's centre.
fn centre_patch(image: &image::RgbaImage, half: u32) -> [f64; 3] {
    let (cx, cy) = (image.width() / 2, image.height() / 2);
    let mut sum = [0.0; 3];
    let mut count = 0.0;
    for y in cy - half..cy + half {
        for x in cx - half..cx + half {
            let p = image.get_pixel(x, y);
            for c in 0..3 {
                sum[c] += linear(p[c]);
            }
            count += 1.0;
        }
    }
    sum.map(|s| s / count)
}

const SIZE: (u32, u32) = (96, 96);

/// The Cornell room's own bake for the renderer (order 3, interreflected, 64 rays).
fn cornell_bake() -> Bake {
    common::bake(
        &common::workspace().join("scenes/cornell/cornell.scene"),
        BakeOptions {
            order: ORDER,
            samples: 64,
            mode: Mode::Interreflected,
            bounces: 1,
            seed: 1,
            ..BakeOptions::default()
        },
    )
}

#[test]
fn rendered_frames_of_the_mover_match_exact_probes_and_show_shadow_and_bleeding() {
    let Some(gpu) = common::gpu() else { return };
    let f = fixture();
    let mut renderer = prt_viewer::Renderer::new(
        &gpu.device,
        &gpu.queue,
        &f.room,
        prt_viewer::offscreen::FORMAT,
        SIZE,
    )
    .unwrap();
    let mut patches = Vec::new();
    for (k, (name, _)) in STOPS.iter().enumerate() {
        let along: f32 = STOPS
            .windows(2)
            .take(k)
            .map(|w| Vec3::from_array(w[0].1).distance(Vec3::from_array(w[1].1)))
            .sum();
        let position = f.placement(k).0;
        // From in front (−y) and a little above, 0.45 away, so the ball fills the centre; in
        // the shadow behind the short box, from behind (the box would hide it).
        let offset = if k == 0 {
            Vec3::new(0.0, 0.38, 0.22)
        } else {
            Vec3::new(0.0, -0.42, 0.16)
        };
        let camera = Camera::looking_at(position + offset, position, 1.7);
        let inputs = FrameInputs::from_view(&View::new(camera, f.lights.clone()), None);
        let mut frame = |probes: Probes| {
            renderer
                .set_probe_scene(&gpu.device, probes, Some(f.mover.clone()))
                .unwrap();
            let scene = renderer.probe_scene_mut().unwrap();
            scene.show_probes = false;
            scene.distance = along;
            prt_viewer::offscreen::render_image(&gpu.device, &gpu.queue, &mut renderer, &inputs)
                .unwrap()
        };
        let moved = frame(f.probes(&f.grid));
        let exact = frame(f.probes(&f.exact[k]));
        let (a, b) = (centre_patch(&moved, 16), centre_patch(&exact, 16));
        let off = (0..3)
            .map(|c| (a[c] - b[c]).abs() / b[c])
            .fold(0.0f64, f64::max);
        let difference = common::difference(&moved, &exact, 3);
        eprintln!(
            "{name}: centre {a:.4?} through the grid, {b:.4?} exact: within {:.2} %; whole frame: mean {:.3} codes, {:.2} % of pixels over 3 codes",
            100.0 * off,
            difference.mean,
            100.0 * difference.outliers
        );
        assert!(off < 0.03, "{name}: the rendered ball is off by {off}");
        assert!(difference.outliers < 0.01, "{name}: {difference:?}");
        patches.push(a);
    }
    let darkened = luminance(patches[0]) / luminance(patches[2]);
    let red = patches[1][0] / patches[1][1];
    let green = patches[3][0] / patches[3][1];
    eprintln!(
        "rendered: shadow/sun luminance {darkened:.3}; red/green {red:.3} by the red wall, {green:.3} by the green wall"
    );
    assert!(darkened < 0.5, "the shadow darkens the ball: {darkened}");
    // The side facing the camera, not the wall: less than the whole ball's ratio.
    assert!(
        red > 1.05 && green < 0.99 && red - green > 0.1,
        "colour bleeding: {red}, {green}"
    );
}

#[test]
fn probe_spheres_show_the_cosine_convolved_incident_radiance_per_pixel() {
    let Some(gpu) = common::gpu() else { return };
    let cornell = cornell();
    let folder = tempfile::tempdir().unwrap();
    std::fs::write(folder.path().join("rig.toml"), RIG).unwrap();
    let lights = Lights::load(Some(&folder.path().join("rig.toml")), ORDER).unwrap();
    let file = probe_bake(&cornell, "grid:4,4,4");
    let mut renderer = prt_viewer::Renderer::new(
        &gpu.device,
        &gpu.queue,
        &fixture().room,
        prt_viewer::offscreen::FORMAT,
        SIZE,
    )
    .unwrap();
    let probes = Probes::new(file.clone(), Path::new("probes.prt")).unwrap();
    renderer.set_probe_scene(&gpu.device, probes, None).unwrap();
    let block = file.probes.as_ref().unwrap();
    let field = ProbeField::new(&file).unwrap();
    let light = lights.prt();
    let bands = prt_viewer::probe_scene::clamped_cosine_bands(ORDER);
    let basis = prt_baker::math::sh::Basis::new(ORDER);
    let mut checked = 0;
    // Probes in the open (grid:4,4,4 puts them 0.5 apart at ±0.25, ±0.75, and z 0.25 …
    // 1.75), each seen from a different side.
    for (p, d) in [
        (21, Vec3::new(0.2, -1.0, 0.3)),
        (22, Vec3::new(-0.6, -0.5, 0.6)),
        (35, Vec3::new(0.7, -0.3, -0.4)),
        (62, Vec3::new(0.0, -0.3, 1.0)),
    ] {
        assert!(block.valid(p), "probe {p} is in the open");
        let d = d.normalize();
        let centre = block.positions[p];
        let camera = Camera::looking_at(centre + 0.12 * d, centre, 1.7);
        let inputs = FrameInputs::from_view(&View::new(camera, lights.clone()), None);
        let image =
            prt_viewer::offscreen::render_image(&gpu.device, &gpu.queue, &mut renderer, &inputs)
                .unwrap();
        let incident = field.probe_incident(p, &light);
        let mut y = vec![0.0f32; ORDER * ORDER];
        basis.eval(d, &mut y);
        let expected: Vec<f64> = (0..3)
            .map(|c| {
                (0..ORDER * ORDER)
                    .map(|j| {
                        bands[(j as f64).sqrt() as usize] * incident.rgb[c][j] * f64::from(y[j])
                    })
                    .sum::<f64>()
            })
            .collect();
        let shown = centre_patch(&image, 1);
        eprintln!("probe {p} from {d:.2?}: shown {shown:.4?}, expected {expected:.4?}");
        for c in 0..3 {
            assert!(
                expected[c] > 0.02 && expected[c] < 0.95,
                "probe {p}: pick a view whose colour is not clamped ({expected:?})"
            );
            assert!(
                (shown[c] - expected[c]).abs() < 0.02 * expected[c] + 0.004,
                "probe {p}, channel {c}: shown {}, expected {}",
                shown[c],
                expected[c]
            );
        }
        checked += 1;
    }
    assert_eq!(checked, 4);
}

fn prt_view() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_prt-view"))
}

#[test]
fn prt_view_takes_probes_and_a_mover_on_the_command_line() {
    let folder = tempfile::tempdir().unwrap();
    let dir = folder.path();
    let mut ball = ball(dir);
    ball.file.write(&dir.join("ball.prt")).unwrap();
    let mut room = fixture().room.clone();
    room.file.write(&dir.join("room.prt")).unwrap();
    probe_bake(&room.scene, "grid:4,4,4")
        .write(&dir.join("probes.prt"))
        .unwrap();
    std::fs::write(dir.join("rig.toml"), RIG).unwrap();
    let cornell = common::workspace().join("scenes/cornell/cornell.scene");
    let run = |extra: &[&str], png: &str| {
        prt_view()
            .arg(&cornell)
            .arg(dir.join("room.prt"))
            .arg("--lights")
            .arg(dir.join("rig.toml"))
            .arg("--probes")
            .arg(dir.join("probes.prt"))
            .args(["--mover", "ball.obj", "--mover-prt", "ball.prt"])
            .args(["--size", "120x90", "--headless", "--screenshot", png])
            .args(extra)
            .current_dir(dir)
            .output()
            .unwrap()
    };
    let output = run(
        &["--path", "0.35,0.4,0.2;-0.75,-0.5,0.8", "--mover-at", "0.5"],
        "shot.png",
    );
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let image = image::open(dir.join("shot.png")).unwrap();
    assert_eq!((image.width(), image.height()), (120, 90));
    for (path, message) in [("0.35,0.4", "not one x,y,z point"), ("", "no points")] {
        let output = run(&["--path", path], "bad.png");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{path}: {stderr}");
        assert!(stderr.contains(message), "{path}: {stderr}");
    }
    // The moving object's own bake, in place of the probes: refused as bad input.
    let output = prt_view()
        .arg(&cornell)
        .arg(dir.join("room.prt"))
        .arg("--probes")
        .arg(dir.join("ball.prt"))
        .args(["--headless", "--screenshot", "x.png"])
        .current_dir(dir)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("not a probe bake"), "{stderr}");
}
