//! Interreflected texel bakes (`--lightmap --mode interreflected`): a bounce hit reads the
//! previous bounce bilinearly from the lightmap around its lightmap UV. Tested against the
//! floor-meets-a-wall closed form per texel (oracles.md), against the per-vertex bake where
//! texel points are vertices, and for determinism across thread counts and the hit cache.

use glam::{DVec3, Vec2, Vec3};
use prt_baker::bake::interreflection;
use prt_baker::bake::lightmap::{self, Atlas, LightmapBake};
use prt_baker::math::sh;
use prt_baker::scene::{Material, Mesh};
use prt_baker::support::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer};
use prt_baker::{BakeOptions, Mode, Scene};
use prt_tests::*;

fn interreflected(order: usize, samples: u32, bounces: u32) -> BakeOptions {
    BakeOptions {
        order,
        samples,
        mode: Mode::Interreflected,
        bounces,
        seed: 11,
        ..BakeOptions::default()
    }
}

fn bake_lightmap(scene: &Scene, atlas: &Atlas, options: &BakeOptions) -> LightmapBake {
    let tracer = EmbreeTracer::new(scene, EmbreeOptions::default()).expect("embree scene");
    lightmap::bake(scene, Some(&tracer), options, atlas.clone(), &Silent).expect("lightmap bake")
}

fn with_albedo(mut mesh: Mesh, albedo: Vec3) -> Mesh {
    mesh.material = Material {
        name: "paint".into(),
        kd: albedo,
        ..Material::default()
    };
    mesh
}

/// Channel `c` of texel `i` (channel 0 of a grey bake's single channel).
fn texel(bake: &LightmapBake, i: usize, c: usize) -> Vec<f64> {
    let t = &bake.transfer;
    let n = sh::coeff_count(t.options.order);
    let c = c.min(t.channels - 1);
    t.coefficients[(i * t.channels + c) * n..][..n]
        .iter()
        .map(|&x| f64::from(x))
        .collect()
}

