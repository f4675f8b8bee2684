//! The values `prt-bake bake`'s options take (clap's value enums, their help) and the
//! library's types each stands for; `commands::bake` lowers its arguments through them.

use clap::ValueEnum;
use prt_baker::Mode;
use prt_baker::bake::lightmap::atlas::AtlasMethod;
use prt_baker::bake::options::{Aux, TransferKind};
use prt_baker::math::sampling::Sampling;
use prt_baker::trace::Backend;

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DenoiseArg {
    Auto,
    On,
    Off,
}

impl DenoiseArg {
    /// On, off, or for `auto` what `usual` says (`commands::bake` knows which bakes).
    pub fn or_auto(self, usual: bool) -> bool {
        match self {
            DenoiseArg::On => true,
            DenoiseArg::Off => false,
            DenoiseArg::Auto => usual,
        }
    }
}

/// `--samples`' default: 64 rays where the bake is denoised, which makes them about as clean
/// as 512 to 1,024 raw ones (docs/explanation/denoising.md); 1,024 for a raw bake, and as an
/// adaptive bake's cap.
pub fn default_samples(denoised: bool, adaptive: bool) -> u32 {
    if denoised && !adaptive { 64 } else { 1024 }
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TransferArg {
    Vector,
    Matrix,
    /// Zonal-harmonic lobes in each vertex's frame, fitted to the vector bake: transfer that
    /// follows the mesh when it is posed or skinned (docs/guides/characters.md).
    Ldprt,
}

impl TransferArg {
    /// The library's kind: an LDPRT bake bakes vectors, then fits its lobes to them.
    pub fn kind(self) -> TransferKind {
        match self {
            TransferArg::Vector | TransferArg::Ldprt => TransferKind::Vector,
            TransferArg::Matrix => TransferKind::Matrix,
        }
    }
}

/// `bake --transfer` and `--lobes`, flattened into `BakeArgs`.
#[derive(clap::Args)]
pub struct TransferArgs {
    /// What is stored per vertex: the diffuse transfer vector (n² floats per channel), the
    /// transfer matrix (n²×n², for glossy BRDFs; any mode, per vertex), or LDPRT lobes (an
    /// LDPRT file; whole per-vertex bakes).
    #[arg(long, value_enum, default_value_t = TransferArg::Vector)]
    pub transfer: TransferArg,
    /// With --transfer ldprt: zonal-harmonic lobes per vertex, 1 (about the normal, closed
    /// form) to 8 (axes optimised per vertex).
    #[arg(long, value_name = "K")]
    pub lobes: Option<usize>,
    /// A glTF file's pose: `rest` (the nodes' own transforms), `ANIM@SECONDS` or
    /// `ANIM#KEYFRAME` (ANIM an animation's name or index), skins applied on the CPU
    /// (docs/guides/characters.md).
    #[arg(long, default_value = "rest")]
    pub pose: prt_baker::scene::Pose,
}

impl TransferArgs {
    /// `Some(K)` for an LDPRT bake (1 lobe by default); `--lobes` without it is refused.
    pub fn ldprt_lobes(&self) -> Result<Option<usize>, prt_baker::Error> {
        match (self.transfer, self.lobes) {
            (TransferArg::Ldprt, lobes) => Ok(Some(lobes.unwrap_or(1))),
            (_, None) => Ok(None),
            (_, Some(_)) => Err(prt_baker::Error::InvalidOption(
                "--lobes is for --transfer ldprt".into(),
            )),
        }
    }
}

#[derive(Clone, Copy, ValueEnum)]
pub enum ModeArg {
    /// Cosine-weighted reflectance only (no rays).
    Unshadowed,
    /// With occlusion rays.
    Shadowed,
    /// Shadowed plus light bounced off other surfaces, in colour.
    Interreflected,
}

impl ModeArg {
    pub fn mode(self) -> Mode {
        match self {
            ModeArg::Unshadowed => Mode::Unshadowed,
            ModeArg::Shadowed => Mode::Shadowed,
            ModeArg::Interreflected => Mode::Interreflected,
        }
    }
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
pub enum AuxArg {
    /// Ambient accessibility: cosine-weighted fraction of the sky seen.
    Ao,
    /// Cosine-weighted mean unoccluded direction.
    BentNormal,
}

impl AuxArg {
    /// `--aux a,b`: the arrays stored beside the coefficients.
    pub fn aux(list: &[AuxArg]) -> Aux {
        Aux {
            ao: list.contains(&AuxArg::Ao),
            bent_normal: list.contains(&AuxArg::BentNormal),
        }
    }
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BackendArg {
    /// Intel Embree (needs a build with the `embree` feature, the default).
    Embree,
    /// obvhs, a pure-Rust BVH.
    Obvhs,
}

impl BackendArg {
    pub const DEFAULT: BackendArg = match Backend::DEFAULT {
        Backend::Obvhs => BackendArg::Obvhs,
        _ => BackendArg::Embree,
    };

    pub fn backend(self) -> Backend {
        match self {
            BackendArg::Embree => Backend::Embree,
            BackendArg::Obvhs => Backend::Obvhs,
        }
    }
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SamplingArg {
    /// Owen-scrambled Sobol points, cosine-weighted (lower error).
    OwenSobol,
    /// The thesis's independent uniform directions (the baseline).
    ThesisRandom,
}

impl SamplingArg {
    pub fn sampling(self) -> Sampling {
        match self {
            SamplingArg::OwenSobol => Sampling::OwenSobol,
            SamplingArg::ThesisRandom => Sampling::ThesisRandom,
        }
    }
}

/// `bake --atlas`: which unwrapper makes a generated lightmap atlas.
#[derive(Clone, Copy, ValueEnum)]
pub enum AtlasArg {
    Unwrap,
    Planar,
}

impl AtlasArg {
    pub fn method(self) -> AtlasMethod {
        match self {
            AtlasArg::Unwrap => AtlasMethod::Unwrap,
            AtlasArg::Planar => AtlasMethod::Planar,
        }
    }
}
