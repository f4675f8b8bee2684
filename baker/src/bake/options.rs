//! What a bake is asked for: the transfer's mode, SH order, samples, seed, bounces and the
//! arrays kept beside it. Every other bake module reads these; none of them is read here.

use crate::math::sampling::Sampling;
use crate::math::sh;
use crate::support::error::{Error, Result};

pub use crate::formats::header::{Aux, Mode, TransferKind};

#[derive(Clone, Debug, PartialEq)]
pub struct BakeOptions {
    /// SH order n (n² coefficients).
    pub order: usize,
    /// Directions (rays, in shadowed mode) per vertex.
    pub samples: u32,
    pub mode: Mode,
    pub seed: u64,
    pub sampling: Sampling,
    /// Interreflection bounces (interreflected mode only; at least 1 there).
    pub bounces: u32,
    /// Rays per vertex whose first hits feed the bounces (interreflected mode): the first
    /// this many of the `samples` directions; `None` is a quarter of them. Bounced light is
    /// dimmer and smoother than direct light, so fewer of the costlier closest-hit rays give
    /// it a comparable error.
    pub bounce_samples: Option<u32>,
    /// Which per-vertex arrays to keep beside the coefficients.
    pub aux: Aux,
    /// Bytes the interreflected mode may spend caching first hits; beyond it the bounce
    /// passes re-trace instead. Changes speed and memory, never the result.
    pub hit_cache_limit: u64,
    /// `--target-error E`: cast rays in rounds until each vertex's estimated RMS coefficient
    /// error is at most E (`samples` becomes the cap); `None` casts `samples` rays everywhere.
    /// See [`crate::bake::adaptive`]; with `denoise`, the error after denoising
    /// ([`crate::bake::adaptive_denoised`]).
    pub target_error: Option<f32>,
    /// `--transfer`: a transfer vector per receiver (diffuse), or a transfer matrix
    /// ([`crate::bake::matrix`]: glossy and other view-dependent BRDFs).
    pub transfer: TransferKind,
    /// `--denoise`: filter the baked transfer with weights every coefficient shares
    /// ([`crate::bake::denoise`]), before a texel bake is dilated and stitched.
    pub denoise: bool,
}

/// The default hit-cache budget: 1 GiB.
pub const DEFAULT_HIT_CACHE_LIMIT: u64 = 1 << 30;

impl Default for BakeOptions {
    fn default() -> BakeOptions {
        BakeOptions {
            order: 4,
            samples: 1024,
            mode: Mode::Shadowed,
            seed: 0,
            sampling: Sampling::OwenSobol,
            bounces: 0,
            bounce_samples: None,
            aux: Aux::default(),
            hit_cache_limit: DEFAULT_HIT_CACHE_LIMIT,
            target_error: None,
            transfer: TransferKind::Vector,
            denoise: false,
        }
    }
}

impl BakeOptions {
    /// Bounce rays per vertex: `bounce_samples`, or a quarter of `samples` (at least 1);
    /// 0 outside interreflected mode.
    pub fn effective_bounce_samples(&self) -> u32 {
        match self.mode {
            Mode::Interreflected => self.bounce_samples.unwrap_or(self.samples.div_ceil(4)),
            _ => 0,
        }
    }

