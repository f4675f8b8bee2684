//! `relight … --occluder OCC.prt --at X,Y,Z [--turn X,Y,Z,DEGREES] …`: the groups that place
//! moving occluders over a bake, checked and handed to
//! [`prt_baker::export::relight_occluded`].

use std::path::{Path, PathBuf};

use prt_baker::Error;
use prt_baker::export::relight_occluded::{PlacedOccluder, relight_occluded};

#[derive(clap::Args)]
pub struct OccluderGroups {
    /// A moving occluder (an occluder file: `bake OBJ --occluder`) whose shadow darkens the bake, placed by the --at and the optional --turn that follow it; repeat `--occluder … --at … [--turn …]` for several (docs/guides/occluders.md). Vector bakes, per vertex or per texel.
    #[arg(long, value_name = "OCC.prt", requires = "at", conflicts_with = "view")]
    occluder: Vec<PathBuf>,
}

impl OccluderGroups {
    pub fn is_empty(&self) -> bool {
        self.occluder.is_empty()
    }

    /// Pairs each --occluder with its --at and its --turn, if the group has one.
    pub fn placed(
        &self,
        at: &[glam::Vec3],
        turn: &[glam::DQuat],
    ) -> Result<Vec<PlacedOccluder>, Error> {
        let count = self.occluder.len();
        if at.len() != count {
            return Err(Error::InvalidOption(format!(
                "{count} --occluder need {count} --at (got {})",
                at.len()
            )));
        }
        let groups = turn_groups().unwrap_or_else(|| (0..turn.len()).collect());
        let mut rotations = vec![glam::DQuat::IDENTITY; count];
        let mut turned = vec![false; count];
        for (t, group) in groups.iter().enumerate() {
            if *group >= count || std::mem::replace(&mut turned[*group], true) {
                return Err(Error::InvalidOption(
                    "each --turn follows its own --occluder, at most one a group".into(),
                ));
            }
            rotations[*group] = turn[t];
        }
        Ok(self
            .occluder
            .iter()
            .zip(at.iter().zip(rotations))
            .map(|(file, (&position, rotation))| PlacedOccluder {
                file: file.clone(),
                position,
                rotation,
            })
            .collect())
    }
}

/// The group of each --turn: the last --occluder before it on the command line (clap keeps
/// each option's values apart; their order comes back from its indices). `None` where the
/// command line does not parse as `relight` (a caller other than the binary), or a --turn
/// comes before every --occluder (then `usize::MAX`, refused by the caller).
fn turn_groups() -> Option<Vec<usize>> {
    let matches = crate::command().try_get_matches().ok()?;
    let (_, relight) = matches.subcommand()?;
    let occluders: Vec<usize> = relight.indices_of("occluder")?.collect();
    let turns: Vec<usize> = relight
        .indices_of("turn")
        .map_or(Vec::new(), Iterator::collect);
    Some(
        turns
            .iter()
            .map(|t| occluders.iter().rposition(|o| o < t).unwrap_or(usize::MAX))
            .collect(),
    )
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
