//! `prt-bake light`: a light rig projected to SH, as the JSON an engine or the three.js runtime
//! reads.

use std::path::PathBuf;

use prt_baker::Error;
use prt_baker::light::Rig;
use prt_baker::math::sh;
use prt_baker::support::output::Output;

use super::UpArg;

#[derive(clap::Args)]
pub struct LightArgs {
    /// The rig file (docs/reference/lights.md).
    rig: PathBuf,
    /// SH order n: n² coefficients per colour channel.
    #[arg(long, default_value_t = 4)]
    order: usize,
    /// The up axis of the scene the coefficients are for: rigs are written for a z-up
    /// world and are turned to a y-up scene as `relight` and the viewer turn them.
    #[arg(long, value_enum, default_value_t = UpArg::Z)]
    up: UpArg,
    /// Output .json file (`-`: standard output).
    #[arg(short, long)]
    output: PathBuf,
}

pub fn run(args: LightArgs) -> Result<(), Error> {
    let LightArgs {
        rig,
        order,
        up,
        output,
    } = args;
    let (rig, output) = (rig.as_path(), output.as_path());
    if !(1..=sh::MAX_ORDER).contains(&order) {
        return Err(Error::InvalidOption(format!(
            "--order {order} is outside 1..={}",
            sh::MAX_ORDER
        )));
    }
    Output::new_or_stdout(output, &[rig.to_path_buf()])?;
    let rig = Rig::load(rig)?;
    let output = Output::new_or_stdout(output, &rig.input_files())?;
    let json = rig.project(order).in_scene_frame(up.up()).to_json() + "\n";
    output.write(json.as_bytes())
}
