//! Per-texel transfer (`prt-bake bake --lightmap`): analytic oracles at texels, agreement
//! with a per-vertex bake where texel points coincide with vertices, coverage of the atlas,
//! a contact shadow on a 4-vertex floor, and the texel file layout.

use glam::{DVec3, Vec2, Vec3};
use prt_baker::bake::lightmap::{self, Atlas, LightmapBake};
use prt_baker::formats::coefficient_file::CoefficientFile;
use prt_baker::math::sh;
use prt_baker::support::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer};
use prt_baker::{BakeOptions, Mode, Scene};
use prt_tests::*;

const Y00: f64 = 0.282_094_791_773_878_1;

fn bake_lightmap(scene: &Scene, atlas: Atlas, options: &BakeOptions) -> LightmapBake {
    let tracer = EmbreeTracer::new(scene, EmbreeOptions::default()).expect("embree scene");
    lightmap::bake(scene, Some(&tracer), options, atlas, &Silent).expect("lightmap bake")
}

/// The 4-vertex floor [−half, half]² at z = 0 (two triangles).
fn floor(half: f32) -> prt_baker::scene::Mesh {
    grid(
        "floor",
        Vec3::new(-half, -half, 0.0),
        Vec3::X * 2.0 * half,
        Vec3::Y * 2.0 * half,
        1,
    )
}

fn texel(bake: &LightmapBake, x: usize, y: usize) -> (Vec3, Vec<f64>) {
    let n = sh::coeff_count(bake.transfer.options.order);
    let i = y * bake.texels.width as usize + x;
    assert!(bake.texels.valid[i], "texel ({x}, {y}) is not valid");
    let t = bake.transfer.coefficients[i * n..(i + 1) * n]
        .iter()
        .map(|&c| f64::from(c))
        .collect();
    (bake.texels.positions[i], t)
}

#[test]
fn texel_under_a_coaxial_disk() {
    // A 4-vertex floor and a disk of radius 1 at height 1; on a 17² lightmap the centre
    // texel's point is the floor's centre, right under the disk (oracles.md).
    let (order, samples) = (4, 1 << 16);
    let scene = scene(vec![floor(1.0), disk(Vec3::Z, 1.0, 512)]);
    let atlas = Atlas::from_vertex_uvs(&scene, &floor_uvs(&scene, 1.0), 17, 17).unwrap();
    let bake = bake_lightmap(&scene, atlas, &shadowed(order, samples));
    assert_eq!(
        bake.texels.valid_count(),
        17 * 17,
        "the floor covers the atlas"
    );
    let (p, got) = texel(&bake, 8, 8);
    assert!(p.length() < 1e-6, "centre texel at {p}");
    let expected = band_moments(order, DVec3::Z, 0.0, std::f64::consts::FRAC_1_SQRT_2);
    assert_matches("texel under the disk", &got, &expected, samples);
}

#[test]
fn floor_texels_in_a_walls_shadow() {
    // A 4-vertex floor [−1, 1]² meeting a wall of height 1 at x = 1, 2,000 long. Every
    // texel of the middle row lies at d = 1 − x from the wall: T_00 follows oracles.md.
    let samples = 1 << 16;
    // Wound to face the floor (normal −x): leak detection takes back faces for insides.
    let wall = grid(
        "wall",
        Vec3::new(1.0, -1000.0, 0.0),
        Vec3::Z,
        Vec3::Y * 2000.0,
        1,
    );
    let scene = scene(vec![floor(1.0), wall]);
    let atlas = Atlas::from_vertex_uvs(&scene, &floor_uvs(&scene, 1.0), 17, 17).unwrap();
    let bake = bake_lightmap(&scene, atlas, &shadowed(1, samples));
    assert_eq!(bake.texels.valid_count(), 17 * 17, "the wall has no texels");
    let mut worst: f64 = 0.0;
    for x in 0..17 {
        let (p, got) = texel(&bake, x, 8);
        let d = 1.0 - f64::from(p.x);
        let expected = (1.0 + d / (d * d + 1.0).sqrt()) / (4.0 * std::f64::consts::PI.sqrt());
        let visible = 1.0 - 0.5 * (1.0 - 1.0 / (1.0 + 1.0 / (d * d)).sqrt());
        let tol = tolerance(Y00 * Y00 * visible * (1.0 - visible), samples);
        worst = worst.max((got[0] - expected).abs() / tol);
        assert!(
            (got[0] - expected).abs() <= tol,
            "texel {x} at d = {d:.4}: T00 {} vs {expected} ± {tol:.1e}",
            got[0]
        );
    }
    eprintln!("wall row: worst error {worst:.2} tolerances");
}

