//! Subsurface transfer against a volumetric path tracer and closed forms.
//!
//! * A semi-infinite medium under a constant sky against Mitsuba 3's figures
//!   (subsurface-digest.md: 0.750, 0.415, 0.115 at albedo 0.99, 0.9, 0.5) and, where the
//!   dipole is accurate (albedo 0.99), its closed-form total diffuse reflectance.
//! * The held-out objects of tests/data/subsurface (a box and a sphere under a constant sky, a
//!   thin slab lit from below only; ior 1.0 and 1.3) against the Mitsuba `volpath` references
//!   there (scripts/mitsuba/subsurface_reference.py): every channel of the relit radiance
//!   within 5 % + 3 standard errors of the reference (the acceptance criterion).
//! * Embree and obvhs agree, bakes do not depend on the thread count, and a whole-scene bake
//!   leaves opaque objects' transfer as it was.
//! * Texel bakes (`--lightmap`): the texel at the box's top centre against the same Mitsuba
//!   references; a whole texel bake holds each texel's own walks, keeps opaque texels, and
//!   agrees across thread counts and backends.
//! * `--receivers` subsets hold the whole bake's rows bit for bit.

use std::path::{Path, PathBuf};

use glam::Vec3;
use prt_baker::bake::lightmap::{self, translucent::texel_points};
use prt_baker::bake::subsurface::{
    self, Points, Walks, apply_to_vertices, bake_points, vertex_points,
};
use prt_baker::math::medium::{Medium, dipole_total_reflectance};
use prt_baker::math::sh::Basis;
use prt_baker::scene::{Materials, Scene};
use prt_baker::support::progress::Silent;
use prt_baker::trace::{self, Backend, Tracer, TracerOptions};
use prt_baker::{BakeOptions, Mode};
use prt_tests::*;

const SQRT_4PI: f64 = 3.544_907_701_811_032;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/subsurface")
        .join(name)
}

fn medium(sigma_t: f32, ior: f32) -> Medium {
    let albedo = Vec3::new(0.99, 0.9, 0.5);
    Medium {
        scattering: albedo * sigma_t,
        absorption: (Vec3::ONE - albedo) * sigma_t,
        ior,
    }
}

fn tracer(scene: &Scene, backend: Backend) -> Box<dyn Tracer> {
    trace::build(backend, scene, TracerOptions::default()).expect("tracer")
}

/// The subsurface transfer (3 channels of `order`²) of the one vertex `vertex`.
fn transfer_at(
    scene: &Scene,
    tracer: &dyn Tracer,
    media: &[Option<Medium>],
    vertex: usize,
    order: usize,
    samples: u32,
    seed: u64,
) -> Vec<[f64; 3]> {
    let all = vertex_points(scene, media);
    let i = all
        .receiver
        .iter()
        .position(|&r| r == vertex)
        .expect("a translucent vertex");
    let one = Points {
        receiver: vec![all.receiver[i]],
        position: vec![all.position[i]],
        normal: vec![all.normal[i]],
        inside: vec![all.inside[i]],
        material: vec![all.material[i]],
    };
    let walks = Walks {
        scene,
        tracer,
        media,
        order,
        samples,
        seed,
        bounced: None,
    };
    let (out, _) = bake_points(&walks, &one, &Silent);
    let n = order * order;
    (0..n)
        .map(|j| std::array::from_fn(|c| f64::from(out[c * n + j])))
        .collect()
}

/// A closed box `lo`..`hi` of six grids of 2 × 2 cells (a vertex at each face's centre), all
/// of material `name`; returns the scene and the top face's centre vertex.
fn cuboid(name: &str, lo: Vec3, hi: Vec3) -> (Scene, usize) {
    let d = hi - lo;
    let (x, y, z) = (Vec3::X * d.x, Vec3::Y * d.y, Vec3::Z * d.z);
    let faces = [
        grid(name, Vec3::new(lo.x, lo.y, hi.z), x, y, 2),
        grid(name, lo, y, x, 2),
        grid(name, lo, z, y, 2),
        grid(name, Vec3::new(hi.x, lo.y, lo.z), y, z, 2),
        grid(name, lo, x, z, 2),
        grid(name, Vec3::new(lo.x, hi.y, lo.z), z, x, 2),
    ];
    let meshes: Vec<_> = faces
        .into_iter()
        .map(|mut m| {
            m.material.name = name.to_string();
            m.material.kd = Vec3::ONE;
            m
        })
        .collect();
    let scene = scene(meshes);
    let top = Vec3::new((lo.x + hi.x) / 2.0, (lo.y + hi.y) / 2.0, hi.z);
    let v = (0..scene.vertex_count())
        .find(|&v| scene.positions[v].distance(top) < 1e-5 && scene.normals[v].z > 0.99)
        .expect("top centre");
    (scene, v)
}

