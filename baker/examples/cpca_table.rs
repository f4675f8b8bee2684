//! Error against size of CPCA compression (docs/explanation/performance.md, "CPCA compression"): for each
//! K clusters and M components, the bake compressed, written and read back as a version-2
//! file, relit by a rig, and compared with the uncompressed bake relit by the same rig.
//!
//! Besides the rig, "upper suns" relights both with a white sun at each of 96 directions
//! spread evenly over the upper hemisphere (about the scene's up axis): the error a rig
//! turned anywhere above the horizon would see, where one rig sees one direction's luck.
//!
//! With REFERENCE.prt, a bake of the same scene with many more rays (docs/explanation/performance.md,
//! "CPCA against converged transfer"), three more columns compare against it instead: the
//! bake itself (its Monte Carlo noise), and the compressed bake (noise and model together).
//!
//! cargo run --release -p prt-baker --example cpca_table -- SCENE FILE.prt RIG.toml [K,.. [M,.. [PRIOR [REFERENCE.prt]]]]
//! (PRIOR: `sphere`, the default, or `upper-hemisphere`, as `compress --light-prior`)

use std::path::Path;

use glam::DVec3;
use prt_baker::export::compress::FitOptions;
use prt_baker::export::relight::vertex_radiance;
use prt_baker::formats::cpca_block;
use prt_baker::light::LightCoefficients;
use prt_baker::math::light_prior::LightPrior;
use prt_baker::math::sh;
use prt_baker::{CoefficientFile, Scene, light::Rig};

/// White suns (unwindowed SH deltas) at `count` directions of the hemisphere about `up`, a
/// Fibonacci spiral in cos θ.
fn upper_suns(order: usize, up: DVec3, count: usize) -> Vec<LightCoefficients> {
    let (t1, t2) = up.any_orthonormal_pair();
    let basis = sh::Basis::new(order);
    let mut y = vec![0.0f64; order * order];
    (0..count)
        .map(|i| {
            let cos = (i as f64 + 0.5) / count as f64;
            let sin = (1.0 - cos * cos).sqrt();
            let phi = i as f64 * 2.399_963_229_728_653; // the golden angle
            basis.eval_recurrence(cos * up + sin * (phi.cos() * t1 + phi.sin() * t2), &mut y);
            LightCoefficients::tinted(order, &y, DVec3::ONE)
        })
        .collect()
}

