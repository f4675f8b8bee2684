//! Glossy oracles: `relight --view` of a transfer-matrix bake through the real
//! baker, Embree, the MTL and glTF loaders and the PLY writer, against closed forms.
//!
//! * A glossy floor under a directional light: an unoccluded receiver's L′ is the light
//!   masked to its upper hemisphere, L′ = H·L with H_ij = ∫_{n·s>0} y_i y_j (quadrature), so
//!   every vertex's radiance is kd·Σ ĝ_l(1) L′_lm y_lm(n) + ks·Σ ĝ_l(s) L′_lm y_lm(r), with ĝ
//!   computed here by Gauss–Legendre quadrature (exact for these polynomials). The tolerance
//!   is the bake's Monte Carlo error by the rule of `prt_tests` (the per-ray variance of the
//!   radiance estimate computed by quadrature), and at most 1 % of the highlight's peak.
//! * The highlight sits where the view's mirror direction meets the light (within a vertex
//!   spacing), and its peak is the band-limited lobe's; the band-limit error against the
//!   unconvolved lobe (ks·E·(s + 1)/2π) is printed and stated in docs/guides/glossy.md.
//! * A matrix bake relit without a view is the vector bake of the same scene and seed, within
//!   the band-limit bound of docs/guides/glossy.md.
//! * glTF roughness and metallic map to the lobe's exponent, ks and diffuse weight.

use std::f64::consts::PI;
use std::path::Path;

use glam::{DVec3, Vec3};
use prt_baker::bake::options::TransferKind;
use prt_baker::math::sh;
use prt_baker::{BakeOptions, CoefficientFile, Scene};
use prt_tests::*;

/// Bakes `scene` (a vertex bake through Embree) and writes it to `path`.
fn bake_to(scene: &Scene, options: &BakeOptions, path: &Path) {
    let tracer = prt_baker::trace::build(
        prt_baker::trace::Backend::DEFAULT,
        scene,
        prt_baker::trace::TracerOptions::default(),
    )
    .unwrap();
    let transfer = prt_baker::bake(
        scene,
        Some(tracer.as_ref()),
        options,
        &prt_baker::support::progress::Silent,
    )
    .unwrap();
    CoefficientFile::from_bake(scene, &transfer)
        .write(path)
        .unwrap();
}

/// `relight` (with `eye` as `--view`) into a PLY, and its per-vertex float radiance.
fn relight(scene: &Path, prt: &Path, rig: &Path, eye: Option<Vec3>) -> Vec<[f32; 3]> {
    let ply = prt.with_extension(format!("{}.ply", rand_suffix()));
    let relit = prt_baker::export::relight::relight_from(scene, prt, rig, &ply, 0.0, eye).unwrap();
    let bytes = std::fs::read(&ply).unwrap();
    std::fs::remove_file(&ply).unwrap();
    read_ply_radiance(&bytes, relit.vertex_count)
}

fn rand_suffix() -> String {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    format!("r{}", NEXT.fetch_add(1, Ordering::Relaxed))
}

/// ĝ_l(s) = (s + 1) ∫₀¹ t^s P_l(t) dt for l < order, by 48-node Gauss–Legendre (exact for
/// the integer exponents used here: degree s + l ≤ 95).
fn lobe_by_quadrature(s: f64, order: usize) -> Vec<f64> {
    let (nodes, weights) = sh::gauss_legendre(48);
    (0..order)
        .map(|l| {
            let integral: f64 = nodes
                .iter()
                .zip(&weights)
                .map(|(x, w)| {
                    let t = 0.5 * (x + 1.0);
                    0.5 * w * t.powf(s) * sh::legendre(l, 0, t)
                })
                .sum();
            (s + 1.0) * integral
        })
        .collect()
}

/// Every basis function at `d` (the slow, trigonometric SH, independent of the baker's).
fn basis_at(order: usize, d: DVec3) -> Vec<f64> {
    let (theta, phi) = sh::angles(d.normalize());
    (0..sh::coeff_count(order))
        .map(|j| {
            let (l, m) = sh::band_and_m(j);
            sh::eval_slow(l, m, theta, phi)
        })
        .collect()
}

