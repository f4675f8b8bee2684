//! `relight … --occluder OCC.prt --at X,Y,Z [--turn X,Y,Z,DEGREES] …`: the groups that place
//! moving occluders over a bake, checked and handed to
//! [`prt_baker::export::relight_occluded`].

use std::path::{Path, PathBuf};

use prt_baker::Error;
use prt_baker::export::relight_occluded::{PlacedOccluder, relight_occluded};

#[derive(clap::Args)]
pub struct OccluderGroups {
    /// A moving occluder (an occluder file: `bake OBJ --occluder`) whose shadow darkens the bake, placed by the --at (and --turn) given with it; repeat `--occluder … --at …` for several (docs/guides/occluders.md). Vector bakes, per vertex or per texel.
    #[arg(long, value_name = "OCC.prt", requires = "at", conflicts_with = "view")]
    occluder: Vec<PathBuf>,
}

impl OccluderGroups {
    pub fn is_empty(&self) -> bool {
        self.occluder.is_empty()
    }

    /// Pairs each --occluder with its --at and --turn (all or none of the groups turned).
    pub fn placed(
        &self,
        at: &[glam::Vec3],
        turn: &[glam::DQuat],
    ) -> Result<Vec<PlacedOccluder>, Error> {
        let count = self.occluder.len();
        if at.len() != count || !(turn.is_empty() || turn.len() == count) {
            return Err(Error::InvalidOption(format!(
                "{count} --occluder need {count} --at and none or {count} --turn (got {} and {})",
                at.len(),
                turn.len()
            )));
        }
        Ok(self
            .occluder
            .iter()
            .enumerate()
            .map(|(k, file)| PlacedOccluder {
                file: file.clone(),
                position: at[k],
                rotation: turn.get(k).copied().unwrap_or_default(),
            })
            .collect())
    }
}

/// Without occluders, --at and --turn belong to --probes: one each at most.
pub fn check_placement(probes: bool, at: &[glam::Vec3], turn: &[glam::DQuat]) -> Result<(), Error> {
    match (probes, at.len(), turn.len()) {
        (true, 1, 0 | 1) | (false, 0, 0) => Ok(()),
        (false, _, _) => Err(Error::InvalidOption(
            "--at and --turn place an object: give --probes or --occluder".into(),
        )),
        _ => Err(Error::InvalidOption(
            "--probes places one object: one --at and at most one --turn".into(),
        )),
    }
}

/// Relights and prints the summary line.
pub fn run(
    (scene, file, lights): (&Path, &Path, &Path),
    placed: &[PlacedOccluder],
    output: &Path,
    exposure: f64,
) -> Result<(), Error> {
    let relit = relight_occluded((scene, file), lights, placed, output, exposure)?;
    println!(
        "relit {} {} with {} light(s) at order {} through {} occluder(s), largest radiance {:.4} -> {}",
        relit.vertex_count,
        if relit.lightmap { "texels" } else { "vertices" },
        relit.light_count,
        relit.order,
        placed.len(),
        relit.max_radiance,
        output.display()
    );
    Ok(())
}
