//! `prt-bake bake --probes`: transfer probes instead of vertices (docs/probes.md).

use std::path::Path;

use prt_baker::bake::probes::{self, ProbeSpec};
use prt_baker::support::output::Output;
use prt_baker::trace::Tracer;
use prt_baker::{BakeOptions, CoefficientFile, Error, Scene};

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
