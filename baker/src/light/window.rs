//! Ringing control: per-band windows applied to light coefficients.
//!
//! Cutting a light's expansion off after band n−1 is a box filter in frequency, and a sharp
//! light (a sun, a bright window in an environment map) rings: the reconstruction overshoots
//! around it and goes negative on the far side, which shows as dark bands or negative
//! radiance. Tapering the bands towards the cut-off trades that ringing for blur: the light
//! gets wider and softer, shadows and highlights lose contrast, and a directional light stops
//! being one. w_0 = 1 always, so the mean radiance, and with it the irradiance of an
//! unoccluded surface averaged over all orientations, is unchanged.
//!
//! Because the transfer product Σ T_j c_j is diagonal in the bands, windowing the light is
//! the same as windowing every vertex's transfer, and costs n² multiplications once.
//!
//! Windows (l the band, W the width, by default the order n, the first band not stored),
//! after Sloan, "Stupid Spherical Harmonics (SH) Tricks" (GDC 2008):
//!
//! * Hanning: w_l = (1 + cos(πl/W))/2 for l < W, 0 beyond: the strongest damping of the
//!   highest stored bands.
//! * Lanczos: w_l = sin(πl/W)/(πl/W) for l < W, 0 beyond (the sinc σ-factor): milder, keeps
//!   more contrast and some of the ringing.

/// A per-band window.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Window {
    /// No tapering: the plain truncated projection.
    #[default]
    None,
    Hanning {
        /// W; `None` means the order.
        width: Option<f64>,
    },
    Lanczos {
        /// W; `None` means the order.
        width: Option<f64>,
    },
}

impl Window {
    /// The factors w_0..w_{n−1} for an order-n projection.
    pub fn factors(&self, order: usize) -> Vec<f64> {
        let width = |w: Option<f64>| w.unwrap_or(order as f64);
        (0..order)
            .map(|l| {
                let l = l as f64;
                match *self {
                    Window::None => 1.0,
                    Window::Hanning { width: w } => {
                        let w = width(w);
                        if l < w {
                            0.5 * (1.0 + (std::f64::consts::PI * l / w).cos())
                        } else {
                            0.0
                        }
                    }
                    Window::Lanczos { width: w } => {
                        let w = width(w);
                        let x = std::f64::consts::PI * l / w;
                        if l == 0.0 {
                            1.0
                        } else if l < w {
                            x.sin() / x
                        } else {
                            0.0
                        }
                    }
                }
            })
            .collect()
    }

    pub fn name(&self) -> &'static str {
        match self {
            Window::None => "none",
            Window::Hanning { .. } => "hanning",
            Window::Lanczos { .. } => "lanczos",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_keep_the_mean_and_taper_monotonically() {
        for window in [
            Window::Hanning { width: None },
            Window::Lanczos { width: None },
            Window::Hanning { width: Some(3.5) },
        ] {
            let w = window.factors(8);
            assert_eq!(w[0], 1.0, "{window:?}");
            for pair in w.windows(2) {
                assert!(pair[1] <= pair[0] && pair[1] >= 0.0, "{window:?}: {w:?}");
            }
        }
        assert_eq!(Window::None.factors(5), vec![1.0; 5]);
        // Hanning at half the width: (1 + cos(π/2))/2.
        let h = Window::Hanning { width: Some(4.0) }.factors(5);
        assert!((h[2] - 0.5).abs() < 1e-15 && h[4] == 0.0);
    }
}
