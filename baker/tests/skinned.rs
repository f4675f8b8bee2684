//! Skinned glTF (docs/guides/characters.md, "Skinned glTF"): `scenes/tube/tube-skinned.glb`,
//! the ribbed tube with a root and an elbow joint and an animation `bend` (0° → 90° over a
//! second). Oracles: the CPU skinning against the closed form of the bend; the straight
//! bake's lobes skinned to the 90° pose against a fresh bake of that pose, compared with the
//! straight bake's world-space SH; the skinned-axis rule against the rebuilt frames; and
//! files with bad skins refused, naming the file and the problem.

mod relit;

use std::path::{Path, PathBuf};

use glam::{DQuat, DVec3, Quat, Vec3};
use prt_baker::bake::ldprt::fit_bake;
use prt_baker::export::relight_ldprt::{ldprt_radiance, ldprt_radiance_axes, pose_axes};
use prt_baker::formats::ldprt_file::LdprtFile;
use prt_baker::scene::Pose;
use prt_baker::{Scene, Transfer};
use relit::{ORDER, bake, light, rms, sh_radiance};

const RADIUS: f32 = 0.2;
/// The elbow's height and the half-length of the weights' blend (`scenes/src/skinned_tube.rs`).
const ELBOW: f32 = 1.0;
const BLEND: f32 = 0.2;

fn glb() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/tube/tube-skinned.glb"
    ))
}

fn load(path: &Path, pose: &str) -> Result<Scene, prt_baker::Error> {
    Scene::load_posed(path, None, &pose.parse::<Pose>().unwrap()).map(|(s, _)| s)
}