    pub fn validate(&self) -> Result<()> {
        if !(1..=sh::MAX_ORDER).contains(&self.order) {
            return Err(Error::InvalidOption(format!(
                "--order {} is outside 1..={}",
                self.order,
                sh::MAX_ORDER
            )));
        }
        if self.samples == 0 {
            return Err(Error::InvalidOption("--samples must be at least 1".into()));
        }
        match (self.mode, self.bounces) {
            (Mode::Interreflected, 0) => {
                return Err(Error::InvalidOption(
                    "--bounces must be at least 1 in interreflected mode".into(),
                ));
            }
            (Mode::Unshadowed | Mode::Shadowed, b) if b > 0 => {
                return Err(Error::InvalidOption(format!(
                    "--bounces {b} needs --mode interreflected (mode is {})",
                    self.mode.name()
                )));
            }
            _ => {}
        }
        if let Some(m) = self.bounce_samples {
            if self.mode != Mode::Interreflected {
                return Err(Error::InvalidOption(
                    "--bounce-samples needs --mode interreflected".into(),
                ));
            }
            if m == 0 || m > self.samples {
                return Err(Error::InvalidOption(format!(
                    "--bounce-samples {m} must be in 1..={} (--samples)",
                    self.samples
                )));
            }
        }
        if self.aux.any() && !self.mode.casts_rays() {
            return Err(Error::InvalidOption(
                "--aux needs rays: use --mode shadowed or interreflected".into(),
            ));
        }
        if self.denoise && !self.mode.casts_rays() {
            return Err(Error::InvalidOption(
                "--denoise on needs rays: an unshadowed bake has no noise".into(),
            ));
        }
        check_adaptive(self)?;
        check_matrix(self)
    }

    /// A note where `samples` is neither a power of two nor a multiple of [`BALANCED_RUN`]:
    /// the first N Sobol points are a scrambled net only in whole runs of a power of two, and
    /// the rays past the last whole run add more noise than they take away. Measured on the
    /// production courtyard at 512², relit under a sun and sky against 16,384 rays: 64 rays
    /// 5.36 %, 72 5.75 %, 75 6.07 %, 80 5.06 %, 96 4.18 %, 100 4.67 % (denoised: 1.06, 1.08,
    /// 1.10, 1.03, 0.90, 0.96 %). An adaptive bake chooses its own counts. (A probe casts
    /// half its rays from each hemisphere: `commands` does not ask this of probes.)
    pub fn samples_note(&self) -> Option<String> {
        let n = self.samples;
        let balanced = n.is_power_of_two() || n % BALANCED_RUN == 0;
        if balanced || self.sampling != Sampling::OwenSobol || self.target_error.is_some() {
            return None;
        }
        // The whole runs on either side: of 16 from 16 rays, of a power of two below.
        let (below, above) = match n > BALANCED_RUN {
            true => (
                n / BALANCED_RUN * BALANCED_RUN,
                n.next_multiple_of(BALANCED_RUN),
            ),
            false => (1 << n.ilog2(), n.next_power_of_two()),
        };
        Some(format!(
            "note: --samples {n} is neither a power of two nor a multiple of {BALANCED_RUN}: the \
             Sobol points are balanced in whole runs of a power of two, and the rays past \
             {below} ({}) add more noise than they take away; {below} or {above} rays do better",
            n - below
        ))
    }
}

/// Refuses what matrix bakes ([`crate::bake::matrix`]) do not support yet, with the reason.
fn check_matrix(options: &BakeOptions) -> Result<()> {
    if options.transfer != TransferKind::Matrix {
        return Ok(());
    }
    let refuse = |what: &str| Err(Error::InvalidOption(format!("--transfer matrix {what}")));
    if options.target_error.is_some() {
        return refuse("with --target-error is not supported: matrix bakes use fixed --samples");
    }
    if options.sampling != Sampling::OwenSobol {
        return refuse(&format!(
            "needs --sampling owen-sobol (sampling is {}): its uniform hemisphere points are \
             the stratified set",
            options.sampling.name()
        ));
    }
    Ok(())
}

/// Adaptive bakes ([`crate::bake::adaptive`]): blocks of the pilot, whose spread gives the
/// error estimate.
pub const PILOT_BLOCKS: usize = 4;
/// Adaptive bakes: points per pilot block.
pub const BLOCK_POINTS: u32 = 64;
/// Adaptive bakes: the variance of an Owen-scrambled net of N points is taken to fall as
/// N^-RATE, Owen's rate for integrands with discontinuities in two dimensions (shadow edges;
/// smooth integrands converge faster, so the prediction errs on the safe side there).
pub const RATE: f64 = 1.5;