/// Σ_lm g_l · a_lm · b_lm.
fn banded_dot(g: &[f64], a: &[f64], b: &[f64]) -> f64 {
    (0..a.len())
        .map(|j| g[sh::band_and_m(j).0] * a[j] * b[j])
        .sum()
}

// ---------------------------------------------------------------------------------------------
// The glossy floor

const FLOOR_ORDER: usize = 5;
const FLOOR_SAMPLES: u32 = 16_384;
/// Grid vertices per side of the 2 × 2 floor.
const FLOOR_SIDE: usize = 31;
const KD: f64 = 0.3;
const KS: f64 = 0.5;
/// The directional light: irradiance E from θ = 30°, φ = 200°.
const SUN_E: f64 = 2.0;

fn sun_direction() -> DVec3 {
    let (theta, phi) = (30f64.to_radians(), 200f64.to_radians());
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// A z-up floor over [−1, 1]², FLOOR_SIDE² vertices, with the material `floor` of floor.mtl.
fn floor_obj() -> String {
    let mut text = String::from("mtllib floor.mtl\nusemtl floor\nvn 0 0 1\n");
    let step = 2.0 / (FLOOR_SIDE - 1) as f64;
    for j in 0..FLOOR_SIDE {
        for i in 0..FLOOR_SIDE {
            let (x, y) = (-1.0 + step * i as f64, -1.0 + step * j as f64);
            text += &format!("v {x} {y} 0\n");
        }
    }
    for j in 0..FLOOR_SIDE - 1 {
        for i in 0..FLOOR_SIDE - 1 {
            let k = |a: usize, b: usize| (j + b) * FLOOR_SIDE + i + a + 1;
            text += &format!(
                "f {}//1 {}//1 {}//1\nf {}//1 {}//1 {}//1\n",
                k(0, 0),
                k(1, 0),
                k(1, 1),
                k(0, 0),
                k(1, 1),
                k(0, 1)
            );
        }
    }
    text
}

/// The expected radiance of a floor vertex at `position` seen from `eye`, and the per-ray
/// variance of its estimate.
///
/// A matrix bake of an unoccluded receiver averages, over N directions uniform on the
/// hemisphere, 2π·y(s)·y(s)ᵀ; the rendered radiance is linear in M, so it is the average of
/// f(s) = 2π·(ks·K_r(s) + kd·K_n(s))·L(s), K_x(s) = Σ_l g_l Σ_m y_lm(x)·y_lm(s) the lobe's
/// band-limited kernel about x and L(s) = Σ L_j y_j(s) the band-limited light. Its mean is
/// the radiance, E[f²] − mean² its per-ray variance.
struct Expected {
    radiance: f64,
    variance: f64,
    /// The glossy term alone.
    glossy: f64,
}

fn expected_floor(light: &[f64], exponent: f64, position: DVec3, eye: DVec3) -> Expected {
    let order = FLOOR_ORDER;
    let to_eye = (eye - position).normalize();
    let r = 2.0 * to_eye.z * DVec3::Z - to_eye;
    let (y_n, y_r) = (basis_at(order, DVec3::Z), basis_at(order, r));
    let (g1, gs) = (
        lobe_by_quadrature(1.0, order),
        lobe_by_quadrature(exponent, order),
    );
    let (mut mean, mut second, mut glossy) = (0.0, 0.0, 0.0);
    band_quadrature(order, DVec3::Z, 0.0, 1.0, |w, _, y| {
        let l: f64 = y.iter().zip(light).map(|(a, b)| a * b).sum();
        let k_r = banded_dot(&gs, &y_r, y);
        let k_n = banded_dot(&g1, &y_n, y);
        let f = 2.0 * PI * (KS * k_r + KD * k_n) * l;
        mean += w / (2.0 * PI) * f;
        second += w / (2.0 * PI) * f * f;
        glossy += w * KS * k_r * l;
    });
    Expected {
        radiance: mean,
        variance: second - mean * mean,
        glossy,
    }
}

/// Where on the floor (z = 0) the view from `eye` mirrors into direction `d`.
fn mirror_point(eye: DVec3, d: DVec3) -> DVec3 {
    DVec3::new(eye.x + eye.z * d.x / d.z, eye.y + eye.z * d.y / d.z, 0.0)
}

#[test]
fn a_glossy_floors_highlight_matches_the_band_limited_lobe() {
    let folder = tempfile::tempdir().unwrap();
    let obj = folder.path().join("floor.obj");
    std::fs::write(&obj, floor_obj()).unwrap();
    let mtl = folder.path().join("floor.mtl");
    let write_mtl = |ns: f64| {
        std::fs::write(
            &mtl,
            format!("newmtl floor\nKd {KD} {KD} {KD}\nKs {KS} {KS} {KS}\nNs {ns}\n"),
        )
        .unwrap()
    };
    write_mtl(8.0);
    let d = sun_direction();
    let rig = folder.path().join("sun.toml");
    std::fs::write(
        &rig,
        format!(
            "[[light]]\nkind = \"directional\"\ndirection = [{}, {}, {}]\nintensity = {SUN_E}\n",
            d.x, d.y, d.z
        ),
    )
    .unwrap();
    // The light's coefficients: a band-limited delta, E·y(d) (docs/reference/lights.md).
    let light: Vec<f64> = basis_at(FLOOR_ORDER, d).iter().map(|y| SUN_E * y).collect();

    let scene = Scene::load(&obj).unwrap();
    assert_eq!(scene.vertex_count(), FLOOR_SIDE * FLOOR_SIDE);
    let prt = folder.path().join("floor.prt");
    let options = BakeOptions {
        transfer: TransferKind::Matrix,
        ..shadowed(FLOOR_ORDER, FLOOR_SAMPLES)
    };
    bake_to(&scene, &options, &prt);

    let spacing = 2.0 / (FLOOR_SIDE - 1) as f64;
    let eyes = [
        DVec3::new(0.3, 0.1, 1.0),
        DVec3::new(0.8, 0.5, 0.8),
        DVec3::new(0.2, -0.3, 1.5),
    ];
    for ns in [8.0, 30.0] {
        write_mtl(ns);
        for eye in eyes {
            let got = relight(&obj, &prt, &rig, Some(eye.as_vec3()));
            let expected: Vec<Expected> = scene
                .positions
                .iter()
                .map(|p| expected_floor(&light, ns, p.as_dvec3(), eye))
                .collect();
            let peak = expected.iter().map(|e| e.radiance).fold(0.0, f64::max);
            let (mut worst, mut worst_of_bound) = (0.0f64, 0.0f64);
            for (v, (g, e)) in got.iter().zip(&expected).enumerate() {
                // f32 storage of M and of the radiance: a few units of 1e-7 of the peak.
                let bound = tolerance(e.variance, FLOOR_SAMPLES) + 1e-5 * peak;
                for (c, &value) in g.iter().enumerate() {
                    let error = (f64::from(value) - e.radiance).abs();
                    assert!(
                        error <= bound && error <= 0.01 * peak,
                        "Ns {ns}, eye {eye}, vertex {v} at {}, channel {c}: {} against {} \
                         (Monte Carlo bound {bound:.2e}, 1 % of the peak {:.2e})",
                        scene.positions[v],
                        value,
                        e.radiance,
                        0.01 * peak
                    );
                    worst = worst.max(error);
                    worst_of_bound = worst_of_bound.max(error / bound);
                }
            }

            // The highlight: the brightest vertex is where the mirror direction meets the sun.
            let brightest = (0..got.len())
                .max_by(|&a, &b| got[a][0].total_cmp(&got[b][0]))
                .unwrap();
            let spot = mirror_point(eye, d);
            let distance = (scene.positions[brightest].as_dvec3() - spot).length();
            // The band-limited lobe at its centre (r = d), against the unconvolved one.
            let centre = expected_floor(&light, ns, spot, eye);
            let unconvolved = KS * SUN_E * (ns + 1.0) / (2.0 * PI);
            eprintln!(
                "Ns {ns:>2}, eye {eye}: worst vertex off by {worst:.2e} ({:.2} % of the peak \
                 {peak:.4}, {worst_of_bound:.1e} of its Monte Carlo bound); brightest vertex \
                 {:.3} from the mirror point {spot:.3} (spacing {spacing:.3}); glossy peak \
                 {:.4} band-limited, {unconvolved:.4} unconvolved (band-limit error {:.1} %)",
                100.0 * worst / peak,
                distance,
                centre.glossy,
                100.0 * (unconvolved - centre.glossy) / unconvolved
            );
            assert!(
                distance <= spacing,
                "Ns {ns}, eye {eye}: the brightest vertex {} is {distance:.3} from the mirror \
                 point {spot}",
                scene.positions[brightest]
            );
            // The baked peak is the band-limited lobe's value at its centre, to within the
            // vertex grid's sampling of the lobe and the Monte Carlo bound.
            let baked_glossy = f64::from(got[brightest][0]) - expected[brightest].radiance
                + expected[brightest].glossy;
            assert!(
                (baked_glossy - centre.glossy).abs() <= 0.01 * peak + 0.02 * centre.glossy,
                "Ns {ns}, eye {eye}: glossy peak {baked_glossy} against {}",
                centre.glossy
            );
            assert!(centre.glossy < unconvolved);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The diffuse render of a matrix bake

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);
const RIG: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../viewer/src/default-rig.toml"
);

/// Without a view, a matrix bake renders kd·Σ ĝ_l(1) L′ y(n) = albedo·((1/π)·M·ĉ)·L: the
/// vector bake's radiance up to the clamped cosine's band-limit error. Per vertex and channel
/// the difference is albedo·(1/π)∫ V·r·L ds, r the clamped cosine above band n − 1, at most
/// albedo·‖r‖/π·‖L_c‖ (Cauchy–Schwarz; ‖r‖/π = 0.0407 at order 4, docs/guides/glossy.md), on the
/// occluded, coloured Cornell box with the viewer's default rig (a sun and a sky), matrix and
/// vector baked with the same seed and rays.
#[test]
fn a_matrix_bake_without_a_view_is_the_vector_bake() {
    let order = 4;
    let samples = 4096;
    let folder = tempfile::tempdir().unwrap();
    let scene_path = Path::new(CORNELL);
    let scene = Scene::load(scene_path).unwrap();
    let vector = folder.path().join("v.prt");
    let matrix = folder.path().join("m.prt");
    bake_to(&scene, &shadowed(order, samples), &vector);
    let options = BakeOptions {
        transfer: TransferKind::Matrix,
        ..shadowed(order, samples)
    };
    bake_to(&scene, &options, &matrix);
    let rig = Path::new(RIG);
    let from_vectors = relight(scene_path, &vector, rig, None);
    let from_matrices = relight(scene_path, &matrix, rig, None);

    // ‖r‖² = ∫ max(cos θ, 0)² − Σ_{l<n} z_l², z_l = π·N_l·ĝ_l(1) the clamped cosine's zonal
    // coefficients.
    let residual = (2.0 * PI / 3.0
        - lobe_by_quadrature(1.0, order)
            .iter()
            .enumerate()
            .map(|(l, g)| (PI * g).powi(2) * (2 * l + 1) as f64 / (4.0 * PI))
            .sum::<f64>())
    .sqrt()
        / PI;
    assert!((residual - 0.0407).abs() < 1e-4, "{residual}");
    let light = prt_baker::light::Rig::load(rig).unwrap().project(order);
    let norms: Vec<f64> = light
        .rgb
        .iter()
        .map(|c| c.iter().map(|x| x * x).sum::<f64>().sqrt())
        .collect();
    let albedo = scene.vertex_albedo();
    let (mut worst, mut sum, mut count, mut largest) = (0.0f64, 0.0, 0, 0.0f64);
    for v in 0..scene.vertex_count() {
        for c in 0..3 {
            let (a, b) = (
                f64::from(from_matrices[v][c]),
                f64::from(from_vectors[v][c]),
            );
            let bound = f64::from(albedo[v][c]) * residual * norms[c];
            assert!(
                (a - b).abs() <= bound,
                "vertex {v}, channel {c}: {a} from the matrix, {b} from the vector bake \
                 (band-limit bound {bound:.2e})"
            );
            worst = worst.max((a - b).abs() / bound);
            sum += (a - b).powi(2);
            count += 1;
            largest = largest.max(b);
        }
    }
    eprintln!(
        "matrix against vector relight, Cornell box, order {order}, {samples} rays: rms \
         difference {:.2e} (largest radiance {largest:.3}), worst at {worst:.2} of its \
         band-limit bound",
        (sum / f64::from(count)).sqrt()
    );
}

// ---------------------------------------------------------------------------------------------
// glTF materials

/// A `.glb` of three triangles, one per material: roughness 0.5 dielectric, roughness 0.5
/// metal, and roughness 1 (diffuse).
fn material_glb() -> Vec<u8> {
    let mut bin = Vec::new();
    for k in 0..3 {
        for p in [
            [0.0f32, 0.0, k as f32],
            [1.0, 0.0, k as f32],
            [0.0, 1.0, k as f32],
        ] {
            bin.extend(p.iter().flat_map(|x| x.to_le_bytes()));
        }
    }
    let accessor = |k: usize| {
        serde_json::json!({"bufferView": 0, "byteOffset": 36 * k, "componentType": 5126,
            "count": 3, "type": "VEC3", "min": [0.0, 0.0, k as f64], "max": [1.0, 1.0, k as f64]})
    };
    let pbr = |roughness: f64, metallic: f64| {
        serde_json::json!({"baseColorFactor": [0.8, 0.4, 0.2, 1.0],
            "roughnessFactor": roughness, "metallicFactor": metallic})
    };
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": 0}, "material": 0},
            {"attributes": {"POSITION": 1}, "material": 1},
            {"attributes": {"POSITION": 2}, "material": 2}]}],
        "materials": [
            {"name": "plastic", "pbrMetallicRoughness": pbr(0.5, 0.0)},
            {"name": "metal", "pbrMetallicRoughness": pbr(0.5, 1.0)},
            {"name": "rough", "pbrMetallicRoughness": pbr(1.0, 0.0)}],
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": bin.len()}],
        "accessors": [accessor(0), accessor(1), accessor(2)],
    });
    prt_tests::glb(&serde_json::to_vec(&json).unwrap(), &bin)
}

