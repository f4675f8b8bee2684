//! Normal-mapped texel transfer: a glTF plane with a procedurally made
//! tangent-space normal map (tilts up to 35°), baked per texel.
//!
//! * Unshadowed (the acceptance criterion): every texel's band-1 lobe points along the map's
//!   normal at the texel, within 2°, with the band-1 norm of the flat plane's within 2 %;
//!   with MikkTSpace tangents, with the file's TANGENT (and its handedness), and with a
//!   `scale`.
//! * Shadowed: the geometric surface still bounds the rays that leave: each texel's transfer
//!   is the clamped-cosine lobe about the mapped normal *cut at the plane's horizon*, on both
//!   backends, and not the uncut lobe.
//! * Hostile: a missing or corrupt normal texture is an error naming the file.
//!
//! Each oracle is checked against what the bake would give without the feature (the flat
//! plane's lobe, the uncut lobe), so switching it off fails the test.

use glam::{DVec3, Vec3, Vec4};
use prt_baker::bake::lightmap::{self, Atlas, LightmapBake};
use prt_baker::math::sh;
use prt_baker::support::progress::Silent;
use prt_baker::trace::{Backend, TracerOptions, build};
use prt_baker::{BakeOptions, Mode, Scene};
use prt_tests::glb;
use serde_json::json;

/// Normal map pixels per side, and lightmap texels per side.
const MAP: u32 = 64;
const LIGHTMAP: u32 = 32;
/// The largest tilt the map encodes.
const MAX_TILT_DEG: f64 = 35.0;

/// The map's tangent-space normal at glTF texture coordinates (s, t): tilted by up to 35°
/// (most at s = ½), its azimuth turning once along t.
fn field(s: f64, t: f64) -> DVec3 {
    let theta = MAX_TILT_DEG.to_radians() * (std::f64::consts::PI * s).sin().powi(2);
    let phi = std::f64::consts::TAU * t;
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// The map as an RGB PNG, each pixel the field at its centre encoded as (n + 1)/2.
fn normal_png() -> Vec<u8> {
    let mut image = image::RgbImage::new(MAP, MAP);
    for (x, y, p) in image.enumerate_pixels_mut() {
        let n = field(
            (f64::from(x) + 0.5) / f64::from(MAP),
            (f64::from(y) + 0.5) / f64::from(MAP),
        );
        let code = |c: f64| ((c + 1.0) * 0.5 * 255.0).round() as u8;
        *p = image::Rgb([code(n.x), code(n.y), code(n.z)]);
    }
    let mut png = Vec::new();
    image
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .expect("png");
    png
}

/// The 2 × 2 plane at y = 0 facing +y (glTF's up), s = (x + 1)/2 and t = (z + 1)/2, with the
/// normal map as `normalTexture` (`scale`), and TANGENT where given. The image is embedded,
/// or an external `uri`.
fn plane_glb(tangent: Option<[f32; 4]>, scale: f32, uri: Option<&str>) -> Vec<u8> {
    let (document, bin) = plane(tangent, scale, uri);
    glb(&serde_json::to_vec(&document).unwrap(), &bin)
}

/// [`plane_glb`]'s JSON document and binary buffer.
fn plane(tangent: Option<[f32; 4]>, scale: f32, uri: Option<&str>) -> (serde_json::Value, Vec<u8>) {
    let positions = [(-1.0f32, -1.0f32), (-1.0, 1.0), (1.0, 1.0), (1.0, -1.0)];
    let floats = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let pos: Vec<f32> = positions.iter().flat_map(|&(x, z)| [x, 0.0, z]).collect();
    let nor: Vec<f32> = positions.iter().flat_map(|_| [0.0, 1.0, 0.0]).collect();
    let uv: Vec<f32> = positions
        .iter()
        .flat_map(|&(x, z)| [(x + 1.0) / 2.0, (z + 1.0) / 2.0])
        .collect();
    let indices: Vec<u8> = [0u32, 1, 2, 0, 2, 3]
        .iter()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let (mut bin, mut views) = (Vec::new(), Vec::new());
    let mut view = |bytes: Vec<u8>| {
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        bin.extend(bytes);
        views.len() - 1
    };
    let mut accessors = vec![
        json!({"bufferView": view(floats(&pos)), "count": 4, "type": "VEC3",
            "componentType": 5126, "min": [-1.0, 0.0, -1.0], "max": [1.0, 0.0, 1.0]}),
        json!({"bufferView": view(floats(&nor)), "count": 4, "type": "VEC3", "componentType": 5126}),
        json!({"bufferView": view(floats(&uv)), "count": 4, "type": "VEC2", "componentType": 5126}),
        json!({"bufferView": view(indices), "count": 6, "type": "SCALAR", "componentType": 5125}),
    ];
    let mut attributes = json!({"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2});
    if let Some(t) = tangent {
        let tangents: Vec<f32> = (0..4).flat_map(|_| t).collect();
        accessors.push(
            json!({"bufferView": view(floats(&tangents)), "count": 4, "type": "VEC4",
            "componentType": 5126}),
        );
        attributes["TANGENT"] = json!(4);
    }
    let image = match uri {
        Some(uri) => json!({"uri": uri}),
        None => json!({"bufferView": view(normal_png()), "mimeType": "image/png"}),
    };
    let document = json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "wall"}],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": 3, "material": 0}]}],
        "accessors": accessors, "bufferViews": views, "buffers": [{"byteLength": bin.len()}],
        "images": [image], "textures": [{"source": 0}],
        "materials": [{"name": "bumpy", "normalTexture": {"index": 0, "scale": scale}}],
    });
    (document, bin)
}

