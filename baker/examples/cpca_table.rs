//! Error against size of CPCA compression (docs/performance.md, "CPCA compression"): for each
//! K clusters and M components, the bake compressed, written and read back as a version-2
//! file, relit by a rig, and compared with the uncompressed bake relit by the same rig.
//!
//! cargo run --release -p prt-baker --example cpca_table -- SCENE FILE.prt RIG.toml [K,.. [M,..]]

use std::path::Path;

use prt_baker::export::relight::vertex_radiance;
use prt_baker::formats::cpca_block;
use prt_baker::{CoefficientFile, Scene, light::Rig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 4 {
        return Err("usage: cpca_table SCENE FILE.prt RIG.toml [K,K,..] [M,M,..]".into());
    }
    let list = |i: usize, default: &[usize]| -> Vec<usize> {
        args.get(i).map_or(default.to_vec(), |s| {
            s.split(',').map(|x| x.parse().expect("a number")).collect()
        })
    };
    let (clusters, pcs) = (list(4, &[16, 64, 256]), list(5, &[2, 4, 8]));
    let scene = Scene::load(Path::new(&args[1]))?;
    let file = CoefficientFile::read(Path::new(&args[2]))?;
    file.check_scene(Path::new(&args[2]), &scene)?;
    let light = Rig::load(Path::new(&args[3]))?
        .project(file.header.order as usize)
        .in_scene_frame(file.header.up);
    let albedo = scene.vertex_albedo();
    let reference = vertex_radiance(&file, &albedo, &light);
    let norm: f64 = reference
        .iter()
        .flatten()
        .map(|&r| f64::from(r).powi(2))
        .sum();
    let (v1, _) = file.to_bytes();
    println!(
        "{} vertices, {} floats per vertex, {} bytes uncompressed",
        file.header.vertex_count,
        file.header.coefficients_per_vertex(),
        v1.len()
    );
    println!(
        "| K | M | floats/vertex | ratio | bytes | coefficient rms | relit rms (rel.) | relit max (rel.) | s |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for &k in &clusters {
        for &m in &pcs {
            let started = std::time::Instant::now();
            let (fit, summary) = prt_baker::export::compress::compress_coefficients(&file, k, m)?;
            let seconds = started.elapsed().as_secs_f64();
            let bytes = cpca_block::to_bytes(&file, &fit, summary.rms_error as f32);
            let read = CoefficientFile::from_bytes(&bytes)?;
            let relit = vertex_radiance(&read, &albedo, &light);
            let (mut sum, mut max, mut peak) = (0.0f64, 0.0f64, 0.0f64);
            for (a, b) in relit.iter().flatten().zip(reference.iter().flatten()) {
                let d = f64::from(*a) - f64::from(*b);
                sum += d * d;
                max = max.max(d.abs());
                peak = peak.max(f64::from(*b).abs());
            }
            println!(
                "| {} | {m} | {:.2} | {:.3} | {} | {:.2e} | {:.3} % | {:.2} % | {seconds:.1} |",
                summary.clusters,
                summary.floats_per_vertex,
                summary.floats_per_vertex / file.header.coefficients_per_vertex() as f64,
                bytes.len(),
                summary.rms_error,
                100.0 * (sum / norm).sqrt(),
                100.0 * max / peak,
            );
        }
    }
    Ok(())
}
