//! Texel bakes at seams: watertight by default (the Cornell room's texels agree
//! with `--robust` as its vertices do, `tests/agreement.rs`), leaking texels
//! that straddle a wall moved out rather than left out.

use glam::{Vec2, Vec3};
use prt_baker::bake::lightmap::{self, Atlas, LightmapBake};
use prt_baker::bake::transfer::{Estimator, Receivers, Scratch};
use prt_baker::math::sh;
use prt_baker::scene::Mesh;
use prt_baker::support::progress::Silent;
use prt_baker::trace::seams::seam_points;
use prt_baker::trace::{EmbreeMode, ObvhsOptions, ObvhsTracer, Tracer};
use prt_baker::{BakeOptions, Mode, Scene};
use prt_tests::*;

fn bake(scene: &Scene, tracer: &dyn Tracer, atlas: Atlas, options: &BakeOptions) -> LightmapBake {
    lightmap::bake(scene, Some(tracer), options, atlas, &Silent).expect("texel bake")
}

/// One texel's coefficients.
fn coefficients(bake: &LightmapBake, i: usize) -> &[f32] {
    let n = sh::coeff_count(bake.transfer.options.order);
    &bake.transfer.coefficients[i * n..(i + 1) * n]
}

const COEFFICIENT_TOLERANCE: f32 = 1e-3;
const TEXEL_AGREEMENT: f64 = 0.999;

/// The fraction of the texels in `among` whose coefficients agree within
/// [`COEFFICIENT_TOLERANCE`]; a texel valid in one bake and not in the other (the leak test
/// decided otherwise) counts as outside.
fn agreement(name: &str, a: &LightmapBake, b: &LightmapBake, among: &[bool]) -> f64 {
    let (mut count, mut outside, mut validity, mut worst) = (0usize, 0usize, 0usize, 0.0f32);
    for i in (0..among.len()).filter(|&i| among[i]) {
        // Left out of both bakes (leaking): its dilated value is its neighbours' mean.
        if !a.texels.valid[i] && !b.texels.valid[i] {
            continue;
        }
        count += 1;
        if a.texels.valid[i] != b.texels.valid[i] {
            validity += 1;
            outside += 1;
            continue;
        }
        let diff = coefficients(a, i)
            .iter()
            .zip(coefficients(b, i))
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max);
        worst = worst.max(diff);
        outside += usize::from(diff > COEFFICIENT_TOLERANCE);
    }
    let agreement = 1.0 - outside as f64 / count as f64;
    eprintln!(
        "{name}: {outside} of {count} texels outside {COEFFICIENT_TOLERANCE:e} ({validity} valid in one bake only; {:.3} % agree), largest difference {worst:.2e}",
        100.0 * agreement
    );
    agreement
}

