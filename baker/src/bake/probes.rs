//! Transfer probes (`bake --probes`): at a point x in space, off any surface, the n² × n²
//! matrix that maps a distant light's SH coefficients L to those of the radiance arriving at x
//! from every direction, L_in = M·L:
//!
//! ```text
//! M_ij(x) = ∫_{S²} V(x, s) y_i(s) y_j(s) ds  (+ the light bounced off the surface hit along s)
//! ```
//!
//! the transfer matrix of [`crate::bake::matrix`] over the whole sphere instead of a
//! hemisphere (Sloan, Kautz & Snyder 2002, §7 lit moving objects from such samples). A probe
//! is baked as two receivers at the same point facing +z and −z, whose hemisphere matrices add
//! up to the sphere's: the same estimator, directions, batches, bounces and determinism as a
//! matrix bake of vertices, with `--samples` rays per probe (half per hemisphere). Unblocked,
//! M = I (the orthonormality of the basis); where a cone of directions is blocked, M = I − the
//! cone's matrix (`tests/probe_oracles.rs`).
//!
//! In interreflected mode the light a blocked ray brings is the diffuse interreflected
//! transfer of the surface it hits, read at its corners exactly as a vertex matrix bake reads
//! it ([`crate::bake::matrix_bounce`]); a back face (the probe is inside or behind geometry)
//! brings nothing.

use std::ops::Range;
use std::path::PathBuf;

use glam::Vec3;

use crate::bake::estimator::Estimator;
use crate::bake::interreflection::albedo_is_grey;
use crate::bake::matrix_bounce::PreparedLight;
use crate::bake::matrix_hits::BounceLight;
use crate::bake::options::{BakeOptions, Mode, TransferKind};
use crate::bake::receivers::Receivers;
use crate::bake::transfer::{Baked, Transfer, tracer_for};
use crate::formats::coefficient_file::CoefficientFile;
use crate::formats::probe_block::{ProbeBlock, ProbeGrid};
use crate::scene::Scene;
use crate::support::error::{Error, Result};
use crate::support::progress::Progress;
use crate::trace::{Backend, Tracer};

/// Where the probes go (`--probes`).
#[derive(Clone, Debug, PartialEq)]
pub enum ProbeSpec {
    /// A file of `x y z` lines ([`crate::formats::probe_points`]).
    Points(PathBuf),
    /// NX × NY × NZ probes at the centres of the cells of a box: the scene's bounds, or `bounds`.
    Grid {
        counts: [u32; 3],
        bounds: Option<(Vec3, Vec3)>,
    },
}

/// The most probes a grid may have (each holds channels × n⁴ floats).
const MAX_GRID_PROBES: u64 = 1 << 24;

impl ProbeSpec {
    /// `grid:NX,NY,NZ`, `grid:NX,NY,NZ:X0,Y0,Z0,X1,Y1,Z1` (a box of its own), or a path.
    pub fn parse(arg: &str) -> Result<ProbeSpec> {
        let Some(grid) = arg.strip_prefix("grid:") else {
            return Ok(ProbeSpec::Points(PathBuf::from(arg)));
        };
        let usage = |why: &str| {
            Error::InvalidOption(format!(
                "--probes {arg}: {why} (grid:NX,NY,NZ or grid:NX,NY,NZ:X0,Y0,Z0,X1,Y1,Z1)"
            ))
        };
        let (counts, bounds) = match grid.split_once(':') {
            Some((c, b)) => (c, Some(b)),
            None => (grid, None),
        };
        let counts: Vec<u32> = counts
            .split(',')
            .map(|c| c.trim().parse::<u32>().ok().filter(|&c| c > 0))
            .collect::<Option<_>>()
            .filter(|c: &Vec<u32>| c.len() == 3)
            .ok_or_else(|| usage("three counts of at least 1"))?;
        if counts.iter().map(|&c| u64::from(c)).product::<u64>() > MAX_GRID_PROBES {
            return Err(usage(&format!("more than {MAX_GRID_PROBES} probes")));
        }
        let bounds = match bounds {
            None => None,
            Some(b) => {
                let v: Vec<f32> = b
                    .split(',')
                    .map(|x| x.trim().parse::<f32>().ok().filter(|x| x.is_finite()))
                    .collect::<Option<_>>()
                    .filter(|v: &Vec<f32>| v.len() == 6)
                    .ok_or_else(|| usage("a box of six finite numbers"))?;
                let (lo, hi) = (Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]));
                if lo.cmpgt(hi).any() {
                    return Err(usage("the box's first corner must be its lowest"));
                }
                Some((lo, hi))
            }
        };
        Ok(ProbeSpec::Grid {
            counts: [counts[0], counts[1], counts[2]],
            bounds,
        })
    }

    /// The probes, in the order they are baked and stored: a grid's at the centres of its
    /// cells ([`ProbeGrid`]: centres rather than corners, so a grid over a room's bounds
    /// keeps off its walls).
    pub fn probes(&self, scene: &Scene) -> Result<ProbeBlock> {
        Ok(match self {
            ProbeSpec::Points(path) => ProbeBlock {
                positions: crate::formats::probe_points::read(path)?,
                grid: None,
                backfaces: Vec::new(),
            },
            ProbeSpec::Grid { counts, bounds } => {
                let (lo, hi) = bounds.unwrap_or_else(|| scene.bounds());
                let grid = ProbeGrid {
                    counts: *counts,
                    lo,
                    hi,
                };
                ProbeBlock {
                    positions: grid.positions(),
                    grid: Some(grid),
                    backfaces: Vec::new(),
                }
            }
        })
    }
}