/// A run of Owen-scrambled Sobol points at least this long is balanced on its own: a bake of
/// a multiple of it casts whole runs.
const BALANCED_RUN: u32 = 16;

/// Refuses what adaptive sampling ([`crate::bake::adaptive`]) does not support, with the reason.
fn check_adaptive(options: &BakeOptions) -> Result<()> {
    let Some(target) = options.target_error else {
        return Ok(());
    };
    if !(target.is_finite() && target > 0.0) {
        return Err(Error::InvalidOption(format!(
            "--target-error {target} must be a positive number"
        )));
    }
    if options.mode != Mode::Shadowed {
        return Err(Error::InvalidOption(format!(
            "--target-error needs --mode shadowed (mode is {}): unshadowed bakes cast no rays, \
             and interreflected bakes would build their bounces from a different number of \
             rays per vertex, which is not supported",
            options.mode.name()
        )));
    }
    if options.sampling != Sampling::OwenSobol {
        return Err(Error::InvalidOption(format!(
            "--target-error needs --sampling owen-sobol (sampling is {}): its error estimate \
             comes from blocks of an Owen-scrambled Sobol sequence",
            options.sampling.name()
        )));
    }
    let least = PILOT_BLOCKS as u32 * BLOCK_POINTS;
    if options.samples < least {
        return Err(Error::InvalidOption(format!(
            "--target-error needs --samples of at least {least} ({PILOT_BLOCKS} blocks × \
             {BLOCK_POINTS} points, the pilot); it is {}",
            options.samples
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_past_a_balanced_run_are_noted() {
        let note = |samples: u32, target_error: Option<f32>| {
            BakeOptions {
                samples,
                target_error,
                ..BakeOptions::default()
            }
            .samples_note()
        };
        for quiet in [1, 8, 64, 48, 80, 96, 1024, 1040] {
            assert_eq!(note(quiet, None), None, "{quiet}");
        }
        let said = note(75, None).expect("75 is noted");
        assert!(
            said.contains("rays past 64 (11)") && said.contains("64 or 80"),
            "{said}"
        );
        let said = note(100, None).expect("100 is noted");
        assert!(
            said.contains("rays past 96 (4)") && said.contains("96 or 112"),
            "{said}"
        );
        let said = note(12, None).expect("12 is noted");
        assert!(
            said.contains("rays past 8 (4)") && said.contains("8 or 16"),
            "{said}"
        );
        assert_eq!(note(75, Some(1e-3)), None);
        let thesis = BakeOptions {
            samples: 75,
            sampling: Sampling::ThesisRandom,
            ..BakeOptions::default()
        };
        assert_eq!(thesis.samples_note(), None);
    }

    #[test]
    fn unsupported_combinations_are_refused() {
        let adaptive = BakeOptions {
            target_error: Some(1e-3),
            samples: 4096,
            ..BakeOptions::default()
        };
        assert!(adaptive.validate().is_ok());
        for (options, message) in [
            (
                BakeOptions {
                    mode: Mode::Interreflected,
                    bounces: 1,
                    ..adaptive.clone()
                },
                "needs --mode shadowed",
            ),
            (
                BakeOptions {
                    mode: Mode::Unshadowed,
                    ..adaptive.clone()
                },
                "needs --mode shadowed",
            ),
            (
                BakeOptions {
                    sampling: Sampling::ThesisRandom,
                    ..adaptive.clone()
                },
                "needs --sampling owen-sobol",
            ),
            (
                BakeOptions {
                    samples: 255,
                    ..adaptive.clone()
                },
                "at least 256",
            ),
            (
                BakeOptions {
                    target_error: Some(0.0),
                    ..adaptive.clone()
                },
                "positive",
            ),
            (
                BakeOptions {
                    target_error: Some(f32::NAN),
                    ..adaptive.clone()
                },
                "positive",
            ),
        ] {
            match options.validate() {
                Err(Error::InvalidOption(m)) => assert!(m.contains(message), "{m}"),
                other => panic!("{options:?}: {other:?}"),
            }
        }
    }
}
