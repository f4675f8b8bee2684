//! LDPRT oracles (docs/guides/characters.md): the rigid limit (an LDPRT bake relit on its own
//! mesh is within the fit error it reports of the SH bake it came from), rotation (turning
//! the mesh equals turning the light the other way), and deformation (`scenes/tube`, a ribbed
//! tube bent 90°:
//! the straight bake's lobes on the bent tube against a fresh bake of the bent tube, compared
//! with the straight bake's world-space SH transfer).

mod relit;

use std::path::Path;

use glam::{DQuat, DVec3, Vec3};
use prt_baker::Scene;
use prt_baker::bake::ldprt::fit_bake;
use prt_baker::export::relight_ldprt::ldprt_radiance;
use prt_baker::formats::ldprt_file::LdprtFile;
use prt_baker::math::sh::rotation::ShRotation;
use prt_baker::scene::Mesh;
use relit::{ORDER, bake, light, rms, sh_radiance};

/// The tube's radius and the z where its bend starts (`scenes/src/tube.rs`: length 2, a
/// quarter circle of radius 0.3 about the middle).
const RADIUS: f32 = 0.2;
const BEND_START: f32 = 1.0 - 0.3 * std::f32::consts::FRAC_PI_4;

/// `scenes/tube/NAME.obj`: the ribbed tube, straight (`tube`) or bent 90° (`tube-bent`),
/// the same vertices and triangles.
fn tube(name: &str) -> Scene {
    let path = format!("{}/../scenes/tube/{name}.obj", env!("CARGO_MANIFEST_DIR"));
    Scene::load(Path::new(&path)).unwrap()
}

/// `scene` with its positions replaced (normals recomputed from them).
fn posed(scene: &Scene, positions: Vec<Vec3>) -> Scene {
    let mesh = Mesh {
        name: "tube".into(),
        positions,
        triangles: scene.triangles.clone(),
        ..Mesh::default()
    };
    Scene::from_meshes(Path::new("tube.obj"), vec![mesh], Vec::new()).unwrap()
}

#[test]
fn rigid_limit_is_within_the_reported_fit_error() {
    let scene = tube("tube");
    let transfer = bake(&scene);
    for lobes in [1, 3] {
        let file = fit_bake(&scene, &transfer, lobes).unwrap();
        let file = LdprtFile::from_bytes(&file.to_bytes()).unwrap();
        let albedo = scene.vertex_albedo();
        let mut worst = 0.0f64;
        for (theta, phi) in [(65.0, 30.0), (120.0, 200.0), (10.0, 0.0)] {
            let light = light(theta, phi);
            let sh = sh_radiance(&transfer, &scene, &light);
            let ld = ldprt_radiance(&file, &scene, &light);
            for v in 0..scene.vertex_count() {
                // Cauchy–Schwarz: |L·(t − fit)| ≤ ‖L‖ ‖t − fit‖ = ‖L‖ · error · ‖t‖.
                let t: f64 = transfer
                    .vertex(v, 0)
                    .iter()
                    .map(|x| f64::from(*x).powi(2))
                    .sum();
                for c in 0..3 {
                    let l: f64 = light.rgb[c].iter().map(|x| x * x).sum();
                    let bound =
                        f64::from(albedo[v][c]) * (l * t).sqrt() * f64::from(file.vertex_error[v]);
                    let diff = f64::from((sh[v][c] - ld[v][c]).abs());
                    assert!(
                        diff <= bound * 1.001 + 1e-5,
                        "vertex {v}: {diff} > bound {bound}"
                    );
                    worst = worst.max((diff - 1e-5) / (bound + 1e-12));
                }
            }
            eprintln!(
                "rigid limit, {lobes} lobe(s), sun at ({theta}, {phi}): relit RMS vs SH {:.5}, fit error mean {:.4} p99 {:.4}",
                rms(&sh, &ld, &(0..scene.vertex_count()).collect::<Vec<_>>()),
                file.error.mean,
                file.error.p99
            );
        }
        eprintln!("rigid limit, {lobes} lobe(s): largest (difference − 1e-5) / bound {worst:.3}");
    }
}

#[test]
fn turning_the_mesh_equals_turning_the_light_back() {
    let loaded = tube("tube");
    let file = fit_bake(&loaded, &bake(&loaded), 2).unwrap();
    // Both poses' normals computed the same way, from their own positions.
    let rest = posed(&loaded, loaded.positions.clone());
    let q = DQuat::from_axis_angle(DVec3::new(0.3, -1.0, 0.5).normalize(), 1.1);
    let turned = posed(
        &rest,
        rest.positions.iter().map(|p| q.as_quat() * *p).collect(),
    );
    let light = light(65.0, 30.0);
    let on_turned = ldprt_radiance(&file, &turned, &light);
    let back = light.rotated(&ShRotation::from_quat(ORDER, q.inverse()));
    let on_rest = ldprt_radiance(&file, &rest, &back);
    let largest = on_rest.iter().flatten().fold(0.0f32, |a, b| a.max(b.abs()));
    let worst = on_turned
        .iter()
        .flatten()
        .zip(on_rest.iter().flatten())
        .fold(0.0f32, |a, (x, y)| a.max((x - y).abs()));
    eprintln!(
        "rotation: largest |turned mesh − turned light| {worst:.2e} of radiance up to {largest:.3}"
    );
    assert!(worst <= 1e-5 * largest.max(1.0), "{worst}");
}

#[test]
fn deformed_lobes_beat_the_straight_bake_on_the_outer_side_of_the_bend() {
    let (straight, bent) = (tube("tube"), tube("tube-bent"));
    let straight_bake = bake(&straight);
    let fresh = bake(&bent);
    let (positions, z0) = (&straight.positions, BEND_START);
    // Outer side: vertices of the bend and the turned half facing away from the bend's
    // centre (rest x < −r/2); inner side: facing it (rest x > r/2).
    let side = |outer: bool| -> Vec<usize> {
        (0..positions.len())
            .filter(|&v| positions[v].z > z0 && (positions[v].x < -0.5 * RADIUS) == outer)
            .filter(|&v| outer || positions[v].x > 0.5 * RADIUS)
            .collect()
    };
    let (outer, inner) = (side(true), side(false));
    for lobes in [1, 3] {
        let file = fit_bake(&straight, &straight_bake, lobes).unwrap();
        let mut ratios = Vec::new();
        for (theta, phi) in [(65.0, 30.0), (120.0, 200.0), (40.0, 150.0)] {
            let light = light(theta, phi);
            let truth = sh_radiance(&fresh, &bent, &light);
            let naive = sh_radiance(&straight_bake, &bent, &light);
            let deformed = ldprt_radiance(&file, &bent, &light);
            let (ld_out, sh_out) = (rms(&deformed, &truth, &outer), rms(&naive, &truth, &outer));
            let (ld_in, sh_in) = (rms(&deformed, &truth, &inner), rms(&naive, &truth, &inner));
            eprintln!(
                "bent tube, {lobes} lobe(s), sun ({theta}, {phi}): outer RMS LDPRT {ld_out:.4} vs \
                 straight SH {sh_out:.4} ({:.1}x); inner RMS LDPRT {ld_in:.4} vs straight SH {sh_in:.4}",
                sh_out / ld_out
            );
            ratios.push(sh_out / ld_out);
        }
        let least = ratios.iter().fold(f64::INFINITY, |a, &b| a.min(b));
        assert!(
            least >= 2.0,
            "{lobes} lobe(s): LDPRT only {least:.2}x closer on the outer side"
        );
    }
}
