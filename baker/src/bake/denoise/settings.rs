//! The filter's sizes and strengths for each kind of receiver, and how a texel bake's rays
//! choose its clusters.

/// The rays a texel from which texels are filtered in clusters of up to 2 × 2, not 3 × 3
/// ([`Settings::texels`]). A cluster's members share its kernel, its range term and its
/// choice of width, and the wide pass reads their mean: finer clusters leave less noise,
/// which counts more as the rays lower the rest. Relit error against 65,536 rays (sun and
/// sky / low sun / sky), the Cornell room at 256², 256 rays, 2 seeds (8 under the sky): 3 ×
/// 3, 0.50 / 0.39 / 0.344 %; 2 × 2, 0.48 / 0.38 / 0.331 %; every texel its own kernel, 0.45 /
/// 0.35 / 0.302 %, for 10 × the filter's time; a raw bake of 2,048 rays, 0.57 / 0.45 / 0.336
/// %. At 1,024 rays, seed 1: 0.308 / 0.238 / 0.200, 0.295 / 0.233 / 0.194, 0.290 / 0.226 /
/// 0.190 %. Under 256 rays the finer clusters are not worth their time: at 64 rays they cost
/// the courtyard 2.2 × the filter's time for 6 % of its error. At 256 rays the room's filter
/// takes 0.07–0.08 CPU-s of a 0.61 s raw bake (3 × 3: 0.04–0.05).
pub const FINE_CLUSTERS_FROM: u32 = 256;

/// The SH order from which texels are filtered with a stricter range term
/// ([`Settings::at_order`]).
pub const SHARP_FROM_ORDER: usize = 12;

/// The filter's sizes and strengths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Neighbours within this many spacings.
    pub radius: f32,
    /// The guide's prefilter radius, in spacings.
    pub guide_radius: f32,
    /// κ: how many noise deviations of difference the range term tolerates.
    pub kappa: f32,
    /// A first-order fit over the tangent plane instead of a weighted mean.
    pub linear: bool,
    /// The wide pass reads clusters about this many spacings across ([`super::clusters`]), or
    /// every receiver (`None`).
    pub step: Option<f32>,
    /// A second-order fit, with vertices' terms ([`super::vertices`]), in place of the first-order
    /// one.
    pub quadratic: bool,
    /// Each texel's answer blended from its own cluster's fit and its like neighbours'
    /// ([`super::blend`]; texels only): continuous across the clusters' seams. On the
    /// production courtyard at 64 rays, 4 seeds, sun and sky / low sun / sky: 0.903 / 1.483
    /// / 0.522 % on one lattice of clusters, 0.867 / 1.435 / 0.500 % blended, for 1.2 × the
    /// filter's time; the mean of two filters on lattices half a cluster apart, which it
    /// replaced, 0.864 / 1.422 / 0.502 % for 1.5 ×.
    pub blend: bool,
    /// Over a normal map, a fit in the normal's squares and product too
    /// ([`super::normal_fit`]): unbiased for band 2, noisier by three regressors.
    pub normal_quadratic: bool,
    /// Texels: near another surface, a fit in the distance to it too ([`super::contact`]).
    pub contact: bool,
    /// Texels: where the transfer curves over the kernel, a fit in the squares of the
    /// plane's coordinates too ([`super::texel_kernel`]).
    pub curved: bool,
}

impl Settings {
    /// Lightmap texels: 7 texels each way, over clusters of up to 3 × 3 texels (measured on
    /// the Cornell room at 64 rays: docs/explanation/denoising-record.md). Against 6 texels over
    /// clusters of 2 × 2, the wide pass reads half the clusters and the error is lower
    /// (1.31 against 1.36 % under a sun and sky); 6 texels over 3 × 3 cost as little but
    /// add 4 % to the error.
    pub const TEXELS: Settings = Settings {
        radius: 7.0,
        guide_radius: 1.5,
        kappa: 4.0,
        linear: true,
        step: Some(3.0),
        quadratic: false,
        blend: true,
        normal_quadratic: false,
        contact: true,
        curved: true,
    };
    /// [`Settings::TEXELS`] for a bake of `samples` rays a texel at SH order `order`: from
    /// [`FINE_CLUSTERS_FROM`] rays, clusters of up to 2 × 2 texels, and over a normal map a
    /// fit quadratic in the normal (at 64 rays its noise outweighs the bias it removes); and
    /// [`Settings::at_order`]'s range term.
    pub fn texels(samples: u32, order: usize) -> Settings {
        let settings = match samples >= FINE_CLUSTERS_FROM {
            true => Settings {
                step: Some(2.0),
                normal_quadratic: true,
                ..Settings::TEXELS
            },
            false => Settings::TEXELS,
        };
        settings.at_order(order)
    }
    /// Texels from [`SHARP_FROM_ORDER`]: the range term at κ = 3, not 4. The higher bands
    /// hold a sun's shadow edge more sharply, and at κ = 4 the filter widened the edge of a
    /// wall's shadow at order 12 by 1.10–1.31 × (seeds 1–6; the bar is 1.25 ×), at κ = 3 by
    /// 0.99–1.24 ×. Below order 12, κ = 4 keeps it within 1.22 ×, and its lower error is
    /// kept: on the courtyard at 256², order 12, 64 rays, sun and sky / low sun / sky, κ = 4
    /// gives 7.56 / 11.01 / 0.88 % and κ = 3 gives 7.71 / 11.76 / 0.84 %.
    pub fn at_order(self, order: usize) -> Settings {
        match order >= SHARP_FROM_ORDER {
            true => Settings { kappa: 3.0, ..self },
            false => self,
        }
    }
    /// Vertices, transfer matrices and subsurface vertices: in clusters of like vertices
    /// within 1.25 of a seed's spacings ([`super::vertex_clusters`]), with a second-order fit and
    /// the robust range term at κ = 3 ([`super::vertices`]; measured on the torus at 64 rays, 4
    /// seeds, before the quarter-width fit: κ = 4, 1.16 / 3.02 / 0.78 %; 3, 1.12 / 2.91 /
    /// 0.72 %; κ = 2 for the robust term alone, 1.16 / 2.93 / 0.76 %).
    pub const VERTICES: Settings = Settings {
        radius: 9.0,
        guide_radius: 1.5,
        kappa: 3.0,
        linear: true,
        step: Some(super::vertices::STEP),
        quadratic: true,
        blend: false,
        normal_quadratic: false,
        contact: false,
        curved: false,
    };
}