/// Writes `bytes` as `scene.glb` in `folder` and loads it.
fn load_in(folder: &std::path::Path, bytes: &[u8]) -> prt_baker::Result<Scene> {
    let path = folder.join("scene.glb");
    std::fs::write(&path, bytes).expect("write glb");
    Scene::load(&path)
}

/// Loads a `.glb` from a temporary folder. With `PRT_NORMAL_SCENES=folder` the scenes are
/// also kept there (`scene-N.glb`, in load order) for bakes with `prt-bake`.
fn load(bytes: &[u8]) -> Scene {
    if let Some(folder) = std::env::var_os("PRT_NORMAL_SCENES") {
        static KEPT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = KEPT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let path = std::path::Path::new(&folder).join(format!("scene-{n}.glb"));
        std::fs::write(path, bytes).expect("keep the scene");
    }
    let folder = tempfile::tempdir().expect("temporary folder");
    load_in(folder.path(), bytes).expect("load glb")
}

fn options(mode: Mode, samples: u32) -> BakeOptions {
    BakeOptions {
        order: 3,
        samples,
        mode,
        seed: 7,
        ..BakeOptions::default()
    }
}

/// A texel bake of the plane over its own uvs, traced with `backend` (none: unshadowed).
fn bake(scene: &Scene, backend: Backend, options: &BakeOptions) -> LightmapBake {
    let atlas = Atlas::from_vertex_uvs(scene, &scene.uvs, LIGHTMAP, LIGHTMAP).expect("atlas");
    let tracer = match backend {
        Backend::None => None,
        b => Some(build(b, scene, TracerOptions::default()).expect("tracer")),
    };
    lightmap::bake(scene, tracer.as_deref(), options, atlas, &Silent).expect("bake")
}

/// The world normal the map gives at world point `p` of the plane, for the tangent frame
/// (tangent +x, bitangent w·(n × t) = −w·z) and `scale`.
fn expected_normal(p: Vec3, w: f64, scale: f64) -> DVec3 {
    let local = field((f64::from(p.x) + 1.0) / 2.0, (f64::from(p.z) + 1.0) / 2.0);
    let local = DVec3::new(local.x * scale, local.y * scale, local.z).normalize();
    (DVec3::X * local.x + DVec3::NEG_Z * (w * local.y) + DVec3::Y * local.z).normalize()
}

/// Per valid texel: its point and its coefficients (one channel).
fn texels(bake: &LightmapBake) -> Vec<(Vec3, Vec<f64>)> {
    let n = sh::coeff_count(bake.transfer.options.order);
    (0..bake.texels.valid.len())
        .filter(|&i| bake.texels.valid[i])
        .map(|i| {
            let c = &bake.transfer.coefficients[i * n..(i + 1) * n];
            (
                bake.texels.positions[i],
                c.iter().map(|&x| f64::from(x)).collect(),
            )
        })
        .collect()
}

