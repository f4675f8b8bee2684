//! `--mover-occluder`: the viewer's per-frame shadowed transfer (occluders.rs) relit by a light
//! equals `prt-bake relight --occluder`'s triple product (`OccludedLight`) per vertex, darkens
//! the floor under the ball and leaves vertices out of reach as baked.

mod common;

use glam::{DQuat, Vec3};
use prt_baker::export::relight_occluded::OccludedLight;
use prt_baker::formats::occluder_file::{LocalSphere, OccluderFile};
use prt_baker::light::Rig;
use prt_baker::{BakeOptions, Mode};
use prt_viewer::occluders::MoverShadow;

#[test]
fn the_shadowed_transfer_relights_as_relight_occluder_does() {
    let bake = common::bake(
        &common::workspace().join("scenes/cornell/cornell.scene"),
        BakeOptions {
            order: 4,
            samples: 64,
            mode: Mode::Shadowed,
            seed: 1,
            ..BakeOptions::default()
        },
    );
    let ball = OccluderFile {
        spheres: vec![LocalSphere {
            centre: Vec3::ZERO,
            radius: 0.25,
        }],
    };
    let at = Vec3::new(-0.5, -0.55, 0.27);
    let shadow = MoverShadow::new(&bake, ball.clone()).unwrap();
    let start = std::time::Instant::now();
    let shadowed = shadow.transfer((at, DQuat::IDENTITY));
    println!(
        "a frame's shadowed transfer: {:.2} ms",
        start.elapsed().as_secs_f64() * 1e3
    );
    let rig = common::workspace().join("viewer/src/default-rig.toml");
    let light = Rig::load(&rig).unwrap().project(4);
    let reference = OccludedLight::new(&light);
    let spheres = ball.placed(at.as_dvec3(), DQuat::IDENTITY);
    let channels = bake.channels();
    let (mut darker, mut worst) = (0, 0.0f64);
    for v in 0..bake.scene.vertex_count() {
        let t = |c: usize, data: &[f32]| {
            let at = (v * channels + if channels == 3 { c } else { 0 }) * 16;
            data[at..at + 16].to_vec()
        };
        let base = &bake.file.coefficients;
        let expected = reference.radiance(
            [&t(0, base)[..], &t(1, base)[..], &t(2, base)[..]],
            bake.scene.positions[v],
            bake.scene.normals[v],
            &spheres,
        );
        for (c, e) in expected.iter().enumerate() {
            let dot = |data: &[f32]| -> f64 {
                t(c, data)
                    .iter()
                    .zip(&light.rgb[c])
                    .map(|(a, b)| f64::from(*a) * b)
                    .sum()
            };
            let got = dot(&shadowed);
            worst = worst.max((got - e).abs() / e.abs().max(1e-2));
            if bake.scene.positions[v].distance(at) > 2.5 + 1e-3 {
                assert_eq!(
                    t(c, &shadowed),
                    t(c, base),
                    "vertex {v} out of reach changed"
                );
            } else if got < dot(base) - 1e-3 {
                darker += 1;
            }
        }
    }
    assert!(worst < 1e-4, "largest relative difference {worst}");
    assert!(darker > 100, "{darker} vertex channels darker");
}

/// The radiance map (RGB per texel, row-major) a PRT frame of `frame` leaves, the lightmap
/// shadowed by `spheres` (none: the plain pass), with the transfer stored as `storage` asks.
fn radiance_map(
    gpu: &prt_viewer::Gpu,
    bake: &prt_viewer::Bake,
    frame: &prt_viewer::FrameInputs,
    spheres: &[prt_baker::math::occlusion::Sphere],
    storage: prt_viewer::texel_transfer::TexelStorage,
) -> Vec<[f32; 3]> {
    let mut renderer = prt_viewer::Renderer::with_texel_storage(
        &gpu.device,
        &gpu.queue,
        bake,
        prt_viewer::offscreen::FORMAT,
        (64, 48),
        storage,
    )
    .unwrap();
    renderer.add_occluders(&gpu.device, bake).unwrap();
    renderer.set_occluder_spheres(&gpu.queue, spheres).unwrap();
    prt_viewer::offscreen::render_image(&gpu.device, &gpu.queue, &mut renderer, frame).unwrap();
    let texture = renderer.texel_radiance().expect("a radiance map");
    let bytes = prt_viewer::offscreen::read_texture(&gpu.device, &gpu.queue, texture, 8).unwrap();
    let halves: Vec<f32> = bytes
        .chunks_exact(2)
        .map(|b| common::from_f16(u16::from_le_bytes([b[0], b[1]])))
        .collect();
    halves.chunks_exact(4).map(|t| [t[0], t[1], t[2]]).collect()
}

