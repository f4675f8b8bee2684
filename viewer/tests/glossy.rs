//! Glossy PRT: the glossy torus (`scenes/torus/glossy.scene`) baked as transfer
//! matrices, its per-vertex diffuse and glossy sums read back from the GPU against a CPU
//! reference computed here from the bake with `prt_baker::math::glossy`, uncompressed and
//! CPCA-compressed, and its highlight seen to move on screen when the camera moves.

mod common;

use glam::{Quat, Vec3};
use prt_baker::bake::options::TransferKind;
use prt_baker::light::LightCoefficients;
use prt_baker::math::cpca::Cpca;
use prt_baker::math::glossy::{lobe_bands, reflect};
use prt_baker::math::sh::Basis;
use prt_baker::{BakeOptions, Mode, Scene};
use prt_viewer::lights::Lights;
use prt_viewer::{Bake, Camera, FrameInputs, Renderer, View, offscreen, probe};

const ORDER: usize = 4;
/// f32 sums on the GPU against f64 here, of terms up to about 1: rounding, far below the
/// 1/255 of a display code.
const TOLERANCE: f32 = 1e-3;

fn glossy_scene() -> std::path::PathBuf {
    common::workspace().join("scenes/torus/glossy.scene")
}

/// The glossy scene as transfer matrices at order 4, 256 rays per vertex, shadowed.
fn matrix_bake() -> Bake {
    common::bake(
        &glossy_scene(),
        BakeOptions {
            order: ORDER,
            samples: 256,
            mode: Mode::Shadowed,
            seed: 1,
            transfer: TransferKind::Matrix,
            ..BakeOptions::default()
        },
    )
}

/// The bake with its matrices replaced by a hand-made CPCA fit (clusters by vertex index
/// mod 3, other vertices' matrices as means and components, weights in [−0.5, 0.5]): the
/// GPU's compressed path must match the reconstruction whatever the fit's quality, which is
/// the compressor's business.
fn compressed(mut bake: Bake) -> Bake {
    let d = ORDER.pow(4);
    let (clusters, pcs) = (3usize, 2usize);
    let v = bake.scene.vertex_count();
    let matrix = |vertex: usize| bake.file.coefficients[vertex * d..(vertex + 1) * d].to_vec();
    let cpca = Cpca {
        dim: d,
        pcs,
        // Vertices on the torus (0..10,800) and the planes.
        means: [100, 5000, 11000].iter().flat_map(|&u| matrix(u)).collect(),
        bases: [200, 7000, 300, 9000, 12000, 12500]
            .iter()
            .flat_map(|&u| matrix(u).into_iter().map(|x| 0.5 * x))
            .collect(),
        cluster: (0..v).map(|u| (u % clusters) as u32).collect(),
        weights: (0..v * pcs)
            .map(|k| ((k * 7919) % 1000) as f32 / 1000.0 - 0.5)
            .collect(),
        iterations: 0,
        seed: 0,
    };
    bake.file.coefficients = cpca.reconstruct();
    bake.cpca = Some(cpca);
    bake
}

/// Per vertex: Σ ĝ_l(1) L′ y(n) and Σ ĝ_l(s) L′ y(r), L′ = M·L, in f64 from the file's
/// matrices (the reconstruction, for a compressed bake).
fn cpu_terms(bake: &Bake, light: &LightCoefficients, eye: Vec3) -> Vec<([f32; 3], [f32; 3])> {
    let scene: &Scene = &bake.scene;
    let n2 = ORDER * ORDER;
    let basis = Basis::new(ORDER);
    let diffuse_bands = lobe_bands(1.0, ORDER);
    let (mut yn, mut yr) = (vec![0.0f32; n2], vec![0.0f32; n2]);
    (0..scene.vertex_count())
        .map(|v| {
            let material = &scene.materials[scene.vertex_material[v] as usize];
            let glossy_bands = material
                .glossy
                .map_or(vec![0.0; ORDER], |g| lobe_bands(g.exponent, ORDER));
            let n = scene.normals[v].normalize();
            let to_eye = (eye - scene.positions[v]).normalize();
            basis.eval(n, &mut yn);
            basis.eval(reflect(to_eye, n).normalize(), &mut yr);
            let m = &bake.file.coefficients[v * n2 * n2..(v + 1) * n2 * n2];
            let mut out = ([0.0f32; 3], [0.0f32; 3]);
            for c in 0..3 {
                let incident: Vec<f32> = (0..n2)
                    .map(|i| {
                        (0..n2)
                            .map(|j| f64::from(m[i * n2 + j]) * light.rgb[c][j])
                            .sum::<f64>() as f32
                    })
                    .collect();
                out.0[c] =
                    prt_baker::math::glossy::convolve_at(&incident, &diffuse_bands, &yn) as f32;
                out.1[c] =
                    prt_baker::math::glossy::convolve_at(&incident, &glossy_bands, &yr) as f32;
            }
            out
        })
        .collect()
}