/// The band-1 lobe of coefficients `c`: Σ_m c_1m y_1m(ω) is linear in ω, = ω·D; returns D's
/// direction and the band's norm.
fn band1(c: &[f64]) -> (DVec3, f64) {
    let basis = sh::Basis::new(2);
    let mut y = [0.0f64; 4];
    let mut axis = |d: DVec3| {
        basis.eval_recurrence(d, &mut y);
        (1..4).map(|j| c[j] * y[j]).sum::<f64>()
    };
    let d = DVec3::new(axis(DVec3::X), axis(DVec3::Y), axis(DVec3::Z));
    (
        d.normalize(),
        c[1..4].iter().map(|x| x * x).sum::<f64>().sqrt(),
    )
}

/// The fraction of texels whose band-1 lobe is within 2° of the map's normal and whose
/// band-1 norm is within 2 % of `flat_norm`; prints the worst angle and norm ratio.
fn lobes_turned(bake: &LightmapBake, w: f64, scale: f64, flat_norm: f64, what: &str) -> f64 {
    let texels = texels(bake);
    let (mut good, mut worst_angle, mut worst_norm) = (0, 0.0f64, 0.0f64);
    for (p, c) in &texels {
        let (dir, norm) = band1(c);
        let angle = dir
            .angle_between(expected_normal(*p, w, scale))
            .to_degrees();
        let ratio = (norm / flat_norm - 1.0).abs();
        worst_angle = worst_angle.max(angle);
        worst_norm = worst_norm.max(ratio);
        if angle <= 2.0 && ratio <= 0.02 {
            good += 1;
        }
    }
    let fraction = f64::from(good) / texels.len() as f64;
    eprintln!(
        "{what}: {good} of {} texels ({:.1} %) within 2° and 2 %; worst {worst_angle:.3}°, \
         norm off by {:.3} %",
        texels.len(),
        100.0 * fraction,
        100.0 * worst_norm
    );
    fraction
}

/// The band-1 norm of the flat plane's texels (the lobe about +y), and a check that they
/// all point up: what every texel gives without the normal map.
fn flat_norm(samples: u32) -> f64 {
    // Scale 0 flattens every texel's normal to the surface's.
    let scene = load(&plane_glb(None, 0.0, None));
    let bake = bake(&scene, Backend::None, &options(Mode::Unshadowed, samples));
    let norms: Vec<f64> = texels(&bake)
        .iter()
        .map(|(_, c)| {
            let (dir, norm) = band1(c);
            assert!(
                dir.angle_between(DVec3::Y).to_degrees() < 0.5,
                "flat texel along {dir}"
            );
            norm
        })
        .collect();
    norms.iter().sum::<f64>() / norms.len() as f64
}

/// The acceptance criterion, with MikkTSpace tangents (the file has no TANGENT).
#[test]
fn unshadowed_texel_lobes_turn_by_the_maps_tilt() {
    let samples = 256;
    let flat = flat_norm(samples);
    let scene = load(&plane_glb(None, 1.0, None));
    let bake = bake(&scene, Backend::None, &options(Mode::Unshadowed, samples));
    let fraction = lobes_turned(&bake, 1.0, 1.0, flat, "MikkTSpace tangents");
    assert!(fraction >= 0.95, "{:.1} % of texels", 100.0 * fraction);
    // Without the map every lobe would point along +y: a tilted texel must not.
    let tilted = texels(&bake)
        .iter()
        .filter(|(_, c)| band1(c).0.angle_between(DVec3::Y).to_degrees() > 30.0)
        .count();
    assert!(tilted > 50, "only {tilted} texels tilted by more than 30°");
}