/// The elbow's weight: a smoothstep over [ELBOW − BLEND, ELBOW + BLEND].
fn elbow_weight(z: f32) -> f32 {
    let t = ((z - (ELBOW - BLEND)) / (2.0 * BLEND)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The bend in closed form: the elbow's part turned by `degrees` about +y through the
/// elbow, blended linearly with the root's (which stays).
fn closed_form(p: Vec3, degrees: f32) -> Vec3 {
    let elbow = Vec3::new(0.0, 0.0, ELBOW);
    let turned = elbow + Quat::from_rotation_y(degrees.to_radians()) * (p - elbow);
    p.lerp(turned, elbow_weight(p.z))
}

#[test]
fn skinning_matches_the_closed_form_bend() {
    let rest = load(&glb(), "rest").unwrap();
    assert_eq!(rest.vertex_count(), 2328);
    for (pose, degrees) in [
        ("bend@1", 90.0),
        ("bend@0.5", 45.0),
        ("bend#1", 45.0),
        ("bend@0.25", 22.5),
        ("0@5", 90.0),
        ("bend@-1", 0.0),
    ] {
        let posed = load(&glb(), pose).unwrap();
        let mut worst = 0.0f32;
        for (p, q) in rest.positions.iter().zip(&posed.positions) {
            worst = worst.max((closed_form(*p, degrees) - *q).length());
        }
        // Where one joint holds the vertex, its normal turns rigidly with it.
        let turn = Quat::from_rotation_y(degrees.to_radians());
        let mut normal = 0.0f32;
        for v in 0..rest.vertex_count() {
            let w = elbow_weight(rest.positions[v].z);
            let expected = if w == 1.0 {
                turn * rest.normals[v]
            } else {
                rest.normals[v]
            };
            if w == 0.0 || w == 1.0 {
                normal = normal.max((expected - posed.normals[v]).length());
            }
        }
        eprintln!("pose {pose}: largest |skinned − closed form| {worst:.2e}, normals {normal:.2e}");
        assert!(worst < 2e-6 && normal < 2e-6, "{pose}: {worst} {normal}");
    }
}

/// A file as it is written and read back: what `relight` sees.
fn ldprt(scene: &Scene, transfer: &Transfer, lobes: usize) -> LdprtFile {
    let mut file = fit_bake(scene, transfer, lobes).unwrap();
    file.pose = Some("rest".into());
    LdprtFile::from_bytes(&file.to_bytes()).unwrap()
}

#[test]
fn skinned_lobes_beat_the_straight_bake_on_the_outer_side_of_the_bend() {
    let (rest, bent) = (
        load(&glb(), "rest").unwrap(),
        load(&glb(), "bend@1").unwrap(),
    );
    let straight_bake = bake(&rest);
    let fresh = bake(&bent);
    let positions = &rest.positions;
    // Outer side: the blend and the turned half facing away from the bend's centre (rest
    // x < −r/2); inner side: facing it (rest x > r/2).
    let side = |outer: bool| -> Vec<usize> {
        (0..positions.len())
            .filter(|&v| positions[v].z > ELBOW - BLEND)
            .filter(|&v| (positions[v].x < -0.5 * RADIUS) == outer)
            .filter(|&v| outer || positions[v].x > 0.5 * RADIUS)
            .collect()
    };
    let (outer, inner) = (side(true), side(false));
    for lobes in [1, 3] {
        let file = ldprt(&rest, &straight_bake, lobes);
        let axes = pose_axes(&file, &glb(), &bent).unwrap();
        let mut ratios = Vec::new();
        for (theta, phi) in [(65.0, 30.0), (120.0, 200.0), (40.0, 150.0)] {
            let light = light(theta, phi);
            let truth = sh_radiance(&fresh, &bent, &light);
            let naive = sh_radiance(&straight_bake, &bent, &light);
            let skinned = ldprt_radiance_axes(&file, &bent, &axes, &light);
            let (ld_out, sh_out) = (rms(&skinned, &truth, &outer), rms(&naive, &truth, &outer));
            let (ld_in, sh_in) = (rms(&skinned, &truth, &inner), rms(&naive, &truth, &inner));
            eprintln!(
                "skinned tube at 90°, {lobes} lobe(s), sun ({theta}, {phi}): outer RMS LDPRT \
                 {ld_out:.4} vs straight SH {sh_out:.4} ({:.1}x); inner LDPRT {ld_in:.4} vs \
                 straight SH {sh_in:.4}",
                sh_out / ld_out
            );
            ratios.push(sh_out / ld_out);
        }
        let least = ratios.iter().fold(f64::INFINITY, |a, &b| a.min(b));
        assert!(
            least >= 2.0,
            "{lobes} lobe(s): only {least:.2}x closer on the outer side"
        );
    }
}

#[test]
fn skinned_frames_equal_the_baked_frames_at_rest_and_stay_close_when_bent() {
    let rest = load(&glb(), "rest").unwrap();
    let file = ldprt(&rest, &bake(&rest), 3);
    let light = light(65.0, 30.0);
    // At the baked pose the skinned rule is the identity on the baked frames.
    let on_rest = ldprt_radiance_axes(
        &file,
        &rest,
        &pose_axes(&file, &glb(), &rest).unwrap(),
        &light,
    );
    let framed = ldprt_radiance(&file, &rest, &light);
    let at_rest = on_rest
        .iter()
        .flatten()
        .zip(framed.iter().flatten())
        .fold(0.0f32, |a, (x, y)| a.max((x - y).abs()));
    assert!(at_rest < 1e-5, "{at_rest}");
    // Bent: the skinned frames and the frames rebuilt from the bent mesh share the normal
    // but not the tangent where the blend shears the surface; how much that moves the
    // radiance is reported.
    let bent = load(&glb(), "bend@1").unwrap();
    let skinned = ldprt_radiance_axes(
        &file,
        &bent,
        &pose_axes(&file, &glb(), &bent).unwrap(),
        &light,
    );
    let rebuilt = ldprt_radiance(&file, &bent, &light);
    let all: Vec<usize> = (0..bent.vertex_count()).collect();
    let largest = skinned.iter().flatten().fold(0.0f32, |a, b| a.max(*b));
    let worst = skinned
        .iter()
        .flatten()
        .zip(rebuilt.iter().flatten())
        .fold(0.0f32, |a, (x, y)| a.max((x - y).abs()));
    eprintln!(
        "bent 90°: skinned axes vs rebuilt frames, RMS {:.2e}, largest {worst:.2e} (radiance up to {largest:.3}); at rest {at_rest:.1e}",
        rms(&skinned, &rebuilt, &all)
    );
    assert!(rms(&skinned, &rebuilt, &all) < 0.02);
}

/// The GLB with its JSON edited by `edit` (the binary chunk kept).
fn edited(edit: impl Fn(&mut serde_json::Value)) -> (tempfile::TempDir, PathBuf) {
    let bytes = std::fs::read(glb()).unwrap();
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let mut json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    edit(&mut json);
    let mut text = serde_json::to_string(&json).unwrap();
    while text.len() % 4 != 0 {
        text.push(' ');
    }
    let bin = &bytes[20 + json_len..];
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + text.len() + bin.len()) as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(text.as_bytes());
    out.extend(bin);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("edited.glb");
    std::fs::write(&path, out).unwrap();
    (dir, path)
}

#[test]
fn bad_skins_are_refused_and_missing_inverse_binds_are_identities() {
    let refused = |edit: &dyn Fn(&mut serde_json::Value), pose: &str, expected: &str| {
        let (_dir, path) = edited(edit);
        let message = load(&path, pose).unwrap_err().to_string();
        assert!(
            message.contains("edited.glb") && message.contains(expected),
            "{message}"
        );
    };
    // Joint 1 named by JOINTS_0, but the skin lists one joint.
    refused(
        &|j| j["skins"][0]["joints"] = serde_json::json!([0]),
        "rest",
        "names joint 1, but the skin has 1 joints",
    );
    // Vertex 0's weights replaced (a sparse accessor) by the first normal's floats.
    let sparse = serde_json::json!({"count": 1, "indices": {"bufferView": 2, "componentType": 5121},
                                    "values": {"bufferView": 1}});
    refused(
        &|j| j["accessors"][3]["sparse"] = sparse.clone(),
        "rest",
        "the weights of vertex 0 sum to",
    );
    refused(
        &|j| j["accessors"][5]["count"] = serde_json::json!(2),
        "rest",
        "2 matrices for 3 joints",
    );
    refused(
        &|j| j["accessors"][2]["componentType"] = serde_json::json!(5126),
        "rest",
        "JOINTS_0",
    );
    refused(
        &|_| {},
        "walk@1",
        "no animation 'walk' (the file has 1: bend)",
    );
    refused(&|_| {}, "bend#3", "has 3 keyframes");
    // No inverse bind matrices: each is the identity (glTF 2.0 §5.27), so the elbow's
    // vertices sit one elbow height higher at rest.
    let (_dir, path) = edited(|j| {
        j["skins"][0]
            .as_object_mut()
            .unwrap()
            .remove("inverseBindMatrices");
    });
    let (rest, identity) = (load(&glb(), "rest").unwrap(), load(&path, "rest").unwrap());
    for (p, q) in rest.positions.iter().zip(&identity.positions) {
        let lift = Vec3::new(0.0, 0.0, elbow_weight(p.z) * ELBOW);
        assert!((*p + lift - *q).length() < 1e-5, "{p} {q}");
    }
}

/// Accessor `name` of the exported file's only primitive, as f32s.
fn attribute(document: &gltf::Document, bin: &[u8], name: &str) -> Vec<f32> {
    let primitive = document
        .meshes()
        .next()
        .unwrap()
        .primitives()
        .next()
        .unwrap();
    let (_, accessor) = primitive
        .attributes()
        .find(|(s, _)| s.to_string() == name)
        .unwrap_or_else(|| panic!("no {name}"));
    let view = accessor.view().unwrap();
    let start = view.offset() + accessor.offset();
    let length = accessor.count() * accessor.size();
    bin[start..start + length]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect()
}

/// The exported GLB lit as a runtime lights it, skinned here by the closed-form joints
/// (root fixed, elbow turned about +y), against `relight --pose`'s computation at three
/// frames of the animation: the runtime's rule and the command line's are one.
#[test]
fn exported_lobes_skinned_like_a_runtime_light_as_relight_does() {
    let rest = load(&glb(), "rest").unwrap();
    let transfer = bake(&rest);
    let dir = tempfile::tempdir().unwrap();
    let (ldprt_path, out) = (dir.path().join("t.ldprt"), dir.path().join("t.glb"));
    let mut file = fit_bake(&rest, &transfer, 3).unwrap();
    file.pose = Some("rest".into());
    std::fs::write(&ldprt_path, file.to_bytes()).unwrap();
    prt_baker::export::ldprt_gltf::export_ldprt_glb(&ldprt_path, &glb(), &out).unwrap();
    let (document, buffers, _) = gltf::import(&out).unwrap();
    let bin = &buffers[0].0;
    let normals = attribute(&document, bin, "_LDPRT_NORMAL");
    let tangents = attribute(&document, bin, "_LDPRT_TANGENT");
    let positions = attribute(&document, bin, "POSITION");
    let axes: Vec<Vec<f32>> = (0..3)
        .map(|k| attribute(&document, bin, &format!("_LDPRT_AXIS_{k}")))
        .collect();
    let zh: Vec<Vec<f32>> = (0..3)
        .map(|k| attribute(&document, bin, &format!("_LDPRT_ZH_{k}")))
        .collect();
    // The skin and the animation came through untouched.
    assert_eq!(document.skins().count(), 1);
    assert_eq!(document.animations().next().unwrap().name(), Some("bend"));
    let basis = prt_baker::math::sh::Basis::new(ORDER);
    let light = light(65.0, 30.0);
    for (pose, degrees) in [("bend@0", 0.0f32), ("bend@0.5", 45.0), ("bend@1", 90.0)] {
        let posed = load(&glb(), pose).unwrap();
        let cli = ldprt_radiance_axes(
            &file,
            &posed,
            &pose_axes(&file, &glb(), &posed).unwrap(),
            &light,
        );
        let turn = glam::DMat3::from_quat(DQuat::from_rotation_y(f64::from(degrees).to_radians()));
        let albedo = posed.vertex_albedo();
        let mut worst = 0.0f64;
        for v in 0..posed.vertex_count() {
            // Blended linear part: (1 − w) I + w R (the root is fixed, the elbow turns).
            let w = f64::from(elbow_weight(positions[3 * v + 2]));
            let m = glam::DMat3::IDENTITY * (1.0 - w) + turn * w;
            let at =
                |a: &[f32]| DVec3::new(a[3 * v].into(), a[3 * v + 1].into(), a[3 * v + 2].into());
            let n = (m * at(&normals)).normalize();
            let t = m * at(&tangents);
            let t = (t - n * t.dot(n)).normalize();
            let frame = [t, n.cross(t), n];
            let mut sh = vec![0.0; 16];
            let mut y = vec![0.0; 16];
            for k in 0..3 {
                let a = at(&axes[k]);
                let axis = frame[0] * a.x + frame[1] * a.y + frame[2] * a.z;
                let g: Vec<f64> = zh[k][4 * v..4 * v + 4].iter().map(|&x| x.into()).collect();
                prt_baker::bake::ldprt::fit::add_lobe(
                    &basis,
                    axis.normalize(),
                    &g,
                    &mut y,
                    &mut sh,
                );
            }
            for c in 0..3 {
                let dot: f64 = sh.iter().zip(&light.rgb[c]).map(|(t, l)| t * l).sum();
                let runtime = f64::from(albedo[v][c]) * dot;
                worst = worst.max((runtime - f64::from(cli[v][c])).abs());
            }
        }
        eprintln!(
            "exported GLB skinned as a runtime, {pose}: largest |runtime − relight| {worst:.2e}"
        );
        assert!(worst < 1e-4, "{pose}: {worst}");
    }
}