fn view(bake: &Bake, camera: Camera) -> View {
    View::new(camera, Lights::suns(1, bake.order()))
}

/// The default framing turned by `degrees` about the vertical axis through the scene's centre.
fn orbit(bake: &Bake, degrees: f32, aspect: f32) -> Camera {
    let framing = Camera::framing(&bake.scene.positions, aspect);
    let (lo, hi) = bake.scene.bounds();
    let centre = 0.5 * (lo + hi);
    let offset = Quat::from_rotation_z(degrees.to_radians()) * (framing.position - centre);
    Camera::looking_at(centre + offset, centre, framing.scale)
}

/// The GPU's two sums against the CPU's at every vertex; returns the vertex with the
/// brightest glossy term.
fn compare(gpu: &prt_viewer::Gpu, bake: &Bake, camera: Camera, what: &str) -> usize {
    let inputs = FrameInputs::from_view(&view(bake, camera), None);
    let mut renderer =
        Renderer::new(&gpu.device, &gpu.queue, bake, offscreen::FORMAT, (64, 64)).unwrap();
    assert!(renderer.is_glossy());
    renderer.update(&gpu.queue, &inputs);
    let gpu_terms = probe::glossy_vertex_terms(&renderer, &gpu.device, &gpu.queue)
        .unwrap()
        .expect("a matrix bake");
    let cpu = cpu_terms(bake, &inputs.prt_light, camera.position);
    assert_eq!(gpu_terms.len(), cpu.len());
    let (mut worst, mut brightest, mut peak) = (0.0f32, 0, f32::MIN);
    for (v, (g, c)) in gpu_terms.iter().zip(&cpu).enumerate() {
        for k in 0..3 {
            for (a, b, term) in [(g.0[k], c.0[k], "diffuse"), (g.1[k], c.1[k], "glossy")] {
                let d = (a - b).abs();
                assert!(
                    d <= TOLERANCE * (1.0 + b.abs()),
                    "{what}, vertex {v}, {term} channel {k}: GPU {a}, CPU {b}"
                );
                worst = worst.max(d);
            }
        }
        if c.1[0] > peak {
            (peak, brightest) = (c.1[0], v);
        }
    }
    assert!(
        peak > 0.05,
        "{what}: no highlight (brightest glossy term {peak})"
    );
    eprintln!(
        "{what}: {} vertices, largest difference {worst:.2e}, brightest glossy vertex {brightest} ({peak:.3})",
        cpu.len()
    );
    brightest
}

/// Uncompressed and compressed, from two camera positions: the GPU evaluates the same lobe in
/// the same reflected direction as the CPU, and the brightest glossy vertex changes with the
/// camera.
#[test]
fn glossy_vertex_terms_equal_the_cpu_reference() {
    let Some(gpu) = common::gpu() else { return };
    let bake = matrix_bake();
    assert!(bake.is_matrix());
    let a = compare(
        &gpu,
        &bake,
        orbit(&bake, -30.0, 1.0),
        "matrix, camera at −30°",
    );
    let b = compare(
        &gpu,
        &bake,
        orbit(&bake, 30.0, 1.0),
        "matrix, camera at +30°",
    );
    let moved = bake.scene.positions[a].distance(bake.scene.positions[b]);
    assert!(
        moved > 0.2,
        "the brightest glossy vertex moved only {moved}"
    );
    let bake = compressed(bake);
    compare(&gpu, &bake, orbit(&bake, 10.0, 1.0), "CPCA 3×2");
}

/// Where a vertex lands on screen, in pixels (x right, y down).
fn to_screen(camera: &Camera, size: (u32, u32), p: Vec3) -> (f32, f32) {
    let clip = camera.view_projection(size.0 as f32 / size.1 as f32) * p.extend(1.0);
    let (x, y) = (clip.x / clip.w, clip.y / clip.w);
    (
        (0.5 * x + 0.5) * size.0 as f32,
        (0.5 - 0.5 * y) * size.1 as f32,
    )
}