#[test]
// `j` indexes the oracles and the bakes, and names the coefficient in messages.
#[allow(clippy::needless_range_loop)]
fn floor_and_wall_texels_follow_the_closed_form() {
    // oracles.md: a floor meeting a wall at a right angle, both of albedo ρ; with the
    // shadowed transfer A on the floor and B on the wall, the totals at a floor point after
    // 0, 1, 2 bounces are A, A + (ρ/2)B, A + (ρ/2)B + (ρ²/4)A (at a wall point A and B swap).
    // Each plane is 4 vertices, 2,000 units; each is a 128×8 block of the lightmap (128
    // columns away from the corner, 8 rows along it), so a bounce reads the other plane's
    // transfer only through its texels. The planes' transfer is constant only where the
    // planes' size is far larger than the distance from the corner (a texel at x sees sky
    // past the wall's top within x/2000 rad of the zenith), so the texels checked are the
    // first three columns: x/2000 ≤ 2 %.
    let (rho, far, res, rows) = (0.5f32, 2000.0f32, 128u32, 8u32);
    let (order, samples) = (3, 1 << 13);
    // Floor: x in [0, far], normal +z. Wall: the plane x = 0, z in [0, far], normal +x.
    let floor = grid(
        "floor",
        Vec3::new(0.0, -far, 0.0),
        Vec3::X * far,
        Vec3::Y * 2.0 * far,
        1,
    );
    let wall = grid(
        "wall",
        Vec3::new(0.0, -far, 0.0),
        Vec3::Y * 2.0 * far,
        Vec3::Z * far,
        1,
    );
    let scene = scene(vec![
        with_albedo(floor, Vec3::splat(rho)),
        with_albedo(wall, Vec3::splat(rho)),
    ]);
    // Texel columns 0..128 are the floor by x, 130..258 the wall by height; rows are y.
    let (pad, width) = (2, 2 * res + 2);
    let uvs: Vec<Vec2> = scene
        .positions
        .iter()
        .zip(&scene.normals)
        .map(|(p, n)| {
            let v = (p.y + far) / (2.0 * far);
            let column = match n.z > 0.5 {
                true => p.x / far * res as f32,
                false => (pad + res) as f32 + p.z / far * res as f32,
            };
            Vec2::new(column / width as f32, v)
        })
        .collect();
    let atlas = Atlas::from_vertex_uvs(&scene, &uvs, width, rows).unwrap();
    let bakes: Vec<LightmapBake> = (0..=2)
        .map(|b| {
            let options = match b {
                0 => BakeOptions {
                    seed: 11,
                    ..shadowed(order, samples)
                },
                b => interreflected(order, samples, b),
            };
            bake_lightmap(&scene, &atlas, &options)
        })
        .collect();
    assert_eq!(
        bakes[0].texels.valid_count(),
        2 * (res * rows) as usize,
        "both planes fill their blocks"
    );
    let a = quarter_moments(order, DVec3::Z, DVec3::X); // floor: sees s.x > 0
    let b = quarter_moments(order, DVec3::X, DVec3::Z); // wall: sees s.z > 0
    let half_rho = f64::from(rho) / 2.0;
    let bounce_samples = samples / 4;
    let n = sh::coeff_count(order);
    let mut worst = 0.0f64;
    // The first three texels from the corner, in the two middle rows, on each plane.
    for (plane, mine, other, first_column) in [("floor", &a, &b, 0), ("wall", &b, &a, res + pad)] {
        for row in [rows / 2 - 1, rows / 2] {
            for k in 0..3 {
                let i = (row * width + first_column + k) as usize;
                let p = bakes[0].texels.positions[i];
                let totals: Vec<Vec<f64>> = bakes.iter().map(|bake| texel(bake, i, 0)).collect();
                for j in 0..n {
                    let tol0 = tolerance(mine.variance(j), samples);
                    let tol0_other = tolerance(other.variance(j), samples);
                    // Bounce 1: half the rays hit the other plane, each worth ρ·(its T_0).
                    let sample1 = f64::from(rho) * other.mean[j];
                    let tol1 =
                        tolerance(sample1 * sample1 * 0.25, bounce_samples) + half_rho * tol0_other;
                    let sample2 = f64::from(rho) * half_rho * mine.mean[j];
                    let tol2 =
                        tolerance(sample2 * sample2 * 0.25, bounce_samples) + half_rho * tol1;
                    let expected = [
                        mine.mean[j],
                        mine.mean[j] + half_rho * other.mean[j],
                        mine.mean[j]
                            + half_rho * other.mean[j]
                            + half_rho * half_rho * mine.mean[j],
                    ];
                    let tols = [tol0, tol0 + tol1, tol0 + tol1 + tol2];
                    for bounces in 0..3 {
                        let got = totals[bounces][j];
                        let err = (got - expected[bounces]).abs();
                        worst = worst.max(err / tols[bounces]);
                        assert!(
                            err <= tols[bounces],
                            "{plane} texel {i} at {p}, coefficient {j} {:?} after {bounces} \
                             bounces: {got:.6} vs {:.6} ± {:.1e}",
                            sh::band_and_m(j),
                            expected[bounces],
                            tols[bounces]
                        );
                    }
                }
            }
        }
    }
    eprintln!("floor and wall texels: worst error {worst:.3} tolerances");
}

/// A 16×16-cell floor [−1, 1]² and a 16×16-cell red wall at x = 1.2 facing it (apart, so
/// no receiver lies on the other surface), with lightmap
/// UVs that put every vertex at a texel centre of a 17×36 lightmap: the floor in rows 0..17,
/// the wall in rows 19..36. Valid texel k (row-major) is then vertex k, at the same point.
fn floor_and_wall_grids() -> (Scene, Atlas) {
    let cells = 16;
    let floor = grid(
        "floor",
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::X * 2.0,
        Vec3::Y * 2.0,
        cells,
    );
    // Wound to face the floor (normal −x).
    let wall = grid(
        "wall",
        Vec3::new(1.2, -1.0, 0.0),
        Vec3::Z * 2.0,
        Vec3::Y * 2.0,
        cells,
    );
    let scene = scene(vec![
        with_albedo(floor, Vec3::splat(0.7)),
        with_albedo(wall, Vec3::new(0.8, 0.3, 0.2)),
    ]);
    let side = cells as usize + 1;
    let uvs: Vec<Vec2> = (0..scene.vertex_count())
        .map(|v| {
            let (x, y) = (v % side, v / side);
            let y = if y < side { y } else { y + 2 };
            (Vec2::new(x as f32, y as f32) + 0.5) / Vec2::new(17.0, 36.0)
        })
        .collect();
    let atlas = Atlas::from_vertex_uvs(&scene, &uvs, 17, 36).unwrap();
    (scene, atlas)
}

