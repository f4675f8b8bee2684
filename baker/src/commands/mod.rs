//! The subcommands of `prt-bake`, one file each. Every file holds the command's arguments
//! (clap declares their ranges and which flags need or exclude which), one function that turns
//! them into the library's options, and `run`, which calls the library and prints a summary.
//! `bake`, the largest, lowers its arguments into a plan (`bake_plan`, with the values of
//! `bake_values`) that `bake_run` runs stage by stage; `bake_parts`, `bake_probes` and
//! `bake_media` are its bakes in parts, of probes and its subsurface media.

pub mod bake;
pub mod bake_ldprt;
pub mod bake_media;
pub mod bake_occluder;
pub mod bake_parts;
pub mod bake_plan;
pub mod bake_probes;
pub mod bake_run;
pub mod bake_values;
pub mod compress;
pub mod export;
pub mod factor_seams;
pub mod gather;
pub mod inspect;
pub mod light;
pub mod merge;
pub mod relight;
pub mod relight_ldprt;
pub mod relight_occluders;
pub mod scene_load;
pub mod stitch;

use clap::ValueEnum;
use prt_baker::scene::Up;
use prt_baker::support::progress::{Progress, ProgressBar, Silent};

/// A progress bar on standard error, or nothing with `--quiet`.
pub fn progress(quiet: bool) -> Box<dyn Progress> {
    if quiet {
        Box::new(Silent)
    } else {
        Box::new(ProgressBar::new())
    }
}

/// `--up`: a scene's up axis.
#[derive(Clone, Copy, PartialEq, ValueEnum)]
pub enum UpArg {
    /// +z is up.
    Z,
    /// +y is up.
    Y,
}

impl UpArg {
    pub fn up(self) -> Up {
        match self {
            UpArg::Z => Up::Z,
            UpArg::Y => Up::Y,
        }
    }
}