/// The file's TANGENT is used as given: w = −1 mirrors the map's green (y), and `scale`
/// multiplies its x and y.
#[test]
fn the_files_tangents_and_scale_are_used() {
    let samples = 256;
    let flat = flat_norm(samples);
    for (w, scale) in [(1.0f32, 1.0f32), (-1.0, 1.0), (1.0, 0.5)] {
        let scene = load(&plane_glb(Some([1.0, 0.0, 0.0, w]), scale, None));
        let bake = bake(&scene, Backend::None, &options(Mode::Unshadowed, samples));
        let what = format!("TANGENT w = {w}, scale {scale}");
        let fraction = lobes_turned(&bake, f64::from(w), f64::from(scale), flat, &what);
        assert!(
            fraction >= 0.95,
            "{what}: {:.1} % of texels",
            100.0 * fraction
        );
        if w < 0.0 {
            // The mirrored frame is not the unmirrored one.
            let wrong = lobes_turned(&bake, 1.0, 1.0, flat, "  (read as w = +1)");
            assert!(wrong < 0.5, "{what}: the sign was ignored");
        }
    }
}

/// The clamped-cosine lobe about `n` cut at the horizon of the surface normal `g`, projected
/// to `order` bands: (1/π) ∫ max(n·s, 0) [g·s > 0] y_j(s) ds (`cut`), or uncut; midpoint
/// quadrature in (cos θ, φ) about `g`, so the cut falls on a cell boundary.
fn lobe(order: usize, n: DVec3, g: DVec3, cut: bool) -> Vec<f64> {
    let basis = sh::Basis::new(order);
    let mut y = vec![0.0; order * order];
    let mut out = vec![0.0; order * order];
    let frame = prt_baker::math::sampling::Frame::from_normal(g.as_vec3());
    let (t, b) = (frame.tangent.as_dvec3(), frame.bitangent.as_dvec3());
    let (rings, segments) = (200, 300);
    let cell = 2.0 / f64::from(rings) * std::f64::consts::TAU / f64::from(segments);
    for i in 0..rings {
        let z = -1.0 + (f64::from(i) + 0.5) * 2.0 / f64::from(rings);
        if cut && z <= 0.0 {
            continue;
        }
        let r = (1.0 - z * z).sqrt();
        for k in 0..segments {
            let phi = (f64::from(k) + 0.5) * std::f64::consts::TAU / f64::from(segments);
            let s = t * (r * phi.cos()) + b * (r * phi.sin()) + g * z;
            let cos = n.dot(s);
            if cos <= 0.0 {
                continue;
            }
            basis.eval_recurrence(s, &mut y);
            for (o, y) in out.iter_mut().zip(&y) {
                *o += cos * y * cell / std::f64::consts::PI;
            }
        }
    }
    out
}

/// In shadowed mode the plane's own surface stops every direction below it: a tilted texel's
/// transfer is its lobe cut at the geometric horizon, on both backends.
#[test]
fn shadowed_texels_keep_the_geometric_hemisphere() {
    let (order, samples) = (3, 1024);
    let scene = load(&plane_glb(None, 1.0, None));
    for backend in [Backend::Embree, Backend::Obvhs] {
        let bake = bake(&scene, backend, &options(Mode::Shadowed, samples));
        let texels = texels(&bake);
        let (mut worst_cut, mut checked, mut far_from_uncut) = (0.0f64, 0, 0);
        // Every 32nd texel, and every 4th tilted by more than 25°.
        for (k, (p, c)) in texels.iter().enumerate() {
            let n = expected_normal(*p, 1.0, 1.0);
            let tilt = n.angle_between(DVec3::Y).to_degrees();
            if k % 32 != 0 && (tilt <= 25.0 || k % 4 != 0) {
                continue;
            }
            let diff = |e: &[f64]| {
                c.iter()
                    .zip(e)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            };
            let cut = diff(&lobe(order, n, DVec3::Y, true));
            worst_cut = worst_cut.max(cut);
            if tilt > 25.0 && diff(&lobe(order, n, DVec3::Y, false)) > 0.03 {
                far_from_uncut += 1;
            }
            checked += 1;
            assert!(
                cut < 0.01,
                "{backend:?}: texel at {p} (tilt {tilt:.1}°) is {cut:.4} off the cut lobe"
            );
        }
        eprintln!(
            "{backend:?}: {checked} texels within {worst_cut:.4} of the cut lobe; \
             {far_from_uncut} tilted ones > 0.03 off the uncut lobe"
        );
        assert!(far_from_uncut > 10, "{backend:?}: the cut is not visible");
    }
}

