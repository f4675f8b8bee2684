//! `prt-bake export --npz` of a probe bake (`bake --probes`, docs/guides/probes.md).

use std::path::Path;

use crate::formats::coefficient_file::CoefficientFile;
use crate::formats::npz::{self, Array};
use crate::math::sh;
use crate::scene::Scene;
use crate::support::error::Result;

/// Writes `probe_positions` (P, 3), `probe_backface_fraction` (P,: above 0.25 the probe is
/// inside geometry) and `probe_transfer` (P, channels, n², n²), float32 in the
/// file's probe order: row i of a probe's matrix maps the light's coefficients to the
/// incident radiance's coefficient i (L_in = M·L). The file must have been baked in `scene`.
pub fn export(path: &Path, file: &CoefficientFile, scene: &Scene, output: &Path) -> Result<()> {
    let probes = file.check_probe_scene(path, scene)?;
    let positions = &probes.positions;
    let mut inputs = scene.input_files();
    inputs.push(path.to_path_buf());
    let output = crate::support::output::Output::new(output, &inputs)?;
    let p = positions.len();
    let n = sh::coeff_count(file.header.order as usize);
    let flat: Vec<f32> = positions.iter().flat_map(|x| x.to_array()).collect();
    let arrays = [
        Array {
            name: "probe_positions",
            shape: vec![p, 3],
            data: &flat,
        },
        Array {
            name: "probe_backface_fraction",
            shape: vec![p],
            data: &probes.backfaces,
        },
        Array {
            name: "probe_transfer",
            shape: vec![p, file.header.channels as usize, n, n],
            data: &file.coefficients,
        },
    ];
    output.write(&npz::to_bytes(&arrays, &[], &[])?)
}