/// The Cornell room baked per texel (128², order 4, 1,024 rays, one seed) with the default
/// Embree tracer, robust Embree and obvhs: the default agrees with robust Embree on ≥ 99.9 %
/// of all texels and of the seam texels (where Embree's fast mode everywhere, reported, does
/// not); so does obvhs, which also bakes the same texels (all but 0.1 %).
#[test]
fn cornell_room_texel_bakes_agree() {
    let scene = Scene::load(&demo_path("cornell/cornell.scene")).expect("the Cornell room");
    let options = BakeOptions {
        order: 4,
        samples: 1024,
        mode: Mode::Shadowed,
        seed: 11,
        ..BakeOptions::default()
    };
    let atlas = || Atlas::generate(&scene, 128, None).expect("atlas");
    let default = embree_tracer(&scene, EmbreeMode::Watertight);
    // The default tracer does route seam texels into robust mode.
    let texels = lightmap::Texels::rasterise(&scene, &atlas());
    let (origins, own): (Vec<Vec3>, Vec<u32>) = (0..texels.valid.len())
        .filter(|&i| texels.valid[i])
        .map(|i| (texels.origins[i], texels.triangle[i]))
        .unzip();
    let points = default
        .watertight_for(&scene, &origins, &own)
        .expect("robust scene")
        .expect("the Cornell room has seam texels");
    eprintln!(
        "cornell room: {} of {} texel ray origins traced in robust mode",
        points.seam_origin_count() - default.seam_origin_count(),
        origins.len()
    );
    assert!(points.seam_origin_count() > default.seam_origin_count());
    let seam = seam_points(&scene, &origins, &own);
    let mut at_seams = vec![false; texels.valid.len()];
    for (i, s) in (0..texels.valid.len())
        .filter(|&i| texels.valid[i])
        .zip(seam)
    {
        at_seams[i] = s;
    }

    let baked_default = bake(&scene, &default, atlas(), &options);
    let robust = bake(
        &scene,
        &embree_tracer(&scene, EmbreeMode::Robust),
        atlas(),
        &options,
    );
    let obvhs = ObvhsTracer::new(&scene, ObvhsOptions::default());
    let baked_obvhs = bake(&scene, &obvhs, atlas(), &options);
    let fast = bake(
        &scene,
        &embree_tracer(&scene, EmbreeMode::Fast),
        atlas(),
        &options,
    );
    let all = &texels.valid;
    for (subset, among) in [("", all), (" at seams", &at_seams)] {
        agreement(
            &format!("cornell texels{subset}, Embree fast mode against robust (reported only)"),
            &fast,
            &robust,
            among,
        );
        let agree = agreement(
            &format!("cornell texels{subset}, default against robust"),
            &baked_default,
            &robust,
            among,
        );
        assert!(
            agree >= TEXEL_AGREEMENT,
            "default against robust{subset}: {:.3} % of texels agree",
            100.0 * agree
        );
        // Each texel samples the stream of its texel index, so the few leaking texels
        // obvhs and Embree decide differently do not change any other texel's samples.
        let agree = agreement(
            &format!("cornell texels{subset}, obvhs against robust"),
            &baked_obvhs,
            &robust,
            among,
        );
        assert!(
            agree >= TEXEL_AGREEMENT,
            "obvhs against robust{subset}: {:.3} % of texels agree",
            100.0 * agree
        );
    }
    // Which texels are baked: obvhs and Embree agree on all but 0.1 %.
    let differ = (0..all.len())
        .filter(|&i| baked_obvhs.texels.valid[i] != robust.texels.valid[i])
        .count();
    let baked = robust.texels.valid_count();
    eprintln!("cornell texels: {differ} of {baked} valid in only one of obvhs and robust Embree");
    assert!(differ as f64 <= (1.0 - TEXEL_AGREEMENT) * baked as f64);
}

fn demo_path(relative: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(relative)
}

/// A closed box without a bottom, standing on z = 0: x in [x0, x1], y in [y0, y1], height h,
/// faces wound outwards.
fn open_box(x0: f32, x1: f32, y0: f32, y1: f32, h: f32) -> Vec<Mesh> {
    let (dx, dy, dz) = (Vec3::X * (x1 - x0), Vec3::Y * (y1 - y0), Vec3::Z * h);
    vec![
        grid("top", Vec3::new(x0, y0, h), dx, dy, 4),
        grid("west", Vec3::new(x0, y0, 0.0), dz, dy, 4),
        grid("east", Vec3::new(x1, y0, 0.0), dy, dz, 4),
        grid("south", Vec3::new(x0, y0, 0.0), dx, dz, 4),
        grid("north", Vec3::new(x0, y1, 0.0), dz, dx, 4),
    ]
}

/// The transfer of one point on the floor (normal +z), baked alone with `tracer`.
fn point_transfer(tracer: &dyn Tracer, options: &BakeOptions, at: Vec3) -> Vec<f32> {
    let receivers = Receivers {
        origins: vec![at + Vec3::Z * 1e-5],
        normals: vec![Vec3::Z],
        horizons: None,
        streams: None,
        strata: None,
    };
    let estimator = Estimator::for_receivers(receivers, options).expect("valid options");
    let n = sh::coeff_count(options.order);
    let mut out = vec![0.0f32; n];
    estimator.receiver_transfer(0, Some(tracer), &mut Scratch::new(n), &mut out, None);
    out
}