/// Per channel, |got − expected| ≤ 5 % of expected + 3 standard errors.
fn within_criterion(got: [f64; 3], expected: [f64; 3], se: [f64; 3]) -> bool {
    (0..3).all(|c| (got[c] - expected[c]).abs() <= 0.05 * expected[c] + 3.0 * se[c])
}

#[test]
fn semi_infinite_medium_matches_mitsuba_and_the_dipole() {
    // 60 mean free paths wide and deep: semi-infinite for every walk that matters.
    let (scene, top) = cuboid(
        "deep",
        Vec3::new(-30.0, -30.0, -60.0),
        Vec3::new(30.0, 30.0, 0.0),
    );
    let media = vec![Some(medium(1.0, 1.0)); scene.materials.len()];
    let tracer = tracer(&scene, Backend::Embree);
    let t = transfer_at(&scene, tracer.as_ref(), &media, top, 1, 20_000, 5);
    let radiance = t[0].map(|x| x * SQRT_4PI);
    let mitsuba = [0.750, 0.415, 0.115];
    println!("semi-infinite: bake {radiance:.4?}, Mitsuba {mitsuba:?}");
    assert!(
        within_criterion(radiance, mitsuba, [0.003; 3]),
        "{radiance:?} vs {mitsuba:?}"
    );
    // The dipole is accurate for bright, highly scattering media (Mitsuba 0.750 there).
    let dipole = dipole_total_reflectance(0.99, 1.0);
    assert!(
        (radiance[0] - dipole).abs() < 0.02 * dipole,
        "{} vs dipole {dipole}",
        radiance[0]
    );
}

/// The projection of `light` at `order` by midpoint quadrature over (θ, φ).
fn project(order: usize, light: impl Fn(Vec3) -> f64) -> Vec<f64> {
    let basis = Basis::new(order);
    let n = order * order;
    let (rows, cols) = (400, 800);
    let mut out = vec![0.0; n];
    let mut y = vec![0.0f32; n];
    for i in 0..rows {
        let theta = (i as f64 + 0.5) / rows as f64 * std::f64::consts::PI;
        let weight = theta.sin()
            * (std::f64::consts::PI / rows as f64)
            * (std::f64::consts::TAU / cols as f64);
        for k in 0..cols {
            let phi = (k as f64 + 0.5) / cols as f64 * std::f64::consts::TAU;
            let d = Vec3::new(
                (theta.sin() * phi.cos()) as f32,
                (theta.sin() * phi.sin()) as f32,
                theta.cos() as f32,
            );
            basis.eval(d, &mut y);
            let l = light(d) * weight;
            for j in 0..n {
                out[j] += l * f64::from(y[j]);
            }
        }
    }
    out
}

struct Reference {
    object: String,
    ior: f32,
    point: Vec3,
    normal: Vec3,
    sigma_t: f32,
    light: String,
    radiance: [f64; 3],
    se: [f64; 3],
}