#[test]
fn texels_on_a_dense_grids_vertices_agree_with_the_vertex_bake() {
    // A 16×16-cell floor whose lightmap UVs put its 17×17 vertices at the 17² texel centres,
    // under a tilted, off-centre disk: every texel is baked at a vertex's point, so texel and
    // vertex transfer must agree within the Monte Carlo error of both.
    let (order, samples) = (3, 1 << 14);
    let cells = 16;
    let floor = grid(
        "floor",
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::X * 2.0,
        Vec3::Y * 2.0,
        cells,
    );
    let mut occluder = disk(Vec3::new(0.3, -0.2, 0.6), 0.7, 64);
    for p in &mut occluder.positions {
        p.z += 0.3 * p.x; // tilt it
    }
    let scene = scene(vec![floor, occluder]);
    let side = cells as f32 + 1.0;
    let uvs: Vec<Vec2> = scene
        .positions
        .iter()
        .enumerate()
        .map(|(v, _)| match v < 17 * 17 {
            true => (Vec2::new((v % 17) as f32, (v / 17) as f32) + 0.5) / side,
            false => Vec2::splat(-1.0),
        })
        .collect();
    let atlas = Atlas::from_vertex_uvs(&scene, &uvs, 17, 17).unwrap();
    let options = shadowed(order, samples);
    let texels = bake_lightmap(&scene, atlas, &options);
    // Another seed for the vertices: independent sample sets, so the comparison is one of
    // two Monte Carlo estimates. (With the same seed, texel k and vertex k share their
    // directions and agree to rounding, checked below.)
    let vertices = bake_scene(
        &scene,
        &BakeOptions {
            seed: 8,
            ..options.clone()
        },
    );
    let same_seed = bake_scene(&scene, &options);
    let mut same_seed_worst = 0.0f64;
    let bound = band_moments(order, DVec3::Z, 0.0, 1.0); // second moments bound the variance
    let (mut worst, mut shadowed_texels) = (0.0f64, 0);
    for v in 0..17 * 17 {
        let (x, y) = (v % 17, v / 17);
        let (p, t) = texel(&texels, x, y);
        assert!(
            p.distance(scene.positions[v]) < 1e-5,
            "texel ({x},{y}) at {p}"
        );
        let vt = vertices.vertex(v, 0);
        for (a, b) in t.iter().zip(same_seed.vertex(v, 0)) {
            same_seed_worst = same_seed_worst.max((a - f64::from(*b)).abs());
        }
        if vt[0] < 0.8 * bound.mean[0] as f32 {
            shadowed_texels += 1;
        }
        for j in 0..t.len() {
            let tol = std::f64::consts::SQRT_2 * tolerance(bound.second[j], samples);
            let err = (t[j] - f64::from(vt[j])).abs();
            worst = worst.max(err / tol);
            assert!(
                err <= tol,
                "texel ({x},{y}) j={j}: {} vs {} ± {tol:.1e}",
                t[j],
                vt[j]
            );
        }
    }
    eprintln!(
        "texel/vertex agreement: worst {worst:.3} tolerances, {shadowed_texels} texels in \
         shadow; same seed: largest difference {same_seed_worst:.1e}"
    );
    assert!(same_seed_worst < 1e-4, "same seed: {same_seed_worst}");
    assert!(
        shadowed_texels > 20,
        "the disk must shadow part of the floor"
    );
}