/// The highlight on screen is where the CPU puts it, from two camera positions on an orbit,
/// and it travels over the torus between them. On screen: the brightest pixel of the
/// highlight alone (the glossy render minus the same render with the lobe taken off the
/// material). Expected: the torus vertex, facing the camera, with the CPU's brightest glossy
/// term, projected. A lobe that ignored the eye would stay on the same part of the torus.
#[test]
fn the_highlight_moves_with_the_camera() {
    let Some(gpu) = common::gpu() else { return };
    let bake = matrix_bake();
    let mut matte = bake.clone();
    for m in &mut matte.scene.materials {
        m.glossy = None;
    }
    let scene = &bake.scene;
    // The torus is the glossy object, and the scene's first.
    assert_eq!(scene.objects[0].name, "torus");
    let torus = scene.objects[0].vertices.start as usize..scene.objects[0].vertices.end as usize;
    let size = (240, 180);
    let aspect = size.0 as f32 / size.1 as f32;
    let highlight = |degrees: f32| {
        let camera = orbit(&bake, degrees, aspect);
        // Two stops down, so that no pixel of the highlight clips at white.
        let mut view = view(&bake, camera);
        view.exposure = -2.0;
        let render = |b: &Bake| {
            let mut renderer =
                Renderer::new(&gpu.device, &gpu.queue, b, offscreen::FORMAT, size).unwrap();
            let inputs = FrameInputs::from_view(&view, None);
            offscreen::render_image(&gpu.device, &gpu.queue, &mut renderer, &inputs).unwrap()
        };
        let (glossy, diffuse) = (render(&bake), render(&matte));
        let mut best = (0i32, (0.0f32, 0.0f32));
        for (x, y, p) in glossy.enumerate_pixels() {
            let q = diffuse.get_pixel(x, y);
            let excess: i32 = (0..3).map(|k| i32::from(p[k]) - i32::from(q[k])).sum();
            if excess > best.0 {
                best = (excess, (x as f32 + 0.5, y as f32 + 0.5));
            }
        }
        assert!(
            best.0 > 15,
            "camera at {degrees}°: no visible highlight ({best:?})"
        );
        let light = FrameInputs::from_view(&view, None).prt_light;
        let cpu = cpu_terms(&bake, &light, camera.position);
        let expected = torus
            .clone()
            .filter(|&v| scene.normals[v].dot(camera.position - scene.positions[v]) > 0.0)
            .max_by(|&a, &b| cpu[a].1[0].total_cmp(&cpu[b].1[0]))
            .expect("the torus faces the camera");
        let at = to_screen(&camera, size, scene.positions[expected]);
        let off = ((at.0 - best.1.0).powi(2) + (at.1 - best.1.1).powi(2)).sqrt();
        eprintln!(
            "camera at {degrees}°: brightest highlight pixel {:?}, the CPU's brightest vertex {expected} at {at:?}, {off:.1} px apart",
            best.1
        );
        assert!(
            off < 8.0,
            "camera at {degrees}°: the highlight is {off:.1} px from where the CPU puts it"
        );
        scene.positions[expected]
    };
    let moved = highlight(-30.0).distance(highlight(30.0));
    eprintln!("the highlight moved {moved:.3} over the torus");
    assert!(
        moved > 0.3,
        "the highlight moved only {moved:.3} over the torus"
    );
}

/// The command line reads a matrix bake and a compressed one from disk (version 2: the
/// clusters are kept, not only the reconstruction) and writes headless screenshots of both.
#[test]
fn the_command_line_shows_matrix_and_compressed_files() {
    if common::gpu().is_none() {
        return;
    }
    let folder = tempfile::tempdir().unwrap();
    let mut bake = matrix_bake();
    let matrix_path = folder.path().join("m.prt");
    bake.file.write(&matrix_path).unwrap();
    let compressed_bake = compressed(bake.clone());
    let cpca = compressed_bake.cpca.clone().unwrap();
    let bytes = prt_baker::formats::cpca_block::to_bytes(&bake.file, &cpca, 0.0);
    let compressed_path = folder.path().join("c.prt");
    std::fs::write(&compressed_path, bytes).unwrap();

    let loaded = Bake::load(&glossy_scene(), &compressed_path).unwrap();
    assert_eq!(loaded.cpca.as_ref(), Some(&cpca));
    assert!(loaded.is_matrix());
    assert_eq!(
        loaded.file.coefficients.len(),
        compressed_bake.file.coefficients.len()
    );

    for (input, name) in [(&matrix_path, "m.png"), (&compressed_path, "c.png")] {
        let png = folder.path().join(name);
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_prt-view"))
            .arg(glossy_scene())
            .arg(input)
            .args(["--headless", "--size", "96x64", "--screenshot"])
            .arg(&png)
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{}: {}",
            input.display(),
            String::from_utf8_lossy(&output.stderr)
        );
        let image = image::open(&png).unwrap().to_rgba8();
        assert_eq!(image.dimensions(), (96, 64));
    }
}