#[test]
fn a_lightmap_is_darkened_per_texel_as_relight_occluder_does() {
    // The Cornell room baked per texel (64² atlas), order 4 RGB interreflected and order 3
    // grey shadowed (an odd order pads each channel's last vec4), shadowed by two balls (one
    // of two spheres, turned) under the viewer's default rig: the radiance pass's occluded
    // texels (texel_occluders.rs, f32 on the device, half floats stored) against
    // `OccludedLight` at the texel points `prt-bake relight --occluder` uses, in both transfer
    // storages. Every texel within 2⁻⁹ of itself plus 2·10⁻⁴ of the largest value (half-float
    // rounding, f32 sums); the shadow is there (texels darker than unshadowed).
    let interreflected = BakeOptions {
        order: 4,
        samples: 32,
        mode: Mode::Interreflected,
        bounces: 1,
        seed: 1,
        ..BakeOptions::default()
    };
    let shadowed = BakeOptions {
        order: 3,
        samples: 32,
        mode: Mode::Shadowed,
        seed: 1,
        ..BakeOptions::default()
    };
    for options in [interreflected, shadowed] {
        darkened_like_relight(&options);
    }
}

fn darkened_like_relight(options: &BakeOptions) {
    use prt_baker::bake::lightmap::{self, Atlas};
    use prt_viewer::texel_transfer::TexelStorage;
    let Some(gpu) = common::gpu() else { return };
    let scene =
        prt_baker::Scene::load(&common::workspace().join("scenes/cornell/cornell.scene")).unwrap();
    let atlas = Atlas::generate(&scene, 64, None).unwrap();
    let tracer = prt_baker::trace::EmbreeTracer::new(&scene, Default::default()).unwrap();
    let baked = lightmap::bake(
        &scene,
        Some(&tracer),
        options,
        atlas,
        &prt_baker::support::progress::Silent,
    )
    .unwrap();
    let file = prt_baker::CoefficientFile::from_lightmap_bake(&scene, &baked);
    let bake = prt_viewer::Bake::new(scene.clone(), file, std::path::Path::new("lm.prt")).unwrap();
    let rig = Rig::load(&common::workspace().join("viewer/src/default-rig.toml")).unwrap();
    let lights = prt_viewer::lights::Lights::from_rig(&rig, options.order).for_up(bake.up());
    let view = prt_viewer::controls::View::new(
        prt_viewer::camera::Camera::framing(&scene.positions, 4.0 / 3.0),
        lights,
    );
    let frame = prt_viewer::FrameInputs::from_view(&view, None);
    let pair = OccluderFile {
        spheres: vec![
            LocalSphere {
                centre: Vec3::new(-0.12, 0.0, 0.0),
                radius: 0.15,
            },
            LocalSphere {
                centre: Vec3::new(0.12, 0.0, 0.05),
                radius: 0.12,
            },
        ],
    };
    let mut spheres = pair.placed(
        glam::DVec3::new(-0.5, -0.55, 0.2),
        DQuat::from_axis_angle(glam::DVec3::Z, 0.7),
    );
    spheres.extend(pair.placed(glam::DVec3::new(0.4, 0.3, 0.6), DQuat::IDENTITY));
    let reference = OccludedLight::new(&frame.prt_light);
    let block = bake.lightmap().unwrap();
    let (points, normals) = prt_baker::export::relight_occluded::texel_points(&scene, block);
    let ones = vec![Vec3::ONE; points.len()];
    let want = reference.file_radiance(&bake.file, (&points, &normals), &ones, &spheres);
    let largest = want.iter().flatten().fold(0.0f32, |m, x| m.max(x.abs()));
    let plain = radiance_map(&gpu, &bake, &frame, &[], TexelStorage::Fit);
    for storage in [TexelStorage::Fit, TexelStorage::Array] {
        let got = radiance_map(&gpu, &bake, &frame, &spheres, storage);
        assert_eq!(got.len(), want.len());
        let (mut worst, mut darker) = (0.0f32, 0);
        for ((g, w), p) in got.iter().zip(&want).zip(&plain) {
            for c in 0..3 {
                let bound = 2f32.powi(-9) * w[c].abs() + 2e-4 * largest;
                worst = worst.max((g[c] - w[c]).abs() / bound);
                darker += usize::from(g[c] < p[c] - 0.01 * largest);
            }
        }
        eprintln!(
            "order {}, {} channel(s), {storage:?}: {} texels, largest {largest:.3}, worst error {worst:.3} of the bound, {darker} texel channels darker than unshadowed",
            options.order,
            bake.channels(),
            got.len()
        );
        assert!(worst <= 1.0, "{storage:?}: {worst} × the bound");
        assert!(darker > 300, "{storage:?}: {darker} texel channels darker");
    }
}