/// Checks the options for a probe bake: matrices, an even number of rays (half per
/// hemisphere), no per-receiver extras.
fn check(options: &BakeOptions) -> Result<()> {
    let refuse = |why: &str| Err(Error::InvalidOption(format!("--probes {why}")));
    if options.samples < 2 || options.samples % 2 != 0 {
        return refuse(&format!(
            "needs an even --samples (half the rays per hemisphere), not {}",
            options.samples
        ));
    }
    if options.aux.any() {
        return refuse("stores no --aux arrays (a probe has no surface)");
    }
    if options.target_error.is_some() {
        return refuse("with --target-error is not supported: probes use fixed --samples");
    }
    Ok(())
}

/// The options of each hemisphere's receiver: a matrix bake with half the rays (and half the
/// bounce rays).
pub fn hemisphere_options(options: &BakeOptions) -> BakeOptions {
    BakeOptions {
        transfer: TransferKind::Matrix,
        samples: options.samples / 2,
        bounce_samples: options.bounce_samples.map(|b| b.div_ceil(2)),
        ..options.clone()
    }
}

/// Two receivers per probe at its position, facing +z and −z, each with its own random
/// stream (2p and 2p + 1).
fn probe_receivers(positions: &[Vec3]) -> Receivers {
    Receivers {
        origins: positions.iter().flat_map(|&p| [p, p]).collect(),
        normals: positions
            .iter()
            .flat_map(|_| [Vec3::Z, Vec3::NEG_Z])
            .collect(),
        horizons: None,
        streams: Some((0..2 * positions.len() as u64).collect()),
        strata: None,
    }
}

/// A probe bake ready to bake any range of its probes (the whole bake, a shard, a
/// checkpoint block). A probe's matrix depends only on its index, its position, the scene
/// and the options, so ranges baked apart join into the whole bake's bytes. In interreflected
/// mode the light the bounce rays read is baked on the first call, once per run, and not at
/// all by a run that bakes nothing (a checkpoint whose blocks are all done).
pub struct ProbeBaker<'a> {
    scene: &'a Scene,
    estimator: Estimator,
    tracer: Option<&'a dyn Tracer>,
    /// Interreflected mode: the vertices' estimator the bounce hits read corners with.
    corners: Option<&'a Estimator>,
    light: std::cell::OnceCell<PreparedLight<'a>>,
    channels: usize,
    /// Matrix options, as recorded in the file.
    pub options: BakeOptions,
}

impl ProbeBaker<'_> {
    /// Transfer channels: three in interreflected mode unless every albedo is grey.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Rays cast by the vertex pass the bounces read (0 until it ran, or where none runs).
    pub fn prepared_rays(&self) -> u64 {
        self.light.get().map_or(0, |l| l.rays)
    }

    pub fn tracer(&self) -> Option<&dyn Tracer> {
        self.tracer
    }

    pub fn backend(&self) -> Backend {
        self.tracer.map_or(Backend::None, |t| t.backend())
    }

    /// The light bounce rays read, baked on first use.
    fn light(&self, progress: &dyn Progress) -> Result<Option<&BounceLight<'_>>> {
        let (Some(tracer), Some(corners)) = (self.tracer, self.corners) else {
            return Ok(None);
        };
        if self.light.get().is_none() {
            let prepared = crate::bake::matrix_bounce::prepare_light(
                self.scene,
                tracer,
                (corners, &self.options),
                &self.estimator.options,
                progress,
            )?;
            let _ = self.light.set(prepared);
        }
        Ok(self.light.get().map(|l| &l.light))
    }

    /// The matrices of probes `range`, `coefficients[((p · channels + c) · n² + i) · n² + j]`
    /// from the range's start, and the rays their own passes cast.
    pub fn bake(&self, range: Range<usize>, progress: &dyn Progress) -> Result<(Vec<f32>, u64)> {
        if range.is_empty() {
            // A shard of no probes (more shards than probes) needs no vertex pass either.
            return Ok((Vec::new(), 0));
        }
        let light = self.light(progress)?;
        let hemispheres = 2 * range.start..2 * range.end;
        let pass = crate::bake::matrix::matrix_pass(
            &self.estimator,
            self.tracer,
            light,
            hemispheres,
            progress,
        );
        let samples = u64::from(self.estimator.options.samples);
        let rays = self.tracer.map_or(0, |_| samples * 2 * range.len() as u64);
        let width = self.channels * self.options.transfer.floats_per_channel(self.options.order);
        let coefficients = pass
            .coefficients
            .chunks_exact(2 * width)
            .flat_map(|pair| {
                let (up, down) = pair.split_at(width);
                up.iter().zip(down).map(|(u, d)| u + d)
            })
            .collect();
        Ok((coefficients, rays))
    }
}

