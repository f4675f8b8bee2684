//! `prt-bake bake --probes`: transfer probes instead of vertices (docs/probes.md).

use std::path::Path;

use prt_baker::bake::probes::{self, ProbeSpec};
use prt_baker::support::output::Output;
use prt_baker::trace::Tracer;
use prt_baker::{BakeOptions, CoefficientFile, Error, Scene};

/// What a memory error names: the points file, or the grid.
fn spec_name(spec: &ProbeSpec) -> String {
    match spec {
        ProbeSpec::Points(path) => path.display().to_string(),
        ProbeSpec::Grid { counts, .. } => {
            format!("--probes grid:{},{},{}", counts[0], counts[1], counts[2])
        }
    }
}

/// Bakes the probes `spec` names in `scene` into the probe file `output`, and prints a summary.
pub fn bake(
    spec: &str,
    output: &Path,
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    progress: &dyn prt_baker::support::progress::Progress,
) -> Result<(), Error> {
    let spec = ProbeSpec::parse(spec)?;
    let mut inputs = scene.input_files();
    if let ProbeSpec::Points(path) = &spec {
        inputs.push(path.clone());
    }
    let output_file = Output::new(output, &inputs)?;
    let probes = spec.probes(scene)?;
    let count = probes.positions.len();
    // Two hemisphere matrices per probe in up to 3 channels, beside the vertex bake.
    let n2 = (options.order * options.order) as u64;
    let needed = (count as u64)
        .checked_mul(2 * 3 * n2 * n2 * 4)
        .and_then(|b| {
            b.checked_add(prt_baker::bake::memory::bake_bytes(
                options,
                scene.vertex_count() as u64,
                scene.triangles.len() as u64,
            )?)
        });
    prt_baker::support::limits::check(
        spec_name(&spec),
        &format!("baking {count} probes at order {}", options.order),
        needed,
    )?;
    let transfer = probes::bake(scene, tracer, options, &probes.positions, progress)?;
    let file = CoefficientFile::from_probe_bake(scene, &transfer, tracer, probes);
    output_file.write(&file.to_bytes().0)?;
    let rays = match transfer.rays_cast {
        0 => String::from("no rays"),
        rays => format!(
            "{rays} rays, {:.2} Mrays/s",
            rays as f64 / transfer.seconds.max(1e-9) / 1e6
        ),
    };
    println!(
        "baked {} probes, {rays}, {:.2} s (order {}, {}, {} channels, {} samples, {}) -> {}",
        count,
        transfer.seconds,
        options.order,
        options.mode.name(),
        transfer.channels,
        options.samples,
        transfer.backend.name(),
        output.display()
    );
    Ok(())
}