/// A 33² floor lightmap (texels 2/33 wide) under a box whose west wall, at x = 0.23, cuts the
/// texel column [0.212, 0.273] off centre: those texels' centres are inside the box (they
/// leak) but part of their footprint is outside. They move out to the wall's foot and get the
/// transfer of a point just outside it; texels wholly inside stay left out.
#[test]
fn floor_texels_half_under_a_wall_move_out() {
    let (x0, x1, y0, y1) = (0.23, 0.6, -0.3, 0.3);
    let mut meshes = vec![grid(
        "floor",
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::X * 2.0,
        Vec3::Y * 2.0,
        1,
    )];
    meshes.extend(open_box(x0, x1, y0, y1, 0.5));
    let scene = scene(meshes);
    let options = shadowed(2, 4096);
    let tracer = embree_tracer(&scene, EmbreeMode::Watertight);
    let atlas = Atlas::from_vertex_uvs(&scene, &floor_uvs(&scene, 1.0), 33, 33).expect("atlas");
    let baked = bake(&scene, &tracer, atlas, &options);
    let size = 2.0 / 33.0;
    let (mut moved, mut inside) = (0, 0);
    for y in 0..33 {
        let cy = -1.0 + (y as f32 + 0.5) * size;
        // Rows whose footprint lies within the box's y range.
        if cy - size / 2.0 < y0 || cy + size / 2.0 > y1 {
            continue;
        }
        for x in 0..33 {
            let i = y * 33 + x;
            let cx = -1.0 + (x as f32 + 0.5) * size;
            if x == 20 {
                // The straddling column: moved to the outside of the wall, within the texel.
                assert!(baked.texels.valid[i], "texel ({x}, {y}) moved out");
                let p = baked.texels.positions[i];
                assert!(
                    p.x < x0 && p.x > x0 - size / 8.0 && (p.y - cy).abs() < 1e-5,
                    "texel ({x}, {y}) at {p}"
                );
                let reference = point_transfer(&tracer, &shadowed(2, 4096 * 4), {
                    Vec3::new(x0 - 1e-3, cy, 0.0)
                });
                let got = coefficients(&baked, i);
                for (j, (g, r)) in got.iter().zip(&reference).enumerate() {
                    assert!(
                        (g - r).abs() < 0.02,
                        "texel ({x}, {y}) coefficient {j}: {g} against {r} just outside the wall"
                    );
                }
                // Half the hemisphere is behind the wall: far from the box's dark inside.
                assert!(got[0] > 0.3 * reference[0].max(0.1), "{got:?}");
                moved += 1;
            } else if (cx - size / 2.0 > x0) && (cx + size / 2.0 < x1) {
                assert!(!baked.texels.valid[i], "texel ({x}, {y}) inside the box");
                inside += 1;
            }
        }
    }
    eprintln!(
        "{moved} texels checked as moved out, {inside} inside; the bake: {} moved out, {} left \
         out as leaking",
        baked.moved, baked.leaking
    );
    assert!(moved >= 8 && inside >= 40, "{moved} moved, {inside} inside");
    assert!(baked.moved >= moved && baked.leaking >= inside);
}

/// A corner of a room built from separate boards meeting at their edges (floor, two walls),
/// the floor's lightmap laid out so texel points fall on its grid's vertices: the points along
/// the walls' feet lie on the walls' bottom edges, where Embree's fast mode leaks. The default
/// tracer routes them into robust mode, so its bake agrees with robust Embree on ≥ 99.9 % of
/// texels; the fast mode's agreement is reported.
#[test]
fn floor_texels_at_the_foot_of_walls_are_watertight() {
    let cells = 24;
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    let scene = scene(vec![
        grid("floor", Vec3::ZERO, x, y, cells),
        grid("wall x", Vec3::ZERO, y, z, cells),
        grid("wall y", Vec3::ZERO, z, x, cells),
    ]);
    // Texel k's centre at floor vertex k: uv = (p·(R − 1) + ½)/R with R = cells + 1.
    let r = (cells + 1) as f32;
    let uvs: Vec<Vec2> = scene
        .positions
        .iter()
        .zip(&scene.normals)
        .map(|(p, n)| match p.z == 0.0 && n.z > 0.99 {
            true => (Vec2::new(p.x, p.y) * (r - 1.0) + Vec2::splat(0.5)) / r,
            false => Vec2::splat(-1.0),
        })
        .collect();
    let atlas = || Atlas::from_vertex_uvs(&scene, &uvs, cells + 1, cells + 1).expect("atlas");
    let options = BakeOptions {
        order: 4,
        samples: 4096,
        mode: Mode::Shadowed,
        seed: 11,
        ..BakeOptions::default()
    };
    let robust = bake(
        &scene,
        &embree_tracer(&scene, EmbreeMode::Robust),
        atlas(),
        &options,
    );
    let default = bake(
        &scene,
        &embree_tracer(&scene, EmbreeMode::Watertight),
        atlas(),
        &options,
    );
    let fast = bake(
        &scene,
        &embree_tracer(&scene, EmbreeMode::Fast),
        atlas(),
        &options,
    );
    let all = robust.texels.valid.clone();
    agreement(
        "boards' floor texels, Embree fast mode against robust (reported only)",
        &fast,
        &robust,
        &all,
    );
    let agree = agreement(
        "boards' floor texels, default against robust",
        &default,
        &robust,
        &all,
    );
    assert!(agree >= TEXEL_AGREEMENT, "{:.3} % agree", 100.0 * agree);
}

