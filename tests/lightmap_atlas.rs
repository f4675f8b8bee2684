//! Generated lightmap atlases (`lightmap::atlas`, both unwrappers): charts never share a
//! texel and keep `PADDING` empty texels between them after conservative rasterisation,
//! UVs lie in [0, 1], `--texel-size` is honoured, and the UVs are bit-identical across runs
//! and thread counts. `atlas_figures` (ignored) prints the chart counts and utilisation
//! quoted in docs/guides/lightmaps.md.

use std::path::Path;

use glam::{Vec2, Vec3};
use prt_baker::Scene;
use prt_baker::bake::lightmap::atlas::{self, AtlasMethod, Generated, PADDING};
use prt_tests::*;

const METHODS: [AtlasMethod; 2] = [AtlasMethod::Unwrap, AtlasMethod::Planar];

fn demo(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{name}"));
    Scene::load(&path).expect("demo scene")
}

/// A finely tessellated sphere (8,192 triangles) on a floor: a curved mesh besides the torus.
fn sphere_scene() -> Scene {
    scene(vec![
        grid(
            "floor",
            Vec3::new(-2.0, -2.0, 0.0),
            Vec3::X * 4.0,
            Vec3::Y * 4.0,
            1,
        ),
        sphere(Vec3::Z, 1.0, 64, 64),
    ])
}

fn generate(scene: &Scene, resolution: u32, texel: Option<f32>, m: AtlasMethod) -> Generated {
    atlas::generate(scene, resolution, texel, m)
        .unwrap_or_else(|e| panic!("{} atlas at {resolution}²: {e}", m.name()))
}

