//! How noisy one receiver's transfer is, from its own rays: what the denoiser
//! ([`crate::bake::denoise`]) weighs the difference between two receivers against.
//!
//! A fixed bake's points are one Owen-scrambled Sobol sequence. Its [`NOISE_BLOCKS`] runs of
//! consecutive points are each a scrambled net, so each gives an estimate of the transfer,
//! and their spread measures the error of one run. This is the estimate adaptive sampling
//! makes from its pilot ([`crate::bake::adaptive`], whose model and correction it shares):
//! the runs are not independent (together they are one net, whose variance falls as
//! N^-[`RATE`]), so the spread is corrected for their negative covariance and scaled from a
//! run's size to the whole sequence's. The plain variance of the N ray values would treat the
//! net as independent samples and overstate the error several times.
//!
//! Only band 0 and band 1 are summed (4 coefficients): they carry most of a diffuse
//! receiver's energy, their spread is rotation-invariant per band (it is formed in the local
//! frame), and 4 additions per unblocked ray cost next to nothing beside the ray. Transfer
//! matrices sum the 9 of bands 0 to 2 ([`NoiseBlocks::bands_0_to_2`]): their range term's signal
//! is exactly those entries of the matrix's first row, next to which 9 additions cost nothing.

use crate::bake::options::RATE;

/// Runs of the sequence whose spread gives the estimate.
pub const NOISE_BLOCKS: usize = 4;
/// Coefficients summed per run by vector bakes: bands 0 and 1.
const NOISE_COEFFICIENTS: usize = 4;
/// The most coefficients summed per run: bands 0 to 2 (transfer matrices).
const MAX_COEFFICIENTS: usize = 9;

/// One receiver's sums per run of its sequence.
#[derive(Clone, Debug)]
pub struct NoiseBlocks {
    /// Coefficients summed: 4 (9 for [`NoiseBlocks::bands_0_to_2`]), or n² where fewer.
    used: usize,
    /// `sums[k · 9 + j]`: run k's sum of coefficient j over its unblocked points.
    sums: [f64; NOISE_BLOCKS * MAX_COEFFICIENTS],
}

impl NoiseBlocks {
    /// Sums of bands 0 and 1 for `n` coefficients per row (the SH order's n²).
    pub fn new(n: usize) -> NoiseBlocks {
        NoiseBlocks {
            used: n.min(NOISE_COEFFICIENTS),
            sums: [0.0; NOISE_BLOCKS * MAX_COEFFICIENTS],
        }
    }

    /// Sums of bands 0 to 2 for `n` coefficients per row: whole bands, so their spread is
    /// the same in the local frame and in world space.
    pub fn bands_0_to_2(n: usize) -> NoiseBlocks {
        NoiseBlocks {
            used: n.min(MAX_COEFFICIENTS),
            ..NoiseBlocks::new(n)
        }
    }

    pub fn clear(&mut self) {
        self.sums = [0.0; NOISE_BLOCKS * MAX_COEFFICIENTS];
    }

    /// Adds the rows of the points not `occluded` to their runs (`blocks`, per row).
    pub fn add_unblocked<'r>(
        &mut self,
        rows: impl Iterator<Item = &'r [f32]>,
        blocks: &[u8],
        occluded: &[bool],
    ) {
        for ((row, &block), &blocked) in rows.zip(blocks).zip(occluded) {
            if !blocked {
                let sums = &mut self.sums[usize::from(block) * MAX_COEFFICIENTS..];
                for (sum, y) in sums[..self.used].iter_mut().zip(row) {
                    *sum += f64::from(*y);
                }
            }
        }
    }

    /// The estimated variance of one summed coefficient of the mean of all `samples` points
    /// (averaged over the coefficients); 0 for fewer than 2 points a run.
    pub fn variance(&self, samples: u32) -> f32 {
        let samples = u64::from(samples);
        let k = NOISE_BLOCKS as u64;
        if samples < 2 * k {
            return 0.0;
        }
        // Run b holds the points i with i·K/N = b: [⌈bN/K⌉, ⌈(b+1)N/K⌉).
        let start = |b: u64| (b * samples).div_ceil(k);
        let mut spread = 0.0;
        for j in 0..self.used {
            let total: f64 = (0..NOISE_BLOCKS)
                .map(|b| self.sums[b * MAX_COEFFICIENTS + j])
                .sum();
            let mean = total / samples as f64;
            for b in 0..NOISE_BLOCKS {
                let count = (start(b as u64 + 1) - start(b as u64)) as f64;
                let run = self.sums[b * MAX_COEFFICIENTS + j] / count;
                spread += (run - mean) * (run - mean);
            }
        }
        let k = NOISE_BLOCKS as f64;
        let spread = spread / (self.used as f64 * (k - 1.0));
        // The runs' expected spread is V − C for a run's variance V and their covariance
        // C = V·(K^(1−RATE) − 1)/(K − 1); the whole sequence's variance is V·K^−RATE.
        let run_variance = spread / (1.0 + (1.0 - k.powf(1.0 - RATE)) / (k - 1.0));
        (run_variance * k.powf(-RATE)) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_that_agree_have_no_noise_and_runs_that_differ_do() {
        let mut blocks = NoiseBlocks::new(16);
        let row = [1.0f32; 16];
        let rows = vec![&row[..]; 64];
        let runs: Vec<u8> = (0..64).map(|i| (i * 4 / 64) as u8).collect();
        blocks.add_unblocked(rows.iter().copied(), &runs, &[false; 64]);
        assert_eq!(blocks.variance(64), 0.0);
        // Run 0 blocked entirely: its estimate is 0 where the others' are 1.
        blocks.clear();
        let occluded: Vec<bool> = (0..64).map(|i| i < 16).collect();
        blocks.add_unblocked(rows.iter().copied(), &runs, &occluded);
        assert!(blocks.variance(64) > 0.01);
        // Too few points a run to say.
        assert_eq!(blocks.variance(7), 0.0);
    }
}