/// The committed table, or the one `PRT_SUBSURFACE_REFERENCES` names (`make
/// mitsuba-subsurface` regenerates it with Mitsuba and points there).
fn references() -> Vec<Reference> {
    let path = std::env::var_os("PRT_SUBSURFACE_REFERENCES")
        .map_or_else(|| data("references.json"), PathBuf::from);
    let text = std::fs::read_to_string(&path).expect("references.json");
    let json: serde_json::Value = serde_json::from_str(&text).expect("json");
    let triple = |v: &serde_json::Value| -> [f64; 3] {
        std::array::from_fn(|c| v[c].as_f64().expect("number"))
    };
    json["references"]
        .as_array()
        .expect("references")
        .iter()
        .map(|r| Reference {
            object: r["object"].as_str().unwrap().to_string(),
            ior: r["ior"].as_f64().unwrap() as f32,
            point: Vec3::from_array(triple(&r["point"]).map(|x| x as f32)),
            normal: Vec3::from_array(triple(&r["normal"]).map(|x| x as f32)),
            sigma_t: r["sigma_t"].as_f64().unwrap() as f32,
            light: r["light"].as_str().unwrap().to_string(),
            radiance: triple(&r["radiance"]),
            se: triple(&r["standard_error"]),
        })
        .collect()
}

/// The relit radiance at the held-out scene's vertex at `r.point` with normal `r.normal`.
fn relit_reference_case(r: &Reference, backend: Backend, samples: u32) -> [f64; 3] {
    relit_seeded(r, backend, samples, 5)
}

fn relit_seeded(r: &Reference, backend: Backend, samples: u32, seed: u64) -> [f64; 3] {
    let scene = Scene::load(&data(&format!("{}.obj", r.object))).expect("scene");
    let vertex = (0..scene.vertex_count())
        .find(|&v| {
            scene.positions[v].distance(r.point) < 1e-5 && scene.normals[v].dot(r.normal) > 0.999
        })
        .expect("the reference's vertex");
    let media = vec![Some(medium(r.sigma_t, r.ior)); scene.materials.len()];
    let tracer = tracer(&scene, backend);
    // A constant sky is band 0 alone; the light from below, max(−ω_y, 0), needs more bands
    // (its projection at order 10 leaves under 0.5 % of the radiance here).
    let (order, light): (usize, Box<dyn Fn(Vec3) -> f64>) = match r.light.as_str() {
        "sky" => (1, Box::new(|_| 1.0)),
        "below" => (10, Box::new(|d: Vec3| f64::from((-d.y).max(0.0)))),
        other => panic!("unknown light {other}"),
    };
    let l = project(order, light);
    let t = transfer_at(
        &scene,
        tracer.as_ref(),
        &media,
        vertex,
        order,
        samples,
        seed,
    );
    std::array::from_fn(|c| t.iter().zip(&l).map(|(t, l)| t[c] * l).sum())
}

#[test]
fn held_out_objects_match_mitsuba_volpath() {
    let mut failures = Vec::new();
    for r in references() {
        let got = relit_reference_case(&r, Backend::Embree, 16_384);
        let ok = within_criterion(got, r.radiance, r.se);
        println!(
            "{:6} ior {:.1}: bake {got:.4?}, Mitsuba {:.4?} ± {:.4?} {}",
            r.object,
            r.ior,
            r.radiance,
            r.se,
            if ok { "ok" } else { "FAIL" }
        );
        if !ok {
            failures.push(format!("{} ior {}", r.object, r.ior));
        }
    }
    assert!(failures.is_empty(), "outside 5 % + 3 SE: {failures:?}");
}

