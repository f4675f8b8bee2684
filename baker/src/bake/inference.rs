//! Visibility inferred from the neighbouring points of a nested Owen–Sobol net (adaptive
//! bakes, [`crate::bake::adaptive`]): the rays a receiver does not need to cast.
//!
//! The first 2^q points of the sequence (a (0,2)-sequence, Owen-scrambled) put exactly one
//! point in every cell of the 2^a × 2^b grid over [0, 1)², a = ⌈q/2⌉ leading bits of u1 and
//! b = ⌊q/2⌋ of u2. A point of the next octave, [2^q, 2^(q+1)), lies in a cell whose point is
//! known, and so are the points of the 8 cells around it: if all 9 agree (all blocked or all
//! unblocked), the new point is given their answer instead of a ray. Each octave is judged on
//! the grid of all the points before it, cast or inferred, so the band of rays that are cast
//! narrows about the shadow's edge as the points get denser.
//!
//! u2 is the azimuth ([`crate::math::sampling::cosine_hemisphere`]), so columns wrap; u1 = r²,
//! so the cells of the first row meet at the pole and are all neighbours of each other.
//!
//! What inference can miss is a feature that falls between all 9 points, one smaller than the
//! cells of the octave judged; the first octave judged is at least the feature floor of the
//! target ([`crate::bake::adaptive::feature_rays`]), so such a feature is worth at most E.
//! A denoised bake audits the inferences that could pass its filter unaveraged (every few
//! inferred points cast too, [`crate::bake::adaptive_denoised`]).

/// A cell no point has filled (never, for a net; kept for safety): not uniform.
const UNKNOWN: u8 = 2;

/// The answers of the first 2^level points, by cell.
#[derive(Default)]
pub struct Grid {
    level: u32,
    /// Bits of u1 and u2 (a + b = level).
    a: u32,
    b: u32,
    /// `cells[ix · 2^b + iy]`: 1 unblocked, 0 blocked, [`UNKNOWN`].
    cells: Vec<u8>,
}

impl Grid {
    /// The grid of points 0..2^level, whose scrambled integer coordinates are `bits[i]` and
    /// answers `seen[i]` (1 unblocked, 0 blocked).
    pub fn new(level: u32, bits: &[(u32, u32)], seen: &[u8]) -> Grid {
        let mut grid = Grid::default();
        grid.rebuild(level, bits, seen);
        grid
    }

    /// Makes this the grid of points 0..2^level, reusing its cells' memory (a receiver builds
    /// one per octave).
    pub fn rebuild(&mut self, level: u32, bits: &[(u32, u32)], seen: &[u8]) {
        (self.level, self.a, self.b) = (level, level.div_ceil(2), level / 2);
        self.cells.clear();
        self.cells.resize(1 << level, UNKNOWN);
        for (&point, &answer) in bits.iter().zip(seen).take(1 << level) {
            let (ix, iy) = self.cell(point);
            self.cells[(ix << self.b) + iy] = answer;
        }
    }

    pub fn level(&self) -> u32 {
        self.level
    }

    fn cell(&self, (x, y): (u32, u32)) -> (usize, usize) {
        let top = |v: u32, bits: u32| {
            if bits == 0 {
                0
            } else {
                (v >> (32 - bits)) as usize
            }
        };
        (top(x, self.a), top(y, self.b))
    }

