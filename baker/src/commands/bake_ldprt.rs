//! `prt-bake bake --transfer ldprt [--lobes K]`: a whole per-vertex vector bake, refitted as
//! K zonal-harmonic lobes per vertex ([`prt_baker::bake::ldprt`]) and written as an LDPRT file.

use prt_baker::bake::ldprt::fit_bake;
use prt_baker::support::output::Output;
use prt_baker::{Error, Scene, Transfer};

use super::bake_plan::{BakePlan, What};

/// Refuses what an LDPRT bake does not cover, before the scene is read: it is per vertex,
/// whole, uncompressed, of every vertex, without subsurface media.
pub fn check(plan: &BakePlan) -> Result<(), Error> {
    let Some(lobes) = plan.ldprt else {
        return Ok(());
    };
    let refuse = |what: &str| Err(Error::InvalidOption(format!("--transfer ldprt {what}")));
    let most = prt_baker::bake::ldprt::fit::MAX_LOBES;
    if !(1..=most).contains(&lobes) {
        return refuse(&format!("--lobes {lobes} is outside 1..={most}"));
    }
    if plan.what != What::Whole {
        return refuse("is a whole bake: not with --probes, --shard or --checkpoint");
    }
    if plan.lightmap.resolution.is_some() {
        return refuse("is per vertex: not with --lightmap");
    }
    if plan.fit.is_some() {
        return refuse("is not compressed: not with --clusters or --pcs");
    }
    if !plan.load.receivers.is_empty() {
        return refuse("fits every vertex: not with --receivers");
    }
    if plan.materials.is_some() {
        return refuse("does not take --materials (subsurface transfer)");
    }
    Ok(())
}

/// Fits the lobes to the bake and writes the LDPRT file; prints what was baked and the fit's
/// error (relative L2 against the bake's SH transfer).
pub fn write(
    plan: &BakePlan,
    scene: &Scene,
    output: &Output,
    transfer: &Transfer,
    lobes: usize,
) -> Result<(), Error> {
    let started = std::time::Instant::now();
    let mut file = fit_bake(scene, transfer, lobes)?;
    // A skinned glTF's lobes follow its skin from the pose they were baked in.
    file.pose = scene
        .pose_linear
        .as_ref()
        .map(|_| plan.load.pose.to_string());
    output.write(&file.to_bytes())?;
    let options = &plan.options;
    println!(
        "baked {} vertices ({}, order {}, {} samples) in {:.2} s; fitted {lobes} lobe(s) per \
         vertex in {:.2} s, relative error mean {:.4} p99 {:.4} max {:.4} -> {}",
        transfer.receiver_count,
        options.mode.name(),
        options.order,
        options.samples,
        transfer.seconds,
        started.elapsed().as_secs_f64(),
        file.error.mean,
        file.error.p99,
        file.error.max,
        plan.output.display()
    );
    Ok(())
}