/// A floor built as two meshes meeting at x = 0, so the generated atlas makes them two charts,
/// and a tall wall along y = 1.5 (so the transfer varies with y, not x): along the seam, each
/// texel of one chart and the other chart's value at the same point (interpolated along y
/// between its nearest texels) agree within the sampling error — their mean squared
/// difference is at most 1.5 × that of the texel between two seeds.
#[test]
fn charts_meeting_at_a_seam_agree_there() {
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    let scene = scene(vec![
        grid("floor west", Vec3::new(-1.0, -1.0, 0.0), x, y * 2.0, 4),
        grid("floor east", Vec3::new(0.0, -1.0, 0.0), x, y * 2.0, 4),
        grid("wall", Vec3::new(-2.0, 1.5, 0.0), x * 4.0, z * 3.0, 4),
    ]);
    let bake_seed = |seed| {
        let options = BakeOptions {
            seed,
            ..shadowed(2, 4096)
        };
        let atlas = Atlas::generate(&scene, 96, None).expect("atlas");
        bake(
            &scene,
            &embree_tracer(&scene, EmbreeMode::Watertight),
            atlas,
            &options,
        )
    };
    let (a, b) = (bake_seed(1), bake_seed(2));
    let triangles = scene.triangles.len() as u32;
    let west = |i: usize| a.texels.triangle[i] < triangles / 3;
    let on_floor = |i: usize| a.texels.valid[i] && a.texels.normals[i].z > 0.99;
    // A texel's world width: the texel points' spacing along the seam.
    let near: Vec<usize> = (0..a.texels.valid.len())
        .filter(|&i| on_floor(i) && a.texels.positions[i].x.abs() < 0.1)
        .collect();
    let (mut pairs, mut pair_sq, mut seed_sq, mut seed_n) = (0usize, 0.0f64, 0.0f64, 0usize);
    // The scene is mirror-symmetric about the seam (x = 0), so the x-odd coefficient
    // (j = 3, Y₁¹ ∝ x) changes sign across it: it differs between the two sides by its
    // gradient times their texels' separation, not by any seam error. The even ones (j = 0,
    // 1, 2) are compared.
    let sq = |p: &[f32], q: &[f32]| -> f64 {
        p[..3]
            .iter()
            .zip(&q[..3])
            .map(|(x, y)| f64::from(x - y).powi(2))
            .sum()
    };
    let east: Vec<usize> = near.iter().copied().filter(|&j| !west(j)).collect();
    for &i in near.iter().filter(|&&i| west(i)) {
        let p = a.texels.positions[i];
        // The other chart at p: its texels need not line up with this chart's (uvunwrap
        // rotates and places charts freely), so interpolate linearly along y (the field's
        // only direction of change) between its nearest texels below and above p.
        let y = |t: usize| a.texels.positions[t].y;
        let below = east
            .iter()
            .copied()
            .filter(|&j| y(j) <= p.y)
            .max_by(|&j, &k| y(j).total_cmp(&y(k)));
        let above = east
            .iter()
            .copied()
            .filter(|&j| y(j) > p.y)
            .min_by(|&j, &k| y(j).total_cmp(&y(k)));
        let (Some(j), Some(k)) = (below, above) else {
            continue;
        };
        if y(k) - y(j) > 0.1 {
            continue;
        }
        let w = (p.y - y(j)) / (y(k) - y(j));
        let lerp = |bake: &LightmapBake| -> Vec<f32> {
            coefficients(bake, j)
                .iter()
                .zip(coefficients(bake, k))
                .map(|(c0, c1)| c0 + w * (c1 - c0))
                .collect()
        };
        pairs += 1;
        pair_sq += sq(coefficients(&a, i), &lerp(&a));
        // A texel's difference between two seeds has twice its variance; the interpolated
        // value has at most its variance, so `pair` ≤ `seed` is expected up to the
        // interpolation's (second-order) error.
        seed_sq += sq(coefficients(&a, i), coefficients(&b, i));
        seed_n += 1;
    }
    let (pair_ms, seed_ms) = (pair_sq / pairs as f64, seed_sq / seed_n as f64);
    eprintln!(
        "seam: {pairs} texel pairs across the chart seam; mean squared difference {pair_ms:.3e} \
         across it, {seed_ms:.3e} between two seeds ({:.2} ×)",
        pair_ms / seed_ms
    );
    assert!(pairs >= 20, "{pairs} pairs");
    assert!(pair_ms <= 1.5 * seed_ms, "{pair_ms:e} against {seed_ms:e}");
}