/// Σ(relit a − relit b)² and Σ(relit b)² over vertices and channels.
fn relit_sums(a: &[[f32; 3]], b: &[[f32; 3]]) -> (f64, f64) {
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .fold((0.0, 0.0), |(s, n), (&x, &y)| {
            let (x, y) = (f64::from(x), f64::from(y));
            (s + (x - y) * (x - y), n + y * y)
        })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 4 {
        return Err(
            "usage: cpca_table SCENE FILE.prt RIG.toml [K,K,..] [M,M,..] [PRIOR] [REFERENCE.prt]"
                .into(),
        );
    }
    let list = |i: usize, default: &[usize]| -> Vec<usize> {
        args.get(i).map_or(default.to_vec(), |s| {
            s.split(',').map(|x| x.parse().expect("a number")).collect()
        })
    };
    let (clusters, pcs) = (list(4, &[16, 64, 256]), list(5, &[2, 4, 8]));
    let prior = match args.get(6).map(String::as_str) {
        None | Some("sphere") => LightPrior::Sphere,
        Some("upper-hemisphere") => LightPrior::UpperHemisphere,
        Some(other) => return Err(format!("unknown prior {other}").into()),
    };
    let scene = Scene::load(Path::new(&args[1]))?;
    let file = CoefficientFile::read(Path::new(&args[2]))?;
    file.check_scene(Path::new(&args[2]), &scene)?;
    let converged = match args.get(7) {
        Some(path) => {
            let converged = CoefficientFile::read(Path::new(path))?;
            converged.check_scene(Path::new(path), &scene)?;
            Some(converged)
        }
        None => None,
    };
    let light = Rig::load(Path::new(&args[3]))?
        .project(file.header.order as usize)
        .in_scene_frame(file.header.up);
    let albedo = scene.vertex_albedo();
    let reference = vertex_radiance(&file, &albedo, &light);
    let order = file.header.order as usize;
    let suns = upper_suns(order, file.header.up.vector(), 96);
    let sun_references: Vec<_> = suns
        .iter()
        .map(|sun| vertex_radiance(&file, &albedo, sun))
        .collect();
    // The converged bake relit by the rig and by the suns, and the bake's own error against it.
    let converged = converged.map(|c| {
        let rig = vertex_radiance(&c, &albedo, &light);
        let suns: Vec<_> = suns
            .iter()
            .map(|sun| vertex_radiance(&c, &albedo, sun))
            .collect();
        let (s, n) = relit_sums(&reference, &rig);
        let (mut ss, mut sn) = (0.0, 0.0);
        for (mine, theirs) in sun_references.iter().zip(&suns) {
            let (a, b) = relit_sums(mine, theirs);
            ss += a;
            sn += b;
        }
        println!(
            "bake against the reference: relit rms {:.3} %, upper suns rms {:.3} %",
            100.0 * (s / n).sqrt(),
            100.0 * (ss / sn).sqrt()
        );
        (rig, suns)
    });
    let (v1, _) = file.to_bytes();
    println!(
        "{} vertices, {} floats per vertex, {} bytes uncompressed",
        file.header.vertex_count,
        file.header.coefficients_per_vertex(),
        v1.len()
    );
    println!(
        "| K | M | floats/vertex | ratio | bytes | coefficient rms | relit rms (rel.) | relit max (rel.) | upper suns rms (rel.) | s |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for &k in &clusters {
        for &m in &pcs {
            let started = std::time::Instant::now();
            let (fit, summary) = prt_baker::export::compress::compress_coefficients(
                &file,
                &FitOptions {
                    prior,
                    ..FitOptions::new(k, m)
                },
            )?;
            let seconds = started.elapsed().as_secs_f64();
            let bytes = cpca_block::to_bytes(&file, &fit, summary.rms_error as f32);
            let read = CoefficientFile::from_bytes(&bytes)?;
            let relit = vertex_radiance(&read, &albedo, &light);
            let (sum, norm) = relit_sums(&relit, &reference);
            let (mut max, mut peak) = (0.0f64, 0.0f64);
            for (a, b) in relit.iter().flatten().zip(reference.iter().flatten()) {
                max = max.max((f64::from(*a) - f64::from(*b)).abs());
                peak = peak.max(f64::from(*b).abs());
            }
            let (mut sun_sum, mut sun_norm) = (0.0, 0.0);
            for (sun, reference) in suns.iter().zip(&sun_references) {
                let (s, n) = relit_sums(&vertex_radiance(&read, &albedo, sun), reference);
                sun_sum += s;
                sun_norm += n;
            }
            let against = converged.as_ref().map_or(String::new(), |(rig, rig_suns)| {
                let (s, n) = relit_sums(&relit, rig);
                let (mut ss, mut sn) = (0.0, 0.0);
                for (sun, theirs) in suns.iter().zip(rig_suns) {
                    let (a, b) = relit_sums(&vertex_radiance(&read, &albedo, sun), theirs);
                    ss += a;
                    sn += b;
                }
                format!(
                    " against the reference: relit rms {:.3} %, upper suns rms {:.3} % |",
                    100.0 * (s / n).sqrt(),
                    100.0 * (ss / sn).sqrt()
                )
            });
            println!(
                "| {} | {m} | {:.2} | {:.3} | {} | {:.2e} | {:.3} % | {:.2} % | {:.3} % | {seconds:.1} |{against}",
                summary.clusters,
                summary.floats_per_vertex,
                summary.floats_per_vertex / file.header.coefficients_per_vertex() as f64,
                bytes.len(),
                summary.rms_error,
                100.0 * (sum / norm).sqrt(),
                100.0 * max / peak,
                100.0 * (sun_sum / sun_norm).sqrt(),
            );
        }
    }
    Ok(())
}