    /// The answer shared by the cell of `point` and all its neighbours, if they agree.
    pub fn infer(&self, point: (u32, u32)) -> Option<u8> {
        let (ix, iy) = self.cell(point);
        let (rows, columns) = (1usize << self.a, 1usize << self.b);
        let first = self.cells[(ix << self.b) + iy];
        if first == UNKNOWN {
            return None;
        }
        let agrees = |x: usize, y: usize| self.cells[(x << self.b) + y] == first;
        if ix == 0 {
            // The pole: the first two rows, every column.
            let last = 1.min(rows - 1);
            return (0..=last)
                .all(|x| (0..columns).all(|y| agrees(x, y)))
                .then_some(first);
        }
        let xs = ix - 1..=(ix + 1).min(rows - 1);
        let ys = [(iy + columns - 1) % columns, iy, (iy + 1) % columns];
        xs.into_iter()
            .all(|x| ys.iter().all(|&y| agrees(x, y)))
            .then_some(first)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::adaptive::{AUDIT_EVERY, AdaptiveScratch, Inference, ReceiverState, Tables};
    use crate::bake::options::BakeOptions;
    use crate::math::sampling::OwenSobol;
    use crate::math::sh::Basis;
    use crate::trace::{Backend, Hit, Ray, Tracer};
    use glam::{Mat3, Vec3};

    fn points(count: u32) -> Vec<(u32, u32)> {
        let set = OwenSobol::new(7);
        (0..count).map(|i| set.bits(i)).collect()
    }

    #[test]
    fn every_cell_of_a_power_of_two_prefix_holds_one_point() {
        let bits = points(1 << 10);
        for level in 2..=10 {
            let grid = Grid::new(level, &bits, &vec![1; bits.len()]);
            assert!(!grid.cells.contains(&UNKNOWN), "level {level}");
        }
    }

    #[test]
    fn a_uniform_neighbourhood_is_inferred_and_an_edge_is_not() {
        // Blocked where u1 < 1/2 (a ring about the pole): far from the edge the answer is
        // inferred, right at it the point must be cast.
        let bits = points(1 << 12);
        let seen: Vec<u8> = bits.iter().map(|&(x, _)| u8::from(x >= 1 << 31)).collect();
        let grid = Grid::new(10, &bits, &seen);
        let (mut inferred, mut cast) = (0, 0);
        for &point in &bits[1 << 10..1 << 11] {
            let u1 = f64::from(point.0) / 2f64.powi(32);
            match grid.infer(point) {
                Some(answer) => {
                    assert_eq!(answer, u8::from(u1 >= 0.5), "u1 = {u1}");
                    inferred += 1;
                }
                None => {
                    // 2^5 rows: the cast points lie within two rows of the edge.
                    assert!((u1 - 0.5).abs() < 2.0 / 32.0, "u1 = {u1} was not inferred");
                    cast += 1;
                }
            }
        }
        assert!(inferred > 6 * cast, "{inferred} inferred, {cast} cast");
    }

    /// Open sky only in a thin band of azimuth about φ = 1 (a slit between two walls).
    struct Slit(f32);

    impl Tracer for Slit {
        fn backend(&self) -> Backend {
            Backend::None
        }

        fn occluded(&self, rays: &[Ray], occluded: &mut [bool]) {
            for (ray, out) in rays.iter().zip(occluded) {
                *out = (ray.dir.y.atan2(ray.dir.x) - 1.0).abs() > self.0;
            }
        }

        fn intersect(&self, _: &[Ray], _: &mut [Option<Hit>]) {
            unreachable!("occlusion only")
        }
    }

    #[test]
    fn audits_count_the_slivers_inference_misses() {
        let options = BakeOptions {
            target_error: Some(1e-3),
            samples: 4096,
            ..BakeOptions::default()
        };
        let n = 9;
        let tables = Tables::new(&options, &Basis::new(3));
        let slit = Slit(0.02);
        let frame = (Vec3::ZERO, &Mat3::IDENTITY);
        let extended = |inference| {
            let s = &mut AdaptiveScratch::default();
            let mut state = ReceiverState::pilot(&tables, n, frame, Some(&slit), s);
            state.extend(&tables, n, frame, Some(&slit), s, 4096, inference);
            state
        };
        let (cast, inferred, audited) = (
            extended(Inference::Off),
            extended(Inference::On),
            extended(Inference::Audited(AUDIT_EVERY)),
        );
        // Casting every point sees the slit's sky 4096 × 0.04/2π ≈ 26 times (its exact share);
        // inference misses some of it, and no audit runs.
        eprintln!(
            "unblocked: cast {}, inferred {}, audited {} ({} audits, {} mismatches)",
            cast.unblocked,
            inferred.unblocked,
            audited.unblocked,
            audited.audited,
            audited.mismatches
        );
        assert!(inferred.unblocked < cast.unblocked);
        assert_eq!((inferred.audited, inferred.mismatches), (0, 0));
        // The audits cast a quarter of the inferred points and find the misses.
        assert!(
            audited.mismatches > 0,
            "no mismatch in {} audits",
            audited.audited
        );
        assert!(audited.rays < cast.rays && audited.rays > inferred.rays);
        assert!(audited.unblocked > inferred.unblocked && audited.unblocked <= cast.unblocked);
    }
}