/// Runs `then` with a [`ProbeBaker`] for the probes at `positions` in `scene`. `tracer` may
/// be `None` only in unshadowed mode (M = I up to quadrature).
pub fn with_baker<T>(
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    positions: &[Vec3],
    then: impl FnOnce(&ProbeBaker) -> Result<T>,
) -> Result<T> {
    let options = BakeOptions {
        transfer: TransferKind::Matrix,
        ..options.clone()
    };
    options.validate()?;
    check(&options)?;
    let tracer = tracer_for(&options, tracer)?;
    let half = hemisphere_options(&options);
    let estimator = Estimator::for_receivers(probe_receivers(positions), &half)?;
    let corners = match tracer {
        Some(_) if options.mode == Mode::Interreflected => Some(Estimator::new(scene, &options)?),
        _ => None,
    };
    let channels = match (&corners, albedo_is_grey(scene)) {
        (Some(_), false) => 3,
        _ => 1,
    };
    then(&ProbeBaker {
        scene,
        estimator,
        tracer,
        corners: corners.as_ref(),
        light: std::cell::OnceCell::new(),
        channels,
        options,
    })
}

/// Bakes the probes at `positions` in `scene`: a [`Transfer`] whose receivers are the probes,
/// `coefficients[((p · channels + c) · n² + i) · n² + j]`, and `options` with
/// `transfer = Matrix` (as recorded in the file). `tracer` may be `None` only in unshadowed
/// mode (M = I up to quadrature).
pub fn bake(
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    positions: &[Vec3],
    progress: &dyn Progress,
) -> Result<Transfer> {
    let started = std::time::Instant::now();
    with_baker(scene, tracer, options, positions, |baker| {
        let (coefficients, rays) = baker.bake(0..positions.len(), progress)?;
        let baked = Baked {
            coefficients,
            channels: baker.channels(),
            visibility: Vec::new(),
            rays_cast: baker.prepared_rays() + rays,
            hit_cache_bytes: None,
        };
        Ok(Transfer::from_direct(
            &baker.options,
            baker.backend(),
            positions.len(),
            baked,
            started.elapsed().as_secs_f64(),
        ))
    })
}

impl CoefficientFile {
    /// Packages a probe bake of `scene` ([`bake`]) with its probes, classifying them
    /// ([`crate::bake::probe_validity`]) with `tracer`.
    pub fn from_probe_bake(
        scene: &Scene,
        transfer: &Transfer,
        tracer: Option<&dyn Tracer>,
        mut probes: ProbeBlock,
    ) -> CoefficientFile {
        let seed = transfer.options.seed;
        probes.backfaces =
            crate::bake::probe_validity::backface_fractions(tracer, seed, &probes.positions, 0);
        let mut file = CoefficientFile::from_bake(scene, transfer);
        file.probes = Some(probes);
        file
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_parse_and_sit_at_cell_centres() {
        assert_eq!(
            ProbeSpec::parse("grid:2,1,3").unwrap(),
            ProbeSpec::Grid {
                counts: [2, 1, 3],
                bounds: None
            }
        );
        assert_eq!(
            ProbeSpec::parse("grid:2,1,1:0,0,0,4,2,2").unwrap(),
            ProbeSpec::Grid {
                counts: [2, 1, 1],
                bounds: Some((Vec3::ZERO, Vec3::new(4.0, 2.0, 2.0)))
            }
        );
        for bad in [
            "grid:2,2",
            "grid:0,1,1",
            "grid:1,1,1:0,0,0,1,1",
            "grid:1,1,1:1,0,0,0,1,1",
        ] {
            assert!(ProbeSpec::parse(bad).is_err(), "{bad}");
        }
        assert_eq!(
            ProbeSpec::parse("points.txt").unwrap(),
            ProbeSpec::Points("points.txt".into())
        );
    }
}