/// A normal texture that is missing, or not an image, is an error naming the file, before
/// any bake.
#[test]
fn a_missing_or_corrupt_normal_texture_names_the_file() {
    let folder = tempfile::tempdir().expect("temporary folder");
    let bytes = plane_glb(None, 1.0, Some("bumps.png"));
    let err = load_in(folder.path(), &bytes).expect_err("missing texture");
    assert!(err.to_string().contains("bumps.png"), "{err}");
    assert!(err.is_bad_input(), "exit 3: {err}");
    eprintln!("{err}");
    std::fs::write(folder.path().join("bumps.png"), b"not a png").unwrap();
    let err = load_in(folder.path(), &bytes).expect_err("corrupt texture");
    assert!(err.to_string().contains("bumps.png"), "{err}");
    assert!(err.is_bad_input(), "exit 3: {err}");
    eprintln!("{err}");
    std::fs::write(folder.path().join("bumps.png"), normal_png()).unwrap();
    let scene = load_in(folder.path(), &bytes).expect("a readable texture");
    let tangents = scene.tangents.as_ref().expect("tangents");
    assert!(
        tangents
            .iter()
            .all(|t| (*t - Vec4::new(1.0, 0.0, 0.0, 1.0)).length() < 1e-4)
    );
}

/// The horizon rule alone: a receiver in open space (nothing below it to hit) whose lobe is
/// turned 35° off its surface normal still gets the cut lobe in shadowed mode, so a mapped
/// normal near a surface's edge, where rays into the surface may miss it, sees nothing
/// through it.
#[test]
fn directions_below_the_surface_count_as_blocked_where_nothing_is_hit() {
    use prt_baker::bake::transfer::{Estimator, Receivers, Scratch};
    let far = prt_tests::patch(Vec3::splat(100.0), Vec3::Z, 0.1);
    let scene = prt_tests::scene(vec![far]);
    let tilt = 35f64.to_radians();
    let n = DVec3::new(tilt.sin(), 0.0, tilt.cos());
    let (order, samples) = (3, 1024);
    for backend in [Backend::Embree, Backend::Obvhs] {
        let tracer = build(backend, &scene, TracerOptions::default()).expect("tracer");
        let receivers = Receivers {
            origins: vec![Vec3::ZERO],
            normals: vec![n.as_vec3()],
            horizons: Some(vec![Vec3::Z]),
            streams: None,
            strata: None,
        };
        let estimator = Estimator::for_receivers(receivers, &options(Mode::Shadowed, samples))
            .expect("estimator");
        let k = sh::coeff_count(order);
        let mut out = vec![0.0f32; k];
        estimator.receiver_transfer(0, Some(&*tracer), &mut Scratch::new(k), &mut out, None);
        let diff = |e: &[f64]| {
            out.iter()
                .zip(e)
                .map(|(a, b)| (f64::from(*a) - b).abs())
                .fold(0.0, f64::max)
        };
        let (cut, uncut) = (
            diff(&lobe(order, n, DVec3::Z, true)),
            diff(&lobe(order, n, DVec3::Z, false)),
        );
        eprintln!("{backend:?}: {cut:.4} off the cut lobe, {uncut:.4} off the uncut one");
        assert!(cut < 0.01 && uncut > 0.03, "{backend:?}: {cut} / {uncut}");
    }
}

/// A TANGENT accessor glTF does not allow (VEC3 here) is refused with the mesh's name where
/// a normal map would read it, not read past its end.
#[test]
fn a_malformed_tangent_accessor_is_an_error() {
    let (mut document, bin) = plane(Some([1.0, 0.0, 0.0, 1.0]), 1.0, None);
    document["accessors"][4]["type"] = json!("VEC3");
    let bytes = glb(&serde_json::to_vec(&document).unwrap(), &bin);
    let folder = tempfile::tempdir().expect("temporary folder");
    let Err(err) = load_in(folder.path(), &bytes) else {
        panic!("VEC3 tangents were read as VEC4");
    };
    eprintln!("{err}");
    assert!(
        err.to_string().contains("TANGENT") && err.is_bad_input(),
        "{err}"
    );
}
