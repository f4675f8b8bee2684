//! Receivers near a point, found in world space: a uniform grid of cubic cells over the
//! receivers' points, its occupied cells sorted by key and found by binary search. Written
//! here because the query is a dozen lines, and its visiting order (cells in a fixed order,
//! receivers in index order within a cell) must be deterministic, which a hash map's is not:
//! the denoiser sums over neighbours in this order.

use glam::Vec3;

#[derive(Clone)]
pub struct Grid {
    cell: f32,
    origin: Vec3,
    /// Occupied cells: (key, start, end) into `order`, sorted by key.
    cells: Vec<(u64, u32, u32)>,
    /// Receiver indices, sorted by (cell key, index).
    order: Vec<u32>,
}

/// Bits per axis of a cell key: 2²¹ cells a side.
const AXIS_BITS: u32 = 21;
const AXIS_MAX: i64 = (1 << AXIS_BITS) - 1;

impl Grid {
    /// A grid of `cell`-sized cubes over `points` (`cell` > 0).
    pub fn new(points: &[Vec3], cell: f32) -> Grid {
        let origin = points
            .iter()
            .fold(Vec3::splat(f32::INFINITY), |a, p| a.min(*p));
        // Far larger scenes than 2²¹ cells a side get coarser cells (a slower query, the
        // same neighbours).
        let extent = points
            .iter()
            .fold(Vec3::ZERO, |a, p| a.max(*p - origin))
            .max_element();
        let cell = cell.max(extent / AXIS_MAX as f32).max(f32::MIN_POSITIVE);
        let mut grid = Grid {
            cell,
            origin,
            cells: Vec::new(),
            order: Vec::new(),
        };
        let mut keyed: Vec<(u64, u32)> = points
            .iter()
            .enumerate()
            .map(|(i, p)| (grid.key(grid.coords(*p)), i as u32))
            .collect();
        keyed.sort_unstable();
        grid.order = keyed.iter().map(|&(_, i)| i).collect();
        for (at, &(key, _)) in keyed.iter().enumerate() {
            match grid.cells.last_mut() {
                Some(last) if last.0 == key => last.2 = at as u32 + 1,
                _ => grid.cells.push((key, at as u32, at as u32 + 1)),
            }
        }
        grid
    }

    fn coords(&self, p: Vec3) -> [i64; 3] {
        let c = ((p - self.origin) / self.cell).floor();
        [c.x as i64, c.y as i64, c.z as i64]
    }

    fn key(&self, c: [i64; 3]) -> u64 {
        c.iter().fold(0u64, |key, &a| {
            (key << AXIS_BITS) | a.clamp(0, AXIS_MAX) as u64
        })
    }

    /// The receivers of each occupied cell, cell by cell in key order, each cell's in index
    /// order.
    pub fn cells(&self) -> impl Iterator<Item = &[u32]> {
        self.cells
            .iter()
            .map(|&(_, start, end)| &self.order[start as usize..end as usize])
    }

    /// Calls `visit` with every receiver in a cell that the sphere of `radius` about `p`
    /// overlaps (a superset of those within `radius`), in a fixed order.
    pub fn visit(&self, p: Vec3, radius: f32, mut visit: impl FnMut(u32)) {
        let lo = self.coords(p - Vec3::splat(radius));
        let hi = self.coords(p + Vec3::splat(radius));
        // Cells of one (x, y) are consecutive keys: one search finds the run of z.
        for x in lo[0].max(0)..=hi[0].min(AXIS_MAX) {
            for y in lo[1].max(0)..=hi[1].min(AXIS_MAX) {
                let first = self.key([x, y, lo[2]]);
                let last = self.key([x, y, hi[2]]);
                let from = self.cells.partition_point(|c| c.0 < first);
                for &(_, start, end) in self.cells[from..].iter().take_while(|c| c.0 <= last) {
                    self.order[start as usize..end as usize]
                        .iter()
                        .for_each(|&i| visit(i));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_query_finds_every_point_within_its_radius() {
        let mut rng = crate::math::sampling::Pcg32::new(1, 2);
        let points: Vec<Vec3> = (0..2000)
            .map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32() * 0.1))
            .collect();
        let grid = Grid::new(&points, 0.05);
        for p in points.iter().step_by(97) {
            let mut found = Vec::new();
            grid.visit(*p, 0.08, |i| {
                if points[i as usize].distance(*p) <= 0.08 {
                    found.push(i)
                }
            });
            found.sort_unstable();
            let truth: Vec<u32> = (0..points.len() as u32)
                .filter(|&i| points[i as usize].distance(*p) <= 0.08)
                .collect();
            assert_eq!(found, truth);
        }
    }
}