/// The 5 % criterion cannot see every error (leaving out the Fresnel reflection inside moves
/// these results by 2–3 %), so the bake is also held to the references statistically: the
/// mean of 8 bakes with their own seeds within 4 combined standard errors (the bake's from the
/// spread of its seeds), plus 0.5 % for the slab, whose light from below is cut at order 10.
#[test]
fn held_out_objects_match_mitsuba_within_their_standard_errors() {
    let mut failures = Vec::new();
    for r in references() {
        let runs: Vec<[f64; 3]> = (0..8)
            .map(|s| relit_seeded(&r, Backend::Embree, 8192, 100 + s))
            .collect();
        let truncation = if r.light == "sky" { 0.0 } else { 0.005 };
        let mut worst = 0.0f64;
        for c in 0..3 {
            let mean = runs.iter().map(|x| x[c]).sum::<f64>() / 8.0;
            let var = runs.iter().map(|x| (x[c] - mean).powi(2)).sum::<f64>() / 7.0;
            let se = (var / 8.0 + r.se[c] * r.se[c]).sqrt();
            let excess = ((mean - r.radiance[c]).abs() - truncation * r.radiance[c]).max(0.0);
            worst = worst.max(excess / se);
        }
        println!(
            "{:6} ior {:.1}: worst channel {worst:.2} standard errors off",
            r.object, r.ior
        );
        if worst > 4.0 {
            failures.push(format!("{} ior {}: {worst:.1} SE", r.object, r.ior));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}

#[test]
fn embree_and_obvhs_agree() {
    for r in references().iter().filter(|r| r.ior > 1.0) {
        let embree = relit_reference_case(r, Backend::Embree, 4096);
        let obvhs = relit_reference_case(r, Backend::Obvhs, 4096);
        println!(
            "{} ior {}: embree {embree:.4?}, obvhs {obvhs:.4?}",
            r.object, r.ior
        );
        // Same seeds, same walks: only rounding in the hits can send a walk another way.
        for c in 0..3 {
            assert!(
                (embree[c] - obvhs[c]).abs() <= 0.01 * embree[c].max(0.01),
                "{}: {embree:?} vs {obvhs:?}",
                r.object
            );
        }
    }
}

#[test]
fn bakes_are_bit_identical_for_any_thread_count() {
    let (scene, _) = cuboid("box", Vec3::splat(-1.0), Vec3::splat(1.0));
    let media = vec![Some(medium(1.0, 1.3)); scene.materials.len()];
    let tracer = tracer(&scene, Backend::Embree);
    let points = vertex_points(&scene, &media);
    let walks = Walks {
        scene: &scene,
        tracer: tracer.as_ref(),
        media: &media,
        order: 3,
        samples: 64,
        seed: 9,
        bounced: None,
    };
    let bake_with = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| bake_points(&walks, &points, &Silent).0)
    };
    let one = bake_with(1);
    assert_eq!(one, bake_with(3));
    let reseeded = bake_points(&Walks { seed: 10, ..walks }, &points, &Silent).0;
    assert_ne!(one, reseeded);
}

#[test]
fn whole_scene_bakes_keep_opaque_transfer_and_compose_bounces() {
    // A translucent box on an opaque floor, both through the library's entry points.
    let floor = {
        let mut m = grid(
            "floor",
            Vec3::new(-3.0, -3.0, 0.0),
            Vec3::X * 6.0,
            Vec3::Y * 6.0,
            6,
        );
        m.material.name = "floor".into();
        m
    };
    let dir = tempfile::tempdir().unwrap();
    let mats = dir.path().join("mats.toml");
    std::fs::write(&mats, "[material.wax.subsurface]\nscattering = [2, 1.5, 1]\nabsorption = [0.02, 0.1, 0.4]\nior = 1.3\n").unwrap();
    let materials = Materials::load(&mats).unwrap();
    let mut all: Vec<prt_baker::scene::Mesh> = Vec::new();
    let (lo, hi) = (Vec3::new(-0.5, -0.5, 0.0), Vec3::new(0.5, 0.5, 1.0));
    let d = hi - lo;
    for (origin, u, v) in [
        (Vec3::new(lo.x, lo.y, hi.z), Vec3::X * d.x, Vec3::Y * d.y),
        (lo, Vec3::Y * d.y, Vec3::X * d.x),
        (lo, Vec3::Z * d.z, Vec3::Y * d.y),
        (Vec3::new(hi.x, lo.y, lo.z), Vec3::Y * d.y, Vec3::Z * d.z),
        (lo, Vec3::X * d.x, Vec3::Z * d.z),
        (Vec3::new(lo.x, hi.y, lo.z), Vec3::Z * d.z, Vec3::X * d.x),
    ] {
        let mut m = grid("wax", origin, u, v, 2);
        m.material.name = "wax".into();
        all.push(m);
    }
    all.push(floor);
    let scene = scene(all);
    let media = materials.media_for(&scene.path, &scene.materials).unwrap();
    let tracer = tracer(&scene, Backend::Embree);
    let mut glow = [0.0f64; 2];
    for (k, mode) in [Mode::Shadowed, Mode::Interreflected]
        .into_iter()
        .enumerate()
    {
        let options = BakeOptions {
            order: 3,
            samples: 256,
            mode,
            bounces: u32::from(mode == Mode::Interreflected),
            seed: 2,
            ..BakeOptions::default()
        };
        let opaque = prt_baker::bake(&scene, Some(tracer.as_ref()), &options, &Silent).unwrap();
        let mut translucent = opaque.clone();
        apply_to_vertices(&scene, tracer.as_ref(), &media, &mut translucent, &Silent).unwrap();
        assert_eq!(translucent.channels, 3);
        let rgb = subsurface::to_rgb(&opaque.coefficients, opaque.channels, 9);
        let floor = scene.objects.last().unwrap().vertices.clone();
        let wax = 0..floor.start as usize;
        let row = |c: &[f32], v: usize| c[v * 27..(v + 1) * 27].to_vec();
        for v in floor.start as usize..floor.end as usize {
            assert_eq!(
                row(&translucent.coefficients, v),
                row(&rgb, v),
                "floor vertex {v} changed"
            );
        }
        // Every translucent vertex glows: red (the least absorbing) brightest.
        for v in wax {
            let t = translucent.vertex(v, 0)[0];
            assert!(
                t > 0.0 && t > translucent.vertex(v, 2)[0],
                "{mode:?} vertex {v}: {t}"
            );
            glow[k] += f64::from(t);
        }
    }
    // Light the floor bounces in only adds: the walks are the same (same seed).
    assert!(
        glow[1] > glow[0],
        "interreflected {} vs shadowed {}",
        glow[1],
        glow[0]
    );
}