#[test]
fn a_four_vertex_floor_shows_a_sphere_contact_shadow() {
    // The motivating case: a sphere resting on a 4-vertex floor. Per vertex the floor sees no
    // shadow (its corners are far from the sphere); per texel, relit by a constant white sky
    // (radiance = T_0 · √(4π)), the texels under the sphere are far darker than the far ones.
    let samples = 1 << 12;
    let scene = scene(vec![floor(4.0), sphere(Vec3::Z, 1.0, 8, 16)]);
    let options = shadowed(1, samples);
    let corners = bake_vertices(&scene, &options, &[0, 1, 2, 3]);
    let sky = (4.0 * std::f64::consts::PI).sqrt();
    for c in &corners {
        assert!(c[0] * sky > 0.97, "a floor corner is lit: {}", c[0] * sky);
    }
    let atlas = Atlas::generate(&scene, 96, None).unwrap();
    let bake = bake_lightmap(&scene, atlas, &options);
    let (mut under, mut far) = (Vec::new(), Vec::new());
    for (i, p) in bake.texels.positions.iter().enumerate() {
        let floor_texel = bake.texels.valid[i] && p.z.abs() < 1e-6;
        let radiance = f64::from(bake.transfer.coefficients[i]) * sky;
        if floor_texel && Vec2::new(p.x, p.y).length() < 0.3 {
            under.push(radiance);
        }
        if floor_texel && Vec2::new(p.x, p.y).length() > 3.5 {
            far.push(radiance);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    assert!(
        under.len() >= 4 && far.len() >= 20,
        "{} {}",
        under.len(),
        far.len()
    );
    let (under, far) = (mean(&under), mean(&far));
    eprintln!(
        "contact shadow: under the sphere {under:.4}, far {far:.4}, ratio {:.3}",
        under / far
    );
    // Measured (seed 7, 4,096 rays): under = 0.22 × far. Within 0.3 of the contact point a
    // unit sphere hides most of the sky; beyond 3.5 it hides under 3 %.
    assert!(far > 0.97, "far texels are lit: {far}");
    assert!(under < 0.3 * far, "under {under} vs far {far}");
}

#[test]
fn every_chart_texel_is_set_and_nothing_else() {
    // The Cornell box unwrapped into 64²: the texel under each triangle's UV centroid is
    // valid (so no texel inside a chart is unset), valid texels hold finite transfer and
    // unit normals; every texel within 2 of a valid one is dilated into, the rest hold zeros.
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell/cornell.scene");
    let scene = Scene::load(&path).expect("cornell scene");
    let atlas = Atlas::generate(&scene, 64, None).unwrap();
    let options = BakeOptions {
        mode: Mode::Unshadowed,
        samples: 64,
        ..shadowed(3, 64)
    };
    let bake = lightmap::bake(&scene, None, &options, atlas.clone(), &Silent).unwrap();
    let n = 9;
    for (t, uv) in atlas.uv1.iter().enumerate() {
        let c = (uv[0] + uv[1] + uv[2]) / 3.0 * 64.0;
        let i = c.y as usize * 64 + c.x as usize;
        assert!(
            bake.texels.valid[i],
            "triangle {t}'s centroid texel is unset"
        );
    }
    let near_valid = |i: usize| {
        let (x, y) = ((i % 64) as isize, (i / 64) as isize);
        (-2..=2).any(|dy| {
            (-2..=2).any(|dx| {
                let (nx, ny) = (x + dx, y + dy);
                (0..64).contains(&nx)
                    && (0..64).contains(&ny)
                    && bake.texels.valid[(ny * 64 + nx) as usize]
            })
        })
    };
    let mut padding = 0;
    for (i, valid) in bake.texels.valid.iter().enumerate() {
        let coeffs = &bake.transfer.coefficients[i * n..(i + 1) * n];
        if *valid {
            assert!(coeffs.iter().all(|c| c.is_finite()) && coeffs[0] > 0.0);
            assert!((bake.texels.normals[i].length() - 1.0).abs() < 1e-5);
            assert!(!bake.dilated[i]);
        } else if near_valid(i) {
            assert!(bake.dilated[i], "padding texel {i} is empty");
            assert!(coeffs.iter().all(|c| c.is_finite()) && coeffs[0] > 0.0);
            padding += 1;
        } else {
            assert!(!bake.dilated[i]);
            assert!(coeffs.iter().all(|&c| c == 0.0));
        }
    }
    assert!(padding > 0);
    // Charts never share a texel: padding keeps them apart.
    let valid = bake.texels.valid_count();
    assert!(
        valid > 64 * 64 / 4,
        "the charts fill the atlas: {valid} texels"
    );
}

#[test]
fn a_texel_file_round_trips_and_refuses_vertex_readers() {
    let scene = scene(vec![floor(1.0), disk(Vec3::Z, 1.0, 16)]);
    let atlas = Atlas::generate(&scene, 16, None).unwrap();
    let options = BakeOptions {
        aux: prt_baker::bake::transfer::Aux {
            ao: true,
            bent_normal: true,
        },
        ..shadowed(2, 64)
    };
    let bake = bake_lightmap(&scene, atlas, &options);
    let file = CoefficientFile::from_lightmap_bake(&scene, &bake);
    let (bytes, _) = file.to_bytes();
    assert_eq!(u32::from_le_bytes(bytes[12..16].try_into().unwrap()), 160);
    let read = CoefficientFile::from_bytes(&bytes).expect("valid texel file");
    let block = read.lightmap.as_ref().expect("a lightmap block");
    assert_eq!((block.width, block.height), (16, 16));
    assert_eq!(block.valid, bake.texels.valid);
    assert_eq!(block.dilated, bake.dilated);
    assert!(block.dilated.iter().any(|&d| d));
    assert_eq!(block.uv1, bake.atlas.uv1);
    assert_eq!(read.coefficients, bake.transfer.coefficients);
    let path = std::path::Path::new("t.prt");
    assert!(
        read.check_scene(path, &scene).is_err(),
        "vertex readers refuse it"
    );
    assert!(read.check_lightmap_scene(path, &scene).is_ok());
    // A damaged validity mask is refused (here by the checksum).
    let mut bad = bytes.clone();
    let last = bad.len() - 1;
    bad[last] = 2;
    assert!(CoefficientFile::from_bytes(&bad).is_err());
}

#[test]
fn texels_inside_a_sphere_are_left_out_as_leaking_and_filled() {
    // A 4-vertex floor passing through a closed sphere of radius 0.5: floor texels inside
    // it see only the sphere's back faces, so they leak; those outside see its front.
    let scene = scene(vec![floor(1.0), sphere(Vec3::ZERO, 0.5, 16, 32)]);
    let atlas = Atlas::from_vertex_uvs(&scene, &floor_uvs(&scene, 1.0), 33, 33).unwrap();
    let bake = bake_lightmap(&scene, atlas, &shadowed(1, 256));
    let (mut inside, mut outside) = (0, 0);
    for (i, p) in bake.texels.positions.iter().enumerate() {
        let r = Vec2::new(p.x, p.y).length();
        if r < 0.45 {
            assert!(
                !bake.texels.valid[i],
                "texel at r = {r} is inside the sphere"
            );
            inside += 1;
        } else if r > 0.55 {
            assert!(
                bake.texels.valid[i],
                "texel at r = {r} is outside the sphere"
            );
            outside += 1;
        }
    }
    assert!(
        inside > 100 && outside > 500,
        "{inside} inside, {outside} outside"
    );
    assert!(bake.leaking >= inside, "{} reported leaking", bake.leaking);
    // The ring just inside the sphere's edge is filled from outside texels.
    assert!(bake.dilated.iter().any(|&d| d));
}

/// Chart seams are stitched: the demo torus unwrapped into 64², where the
/// unwrapper cuts the smooth surface into charts, must read the same on both sides of every
/// seam after the bake, to a small part of the step it had before, and the texels the seams do
/// not read keep their baked values (`baker/src/bake/lightmap/stitch.rs`).
#[test]
fn chart_seams_are_stitched() {
    let torus =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/torus/torus.scene");
    let scene = Scene::load(&torus).expect("the demo torus");
    let options = shadowed(4, 256);
    let atlas = Atlas::generate(&scene, 64, None).unwrap();
    let bake = bake_lightmap(&scene, atlas, &options);
    let seams = bake.seams;
    eprintln!(
        "seams: {} samples, step {:.2e} before, {:.2e} after",
        seams.samples, seams.step_before, seams.step_after
    );
    assert!(
        seams.samples > 100,
        "the torus's charts meet at seams: {seams:?}"
    );
    assert!(
        seams.step_before > 1e-3,
        "the unstitched bake steps: {seams:?}"
    );
    assert!(
        seams.step_after < seams.step_before / 10.0,
        "the seams still step: {seams:?}"
    );
}