#[test]
fn the_bench_times_moving_occluders_over_a_lightmap() {
    // `prt-view --bench --bench-occluder OCC --bench-occluders 2` on a 32² lightmap of the
    // Cornell room: the table has the occluded rows and their ratio to PRT; an occluder of too
    // many spheres for a lightmap (2 × 40 > 64) is refused with exit code 3.
    use prt_baker::bake::lightmap::{self, Atlas};
    let folder = tempfile::tempdir().unwrap();
    let cornell = common::workspace().join("scenes/cornell/cornell.scene");
    let scene = prt_baker::Scene::load(&cornell).unwrap();
    let tracer = prt_baker::trace::EmbreeTracer::new(&scene, Default::default()).unwrap();
    let options = BakeOptions {
        order: 4,
        samples: 8,
        mode: Mode::Shadowed,
        seed: 1,
        ..BakeOptions::default()
    };
    let atlas = Atlas::generate(&scene, 32, None).unwrap();
    let baked = lightmap::bake(
        &scene,
        Some(&tracer),
        &options,
        atlas,
        &prt_baker::support::progress::Silent,
    )
    .unwrap();
    let prt = folder.path().join("lm.prt");
    prt_baker::CoefficientFile::from_lightmap_bake(&scene, &baked)
        .write(&prt)
        .unwrap();
    let ball = |spheres: usize, name: &str| {
        let path = folder.path().join(name);
        let file = OccluderFile {
            spheres: (0..spheres)
                .map(|k| LocalSphere {
                    centre: Vec3::new(0.01 * k as f32, 0.0, 0.0),
                    radius: 0.2,
                })
                .collect(),
        };
        std::fs::write(&path, file.to_bytes()).unwrap();
        path
    };
    let run = |occ: &std::path::Path| {
        std::process::Command::new(env!("CARGO_BIN_EXE_prt-view"))
            .arg(&cornell)
            .arg(&prt)
            .args([
                "--bench",
                "--bench-frames",
                "2",
                "--size",
                "64x48",
                "--bench-occluders",
                "2",
            ])
            .arg("--bench-occluder")
            .arg(occ)
            .output()
            .unwrap()
    };
    let output = run(&ball(1, "ball.occ"));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(stdout.contains("| PRT, 2 moving occluders |"), "{stdout}");
    assert!(
        stdout.contains("PRT with moving occluders / PRT: "),
        "{stdout}"
    );
    let output = run(&ball(40, "many.occ"));
    assert_eq!(
        output.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
}

#[test]
fn prt_view_shadows_a_lightmap_where_the_mover_stands() {
    // The command line end to end on a lightmap: the Cornell room's 48² texel bake, a ball
    // (its own bake, an occluder of one sphere) lit by a 2³ probe grid and standing on the
    // floor; `--mover-occluder` must darken the frame (the mover's placement reaches the
    // radiance pass each frame) and brighten nothing.
    use prt_baker::bake::lightmap::{self, Atlas};
    use prt_baker::bake::probes::{self, ProbeSpec};
    use prt_baker::support::progress::Silent;
    let folder = tempfile::tempdir().unwrap();
    let dir = folder.path();
    let cornell = common::workspace().join("scenes/cornell/cornell.scene");
    let scene = prt_baker::Scene::load(&cornell).unwrap();
    let tracer = prt_baker::trace::EmbreeTracer::new(&scene, Default::default()).unwrap();
    let options = |samples| BakeOptions {
        order: 4,
        samples,
        mode: Mode::Shadowed,
        seed: 1,
        ..BakeOptions::default()
    };
    let atlas = Atlas::generate(&scene, 48, None).unwrap();
    let baked = lightmap::bake(&scene, Some(&tracer), &options(16), atlas, &Silent).unwrap();
    prt_baker::CoefficientFile::from_lightmap_bake(&scene, &baked)
        .write(&dir.join("room.prt"))
        .unwrap();
    let block = ProbeSpec::parse("grid:2,2,2")
        .unwrap()
        .probes(&scene)
        .unwrap();
    let transfer = probes::bake(
        &scene,
        Some(&tracer),
        &options(64),
        &block.positions,
        &Silent,
    )
    .unwrap();
    prt_baker::CoefficientFile::from_probe_bake(&scene, &transfer, Some(&tracer), block)
        .write(&dir.join("probes.prt"))
        .unwrap();
    // A ball of radius 0.25 (a coarse UV sphere: enough for its own bake).
    let (rings, segments) = (8, 12);
    let mut obj = String::from("o ball\n");
    for i in 0..=rings {
        for j in 0..segments {
            let (t, p) = (
                std::f32::consts::PI * i as f32 / rings as f32,
                std::f32::consts::TAU * j as f32 / segments as f32,
            );
            let v = 0.25 * Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
            obj += &format!("v {} {} {}\n", v.x, v.y, v.z);
        }
    }
    let at = |i: usize, j: usize| i * segments + j % segments + 1;
    for i in 0..rings {
        for j in 0..segments {
            obj += &format!("f {} {} {}\n", at(i, j), at(i + 1, j), at(i + 1, j + 1));
            obj += &format!("f {} {} {}\n", at(i, j), at(i + 1, j + 1), at(i, j + 1));
        }
    }
    std::fs::write(dir.join("ball.obj"), obj).unwrap();
    let mut ball = common::bake(&dir.join("ball.obj"), options(64));
    ball.file.write(&dir.join("ball.prt")).unwrap();
    let occluder = OccluderFile {
        spheres: vec![LocalSphere {
            centre: Vec3::ZERO,
            radius: 0.25,
        }],
    };
    std::fs::write(dir.join("ball.occ"), occluder.to_bytes()).unwrap();
    // The default rig, windowed: under the unwindowed order-4 sun a ball blocking its
    // negative lobes brightens some receivers (217 pixels here; docs/guides/occluders.md,
    // "Limits").
    let rig = std::fs::read_to_string(common::workspace().join("viewer/src/default-rig.toml"));
    std::fs::write(
        dir.join("rig.toml"),
        format!("window = \"hanning\"\n{}", rig.unwrap()),
    )
    .unwrap();
    let shot = |extra: &[&str], png: &str| {
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_prt-view"))
            .arg(&cornell)
            .arg(dir.join("room.prt"))
            .args([
                "--probes",
                "probes.prt",
                "--mover",
                "ball.obj",
                "--mover-prt",
            ])
            .args([
                "ball.prt",
                "--path",
                "-0.4,-0.3,0.27;0.4,-0.3,0.27",
                "--mover-at",
                "0.5",
            ])
            .args([
                "--hide-probes",
                "--size",
                "160x120",
                "--headless",
                "--screenshot",
                png,
            ])
            .args(["--lights", "rig.toml"])
            .args(extra)
            .current_dir(dir)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{stderr}");
        image::open(dir.join(png)).unwrap().to_rgba8()
    };
    let plain = shot(&[], "plain.png");
    let shadowed = shot(&["--mover-occluder", "ball.occ"], "shadowed.png");
    let (mut darker, mut brighter) = (0, 0);
    for (a, b) in plain.pixels().zip(shadowed.pixels()) {
        let sum = |p: &image::Rgba<u8>| p.0[..3].iter().map(|&c| i32::from(c)).sum::<i32>();
        darker += usize::from(sum(b) < sum(a) - 6);
        brighter += usize::from(sum(b) > sum(a) + 6);
    }
    eprintln!("{darker} pixels darker, {brighter} brighter with the mover's shadow");
    assert!(darker > 300, "{darker} pixels darker");
    assert!(
        brighter < darker / 20,
        "{brighter} brighter, {darker} darker"
    );
}