/// The texel nearest `point` (with a normal along `normal`) of a `resolution`² texel bake of
/// `scene`, as subsurface receivers: the texel's index and its points alone.
fn texel_near(
    scene: &Scene,
    tracer: &dyn Tracer,
    media: &[Option<Medium>],
    resolution: u32,
    point: Vec3,
    normal: Vec3,
) -> (usize, Points) {
    let atlas = lightmap::Atlas::generate(scene, resolution, None).expect("atlas");
    let prepared = lightmap::prepare(scene, Some(tracer), 0, atlas).expect("texels");
    let (all, _) = texel_points(scene, &prepared.texels, media);
    let i = (0..all.receiver.len())
        .filter(|&i| all.normal[i].dot(normal) > 0.999)
        .min_by(|&a, &b| {
            let d = |i: usize| all.position[i].distance(point);
            d(a).total_cmp(&d(b))
        })
        .expect("a translucent texel");
    let one = Points {
        receiver: vec![all.receiver[i]],
        position: vec![all.position[i]],
        normal: vec![all.normal[i]],
        inside: vec![all.inside[i]],
        material: vec![all.material[i]],
    };
    (all.receiver[i], one)
}

/// Texel receivers run the vertex bake's estimator at their own point and normal: the texel
/// at the held-out box's top centre (within half a texel of it) meets the Mitsuba references
/// as the vertex there does (5 % + 3 standard errors).
#[test]
fn texel_bakes_match_mitsuba_volpath_at_the_box_top() {
    let scene = Scene::load(&data("box.obj")).expect("scene");
    let tracer = tracer(&scene, Backend::Embree);
    let mut failures = Vec::new();
    for r in references().iter().filter(|r| r.object == "box") {
        let media = vec![Some(medium(r.sigma_t, r.ior)); scene.materials.len()];
        let (texel, points) = texel_near(&scene, tracer.as_ref(), &media, 48, r.point, r.normal);
        let walks = Walks {
            scene: &scene,
            tracer: tracer.as_ref(),
            media: &media,
            order: 1,
            samples: 16_384,
            seed: 5,
            bounced: None,
        };
        let (t, _) = bake_points(&walks, &points, &Silent);
        // A constant sky: band 0 alone, L00 = √(4π).
        let got: [f64; 3] = std::array::from_fn(|c| f64::from(t[c]) * SQRT_4PI);
        let vertex = relit_reference_case(r, Backend::Embree, 16_384);
        let ok = within_criterion(got, r.radiance, r.se);
        println!(
            "box ior {:.1}: texel {texel} at {:.3?}: {got:.4?}, vertex {vertex:.4?}, Mitsuba {:.4?} {}",
            r.ior,
            points.position[0],
            r.radiance,
            if ok { "ok" } else { "FAIL" }
        );
        if !ok {
            failures.push(format!("box ior {}", r.ior));
        }
    }
    assert!(failures.is_empty(), "outside 5 % + 3 SE: {failures:?}");
}