/// The polygon of `triangle` (texel units) clipped to the unit square at `square`.
fn clip(triangle: [Vec2; 3], square: Vec2) -> Vec<Vec2> {
    let mut poly = triangle.to_vec();
    // Keep the side where `inside(p) >= 0` of four half-planes.
    let planes: [(Vec2, f32); 4] = [
        (Vec2::X, -square.x),
        (-Vec2::X, square.x + 1.0),
        (Vec2::Y, -square.y),
        (-Vec2::Y, square.y + 1.0),
    ];
    for (n, d) in planes {
        let inside = |p: Vec2| n.dot(p) + d;
        let mut out = Vec::new();
        for k in 0..poly.len() {
            let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
            let (da, db) = (inside(a), inside(b));
            if da >= 0.0 {
                out.push(a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                out.push(a + (b - a) * (da / (da - db)));
            }
        }
        poly = out;
        if poly.is_empty() {
            break;
        }
    }
    poly
}

fn area(poly: &[Vec2]) -> f32 {
    (0..poly.len())
        .map(|k| poly[k].perp_dot(poly[(k + 1) % poly.len()]))
        .sum::<f32>()
        .abs()
        * 0.5
}

const EMPTY: u32 = u32::MAX;
const SHARED: u32 = u32::MAX - 1;

/// Per texel, the chart whose triangles overlap it with positive area (as the bake's
/// rasteriser decides coverage), `EMPTY`, or `SHARED` if two charts do.
fn chart_texels(g: &Generated) -> Vec<u32> {
    let (w, h) = (g.atlas.width as usize, g.atlas.height as usize);
    let mut owner = vec![EMPTY; w * h];
    for (t, uv) in g.atlas.texel_corners().enumerate() {
        let chart = g.chart[t];
        if chart == EMPTY {
            continue;
        }
        let lo = uv[0].min(uv[1]).min(uv[2]).floor().max(Vec2::ZERO);
        let hi = uv[0].max(uv[1]).max(uv[2]).ceil();
        for y in lo.y as usize..(hi.y as usize).min(h) {
            for x in lo.x as usize..(hi.x as usize).min(w) {
                if area(&clip(uv, Vec2::new(x as f32, y as f32))) <= 0.0 {
                    continue;
                }
                let o = &mut owner[y * w + x];
                *o = match *o {
                    EMPTY => chart,
                    c if c == chart => chart,
                    _ => SHARED,
                };
            }
        }
    }
    owner
}

/// Checks one generated atlas and returns the fraction of texels its charts cover.
fn check(what: &str, scene: &Scene, g: &Generated) -> f64 {
    let (w, h) = (g.atlas.width as usize, g.atlas.height as usize);
    assert_eq!(g.atlas.uv1.len(), scene.triangles.len());
    for (t, uv) in g.atlas.uv1.iter().enumerate() {
        if g.chart[t] == EMPTY {
            continue;
        }
        for p in uv {
            assert!(
                (0.0..=1.0).contains(&p.x) && (0.0..=1.0).contains(&p.y),
                "{what}: triangle {t} has UV {p} outside [0, 1]"
            );
        }
    }
    // Every triangle of positive area is in the atlas.
    for (t, tri) in scene.triangles.iter().enumerate() {
        let p = tri.map(|v| scene.positions[v as usize]);
        if (p[1] - p[0]).cross(p[2] - p[0]).length() > 1e-6 {
            assert_ne!(g.chart[t], EMPTY, "{what}: triangle {t} is left out");
        }
    }
    let owner = chart_texels(g);
    let r = PADDING as isize;
    let mut covered = 0;
    for y in 0..h {
        for x in 0..w {
            let c = owner[y * w + x];
            assert_ne!(
                c, SHARED,
                "{what}: texel ({x}, {y}) is covered by two charts"
            );
            if c == EMPTY {
                continue;
            }
            covered += 1;
            // No other chart within PADDING texels (8-neighbourhood rings), so at least
            // PADDING empty texels lie between any two charts.
            for dy in -r..=r {
                for dx in -r..=r {
                    let (nx, ny) = (x as isize + dx, y as isize + dy);
                    if nx < 0 || ny < 0 || nx >= w as isize || ny >= h as isize {
                        continue;
                    }
                    let n = owner[ny as usize * w + nx as usize];
                    assert!(
                        n == EMPTY || n == c,
                        "{what}: charts {c} at ({x}, {y}) and {n} at ({nx}, {ny}) are closer \
                         than {PADDING} empty texels"
                    );
                }
            }
        }
    }
    covered as f64 / (w * h) as f64
}

#[test]
fn generated_charts_never_share_a_texel_and_keep_their_padding() {
    let scenes = [
        ("torus", demo("torus/torus.scene")),
        ("cornell", demo("cornell/cornell.scene")),
        ("sphere", sphere_scene()),
    ];
    for (name, scene) in &scenes {
        for m in METHODS {
            for res in [64, 256] {
                let g = generate(scene, res, None, m);
                let used = check(&format!("{name} {} {res}²", m.name()), scene, &g);
                eprintln!(
                    "{name} {} {res}²: {} charts, {:.1} % of texels",
                    m.name(),
                    g.chart_count,
                    100.0 * used
                );
            }
        }
        if *name != "cornell" {
            // Hundreds of planar charts, each with its padding: at 16² they cannot fit.
            let err = atlas::generate(scene, 16, None, AtlasMethod::Planar).unwrap_err();
            assert!(err.to_string().contains("do not fit"), "{name}: {err}");
        }
    }
}

/// World area over texel area, summed over the atlas's triangles: the texel size squared.
fn texel_size_of(scene: &Scene, g: &Generated) -> f64 {
    let (mut world, mut texels) = (0.0f64, 0.0f64);
    for ((t, tri), uv) in scene
        .triangles
        .iter()
        .enumerate()
        .zip(g.atlas.texel_corners())
    {
        if g.chart[t] == EMPTY {
            continue;
        }
        let p = tri.map(|v| scene.positions[v as usize]);
        world += f64::from((p[1] - p[0]).cross(p[2] - p[0]).length()) * 0.5;
        texels += f64::from((uv[1] - uv[0]).perp_dot(uv[2] - uv[0]).abs()) * 0.5;
    }
    (world / texels).sqrt()
}

#[test]
fn texel_size_is_honoured_and_charts_that_do_not_fit_are_refused() {
    for (name, scene, s) in [
        ("cornell", demo("cornell/cornell.scene"), 0.05f32),
        ("sphere", sphere_scene(), 0.05),
        ("torus", demo("torus/torus.scene"), 0.05),
    ] {
        for m in METHODS {
            let g = generate(&scene, 512, Some(s), m);
            check(&format!("{name} {} at {s}", m.name()), &scene, &g);
            let got = texel_size_of(&scene, &g);
            eprintln!("{name} {}: texel size {got:.5} for {s}", m.name());
            assert!(
                (got / f64::from(s) - 1.0).abs() < 0.02,
                "{name} {}: texel size {got} for --texel-size {s}",
                m.name()
            );
            assert_eq!(g.atlas.texel_size, Some(s));
            // A texel 10 × smaller: the charts need 100 × the area and cannot fit.
            let err = atlas::generate(&scene, 512, Some(s / 10.0), m).unwrap_err();
            assert!(err.to_string().contains("do not fit"), "{err}");
        }
    }
}

#[test]
fn generated_atlases_are_bit_identical_for_any_thread_count() {
    let scene = demo("torus/torus.scene");
    let bits = |g: &Generated| -> Vec<u32> {
        let uvs = g.atlas.uv1.iter().flatten();
        uvs.flat_map(|p| [p.x.to_bits(), p.y.to_bits()]).collect()
    };
    for m in METHODS {
        let mut runs = Vec::new();
        for threads in [1, 2, 1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let g = pool.install(|| generate(&scene, 256, None, m));
            runs.push((bits(&g), g.chart));
        }
        for r in &runs[1..] {
            assert!(r == &runs[0], "{}: the UVs differ between runs", m.name());
        }
    }
}

/// The figures of docs/guides/lightmaps.md: charts, covered texels and unwrap time per scene,
/// unwrapper and resolution. `cargo test --release -p prt-tests --test lightmap_atlas --
/// --ignored --nocapture`.
#[test]
#[ignore]
fn atlas_figures() {
    let scenes = [
        ("torus", demo("torus/torus.scene")),
        ("cornell", demo("cornell/cornell.scene")),
        ("sphere", sphere_scene()),
    ];
    for (name, scene) in &scenes {
        for res in [256, 512] {
            for m in METHODS {
                let started = std::time::Instant::now();
                let g = generate(scene, res, None, m);
                let seconds = started.elapsed().as_secs_f64();
                let used = check(name, scene, &g);
                println!(
                    "| {name} ({} triangles) | {res}² | {} | {} | {:.1} % | {:.2} s |",
                    scene.triangles.len(),
                    m.name(),
                    g.chart_count,
                    100.0 * used,
                    seconds
                );
            }
        }
    }
}