/// glTF roughness 0.5 maps to the exponent 1/(2r⁴) − 1/2 = 7.5; ks is F0 = mix(0.04, base,
/// metallic) and the diffuse weight 1 − metallic; roughness 1 leaves a material diffuse.
#[test]
fn gltf_roughness_and_metallic_make_the_glossy_layer() {
    let folder = tempfile::tempdir().unwrap();
    let path = folder.path().join("materials.glb");
    std::fs::write(&path, material_glb()).unwrap();
    let scene = Scene::load(&path).unwrap();
    let layer = |name: &str| {
        let v = (0..scene.vertex_count())
            .find(|&v| scene.materials[scene.vertex_material[v] as usize].name == name)
            .unwrap_or_else(|| panic!("no vertex of material {name}"));
        scene.materials[scene.vertex_material[v] as usize].glossy
    };
    let plastic = layer("plastic").expect("roughness 0.5 is glossy");
    assert!(
        (plastic.exponent - 7.5).abs() < 1e-4,
        "{}",
        plastic.exponent
    );
    assert!((plastic.ks - Vec3::splat(0.04)).abs().max_element() < 1e-6);
    assert_eq!(plastic.diffuse_weight, 1.0);
    let metal = layer("metal").expect("roughness 0.5 is glossy");
    assert!((metal.exponent - 7.5).abs() < 1e-4, "{}", metal.exponent);
    assert!((metal.ks - Vec3::new(0.8, 0.4, 0.2)).abs().max_element() < 1e-6);
    assert_eq!(metal.diffuse_weight, 0.0);
    assert_eq!(layer("rough"), None);
}