/// A translucent box just above an opaque floor, 6 + 1 separate grids. (Not touching it: where
/// a translucent face and another surface coincide, which one a walk hits is the backend's
/// choice, and Embree and obvhs choose differently.)
fn box_on_floor() -> (Scene, Vec<Option<Medium>>) {
    let mut all = Vec::new();
    let (lo, hi) = (Vec3::new(-0.5, -0.5, 0.02), Vec3::new(0.5, 0.5, 1.02));
    let d = hi - lo;
    for (origin, u, v) in [
        (Vec3::new(lo.x, lo.y, hi.z), Vec3::X * d.x, Vec3::Y * d.y),
        (lo, Vec3::Y * d.y, Vec3::X * d.x),
        (lo, Vec3::Z * d.z, Vec3::Y * d.y),
        (Vec3::new(hi.x, lo.y, lo.z), Vec3::Y * d.y, Vec3::Z * d.z),
        (lo, Vec3::X * d.x, Vec3::Z * d.z),
        (Vec3::new(lo.x, hi.y, lo.z), Vec3::Z * d.z, Vec3::X * d.x),
    ] {
        let mut m = grid("wax", origin, u, v, 2);
        m.material.name = "wax".into();
        all.push(m);
    }
    let mut floor = grid(
        "floor",
        Vec3::new(-3.0, -3.0, 0.0),
        Vec3::X * 6.0,
        Vec3::Y * 6.0,
        6,
    );
    floor.material.name = "floor".into();
    floor.material.kd = Vec3::new(0.8, 0.6, 0.4);
    all.push(floor);
    let scene = scene(all);
    let wax = Medium {
        scattering: Vec3::new(2.0, 1.5, 1.0),
        absorption: Vec3::new(0.02, 0.1, 0.4),
        ior: 1.3,
    };
    let media = scene
        .materials
        .iter()
        .map(|m| (m.name == "wax").then_some(wax))
        .collect();
    (scene, media)
}