#[test]
fn texels_on_dense_grids_vertices_agree_with_the_vertex_bake() {
    // Every texel is baked at a vertex's point, and bounce hits read the same surfaces:
    // bilinearly between texels, or barycentrically between the vertices there (the same
    // points). Two independent Monte Carlo estimates (other seeds) must agree within their
    // errors; with the same seed texel k and vertex k share their rays, so only the
    // interpolation differs.
    let (order, samples) = (2, 1 << 13);
    let (scene, atlas) = floor_and_wall_grids();
    let options = interreflected(order, samples, 1);
    let texels = bake_lightmap(&scene, &atlas, &options);
    let count = scene.vertex_count();
    assert_eq!(
        texels.texels.valid_count(),
        count,
        "every vertex is a texel"
    );
    assert_eq!(texels.transfer.channels, 3, "a red wall makes colour");
    let vertices = bake_scene(
        &scene,
        &BakeOptions {
            seed: 8,
            ..options.clone()
        },
    );
    let same_seed = bake_scene(&scene, &options);
    let direct = bake_scene(
        &scene,
        &BakeOptions {
            seed: 8,
            ..shadowed(order, samples)
        },
    );
    let n = sh::coeff_count(order);
    let valid: Vec<usize> = (0..texels.texels.valid.len())
        .filter(|&i| texels.texels.valid[i])
        .collect();
    // Per-sample bounds: a direct sample is at most |y_j| ≤ the second moment's root; a
    // bounce sample is ρ_max × the largest direct coefficient, × N/M.
    let bound = band_moments(order, DVec3::Z, 0.0, 1.0);
    let largest: Vec<f64> = (0..n)
        .map(|j| {
            (0..count)
                .map(|v| f64::from(direct.vertex(v, 0)[j]).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    let (mut worst, mut same_worst, mut bounce_dc) = (0.0f64, 0.0f64, 0.0f64);
    for (v, &i) in valid.iter().enumerate() {
        assert!(texels.texels.positions[i].distance(scene.positions[v]) < 1e-5);
        for c in 0..3 {
            let t = texel(&texels, i, c);
            let vt = vertices.vertex(v, c);
            let st = same_seed.vertex(v, c);
            bounce_dc = bounce_dc.max(f64::from(st[0] - same_seed.vertex(v, 0)[0]).abs());
            for j in 0..n {
                let sample = 0.8 * largest[j];
                let tol = std::f64::consts::SQRT_2
                    * (tolerance(bound.second[j], samples)
                        + tolerance(sample * sample, samples / 4));
                let err = (t[j] - f64::from(vt[j])).abs();
                worst = worst.max(err / tol);
                assert!(
                    err <= tol,
                    "texel {i} (vertex {v}) channel {c} j={j}: {} vs {} ± {tol:.1e}",
                    t[j],
                    vt[j]
                );
                same_worst = same_worst.max((t[j] - f64::from(st[j])).abs());
            }
        }
    }
    eprintln!(
        "texel/vertex interreflected agreement: worst {worst:.3} tolerances; same seed: \
         largest difference {same_worst:.2e} (largest red–green DC difference {bounce_dc:.3})"
    );
    // Same rays: the bilinear and the barycentric reading of the same vertex values differ
    // only inside cells, by a small part of the bounce.
    assert!(same_worst < 2e-3, "same seed: {same_worst}");
}

#[test]
fn interreflected_texel_bakes_do_not_depend_on_threads_or_the_hit_cache() {
    let (scene, atlas) = floor_and_wall_grids();
    let options = interreflected(2, 256, 2);
    let in_pool = |threads: usize, options: &BakeOptions| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| bake_lightmap(&scene, &atlas, options))
    };
    let one = in_pool(1, &options);
    let two = in_pool(2, &options);
    assert!(one.transfer.hit_cache_bytes.is_some());
    // No cache: each bounce re-traces its rows, which must be the same rows.
    let retraced = in_pool(
        2,
        &BakeOptions {
            hit_cache_limit: 0,
            ..options.clone()
        },
    );
    assert!(retraced.transfer.hit_cache_bytes.is_none());
    let bits = |b: &LightmapBake| -> Vec<u32> {
        b.transfer
            .coefficients
            .iter()
            .map(|c| c.to_bits())
            .collect()
    };
    assert!(bits(&one) == bits(&two), "1 and 2 threads differ");
    assert!(bits(&one) == bits(&retraced), "re-traced bounces differ");
    assert_eq!(one.dilated, two.dilated);
    // Dilated texels hold values in every channel.
    let n = sh::coeff_count(2);
    let dilated = one.dilated.iter().position(|&d| d).expect("dilated texels");
    assert!((0..3).all(|c| one.transfer.coefficients[(dilated * 3 + c) * n] > 0.0));
}

#[test]
fn the_texel_hit_cache_keeps_one_hit_per_bounce_ray() {
    // Inside a closed box every bounce ray lands on a front face. The cache keeps each hit
    // (triangle, u, v: 12 bytes) plus 4 bytes a texel for where its hits start; folded rows
    // took one 16-byte entry per distinct texel tap, 2–3 per bounce ray on a dense lightmap.
    let cells = 16;
    let (x, y, z) = (Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z * 2.0);
    let at = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    // Each face wound to face the inside (normal edge_u × edge_v).
    let faces = [
        ("floor", at(-1.0, -1.0, 0.0), x, y),
        ("ceiling", at(-1.0, -1.0, 2.0), y, x),
        ("east", at(1.0, -1.0, 0.0), z, y),
        ("west", at(-1.0, -1.0, 0.0), y, z),
        ("north", at(-1.0, 1.0, 0.0), x, z),
        ("south", at(-1.0, -1.0, 0.0), z, x),
    ];
    let scene = scene(
        faces
            .iter()
            .map(|&(name, origin, u, v)| {
                with_albedo(grid(name, origin, u, v, cells), Vec3::splat(0.5))
            })
            .collect(),
    );
    // Six 17 × 17 blocks, 3 × 2, 2 texels apart.
    let side = cells as usize + 1;
    let (w, h) = (3 * (side + 2), 2 * (side + 2));
    let uvs: Vec<Vec2> = (0..scene.vertex_count())
        .map(|v| {
            let (block, k) = (v / (side * side), v % (side * side));
            let x = block % 3 * (side + 2) + k % side;
            let y = block / 3 * (side + 2) + k / side;
            (Vec2::new(x as f32, y as f32) + 0.5) / Vec2::new(w as f32, h as f32)
        })
        .collect();
    let atlas = Atlas::from_vertex_uvs(&scene, &uvs, w as u32, h as u32).unwrap();
    let options = interreflected(1, 256, 1);
    let bake = bake_lightmap(&scene, &atlas, &options);
    let bytes = bake
        .transfer
        .hit_cache_bytes
        .expect("the hits fit the cache");
    let texels = bake.texels.valid_count() as u64;
    let rays = texels * u64::from(options.effective_bounce_samples());
    let per_ray = bytes as f64 / rays as f64;
    eprintln!("hit cache: {bytes} bytes for {texels} texels, {per_ray:.2} per bounce ray");
    let most = rays * interreflection::BYTES_PER_HIT + texels * 4;
    assert!(bytes <= most, "{bytes} bytes, at most {most}");
    // Nearly every ray hits a front face (a few slip out where the faces meet).
    assert!(
        bytes as f64 >= 0.95 * most as f64,
        "{bytes} bytes, expected about {most}"
    );
}

#[test]
fn a_constant_lightmap_reads_back_constant_up_to_the_charts_edges() {
    // A 4-vertex floor in the middle 8×8 texels of a 16×16 lightmap, every valid texel
    // holding 1: a bounce hit anywhere on the floor, even half a texel from its edge where
    // bilinear taps reach the padding, must read 1. That needs the padding dilated before
    // the lookup (and the weights of empty texels renormalised away).
    let floor = grid(
        "floor",
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::X * 2.0,
        Vec3::Y * 2.0,
        1,
    );
    let scene = scene(vec![floor]);
    let uvs: Vec<Vec2> = scene
        .positions
        .iter()
        .map(|p| Vec2::new(p.x, p.y) / 4.0 + Vec2::splat(0.5))
        .collect();
    let atlas = Atlas::from_vertex_uvs(&scene, &uvs, 16, 16).unwrap();
    let texels = prt_baker::bake::lightmap::Texels::rasterise(&scene, &atlas);
    assert_eq!(texels.valid_count(), 64);
    let targets = prt_baker::bake::transfer::BounceTargets::texels(&atlas, &texels);
    let ones = vec![1.0f32; 64];
    let lightmap = targets.slot_values(&ones, 1);
    let mut slots = [(0, 0.0); 4];
    let steps = 40;
    for triangle in 0..2 {
        for i in 0..=steps {
            for j in 0..=steps - i {
                let (b1, b2) = (i as f32 / steps as f32, j as f32 / steps as f32);
                let count = targets.lookup(&scene, triangle, [1.0 - b1 - b2, b1, b2], &mut slots);
                let value: f32 = slots[..count]
                    .iter()
                    .map(|&(slot, w)| w * lightmap[slot as usize])
                    .sum();
                assert!(
                    (value - 1.0).abs() < 1e-5,
                    "triangle {triangle} at ({b1}, {b2}): {value} from {:?}",
                    &slots[..count]
                );
            }
        }
    }
}