/// A whole texel bake (`lightmap::bake_translucent`, what `bake --lightmap --materials` runs):
/// a translucent texel holds exactly its own walks (the same estimate as the texel alone),
/// opaque texels keep their transfer, translucent texels glow, light the floor bounces in
/// adds to it, bakes do not depend on the thread count, and Embree and obvhs agree.
#[test]
fn texel_bakes_carry_each_texels_walks() {
    let (scene, media) = box_on_floor();
    let embree = tracer(&scene, Backend::Embree);
    let atlas = lightmap::Atlas::generate(&scene, 64, None).expect("atlas");
    let n = 4;
    let mut glow = [0.0f64; 2];
    for (k, mode) in [Mode::Shadowed, Mode::Interreflected]
        .into_iter()
        .enumerate()
    {
        let options = BakeOptions {
            order: 2,
            samples: 64,
            mode,
            bounces: u32::from(mode == Mode::Interreflected),
            seed: 3,
            ..BakeOptions::default()
        };
        let bake_on = |tracer: &dyn Tracer, threads: usize, media: &[Option<Medium>]| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                lightmap::bake_translucent(
                    &scene,
                    Some(tracer),
                    &options,
                    atlas.clone(),
                    media,
                    &Silent,
                )
                .expect("texel bake")
            })
        };
        let bake = bake_on(embree.as_ref(), 1, &media);
        assert_eq!(bake.transfer.channels, 3);
        assert_eq!(
            bake.transfer.coefficients,
            bake_on(embree.as_ref(), 3, &media).transfer.coefficients,
            "{mode:?}: thread count"
        );
        let opaque = bake_on(embree.as_ref(), 2, &[]);
        let opaque_rgb =
            subsurface::to_rgb(&opaque.transfer.coefficients, opaque.transfer.channels, n);
        let texels = &bake.texels;
        let row = |c: &[f32], i: usize| c[i * 3 * n..(i + 1) * 3 * n].to_vec();
        let (points, _) = texel_points(&scene, texels, &media);
        let translucent: std::collections::HashSet<usize> =
            points.receiver.iter().copied().collect();
        for i in (0..texels.valid.len()).filter(|&i| texels.valid[i]) {
            if !translucent.contains(&i) {
                assert_eq!(
                    row(&bake.transfer.coefficients, i),
                    row(&opaque_rgb, i),
                    "{mode:?}: opaque texel {i} changed"
                );
            }
        }
        // Every translucent texel glows, red (the least absorbing) brightest.
        for &i in &points.receiver {
            let t = row(&bake.transfer.coefficients, i);
            assert!(t[0] > 0.0 && t[0] > t[2 * n], "{mode:?}: texel {i}: {t:?}");
            glow[k] += f64::from(t[0]);
        }
        // The texel at the top's centre, far from seams (stitching leaves it), holds its walks.
        let (texel, one) = texel_near(
            &scene,
            embree.as_ref(),
            &media,
            64,
            Vec3::new(0.0, 0.0, 1.02),
            Vec3::Z,
        );
        if mode == Mode::Shadowed {
            let walks = Walks {
                scene: &scene,
                tracer: embree.as_ref(),
                media: &media,
                order: 2,
                samples: 64,
                seed: 3,
                bounced: None,
            };
            assert_eq!(
                bake_points(&walks, &one, &Silent).0,
                row(&bake.transfer.coefficients, texel)
            );
        }
        // Embree and obvhs: the mean over the translucent texels within 1 %.
        let obvhs = tracer(&scene, Backend::Obvhs);
        let other = bake_on(obvhs.as_ref(), 2, &media);
        let mean = |c: &[f32]| -> f64 {
            points
                .receiver
                .iter()
                .map(|&i| f64::from(c[i * 3 * n]))
                .sum::<f64>()
                / points.receiver.len() as f64
        };
        let (a, b) = (
            mean(&bake.transfer.coefficients),
            mean(&other.transfer.coefficients),
        );
        println!("{mode:?}: mean red glow embree {a:.5}, obvhs {b:.5}");
        assert!(
            (a - b).abs() <= 0.01 * a,
            "{mode:?}: embree {a} vs obvhs {b}"
        );
    }
    assert!(
        glow[1] > glow[0],
        "interreflected {} vs shadowed {}",
        glow[1],
        glow[0]
    );
}

/// A `--receivers` bake of translucent and opaque objects holds, bit for bit, the whole
/// bake's rows of their vertices, shadowed and interreflected.
#[test]
fn receiver_subsets_hold_the_whole_bakes_rows() {
    use prt_baker::bake::receiver_subset::bake_objects_translucent;
    let (scene, media) = box_on_floor();
    let tracer = tracer(&scene, Backend::Embree);
    // The box's top and the floor.
    let objects = [0u32, scene.objects.len() as u32 - 1];
    for mode in [Mode::Shadowed, Mode::Interreflected] {
        let options = BakeOptions {
            order: 2,
            samples: 64,
            mode,
            bounces: u32::from(mode == Mode::Interreflected),
            seed: 4,
            ..BakeOptions::default()
        };
        let mut whole = prt_baker::bake(&scene, Some(tracer.as_ref()), &options, &Silent).unwrap();
        apply_to_vertices(&scene, tracer.as_ref(), &media, &mut whole, &Silent).unwrap();
        let subset = bake_objects_translucent(
            &scene,
            Some(tracer.as_ref()),
            &options,
            &objects,
            &media,
            &Silent,
        )
        .unwrap();
        assert_eq!(subset.channels, 3);
        let rows: Vec<usize> = objects
            .iter()
            .flat_map(|&o| scene.objects[o as usize].vertices.clone())
            .map(|v| v as usize)
            .collect();
        assert_eq!(subset.receiver_count, rows.len());
        for (r, &v) in rows.iter().enumerate() {
            for c in 0..3 {
                assert_eq!(
                    subset.vertex(r, c),
                    whole.vertex(v, c),
                    "{mode:?} vertex {v}"
                );
            }
        }
    }
}
