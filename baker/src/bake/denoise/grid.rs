//! Receivers near a point, found in world space: a uniform grid of cubic cells over the
//! receivers' points, its occupied cells sorted by key, each column of cells found in a table
//! (or, for a grid too large for one, by binary search). Written
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
    /// Where each (x, y) column's cells start in `cells`, column x · `columns.1` + y, and
    /// one more entry for the end; empty where the grid has over [`TABLE_MAX`] columns.
    column_starts: Vec<u32>,
    /// Columns along x and y.
    columns: (i64, i64),
}

/// The most columns a table indexes (16 MiB): past it, a binary search finds each column.
const TABLE_MAX: i64 = 1 << 22;

/// Bits per axis of a cell key: 2²¹ cells a side.
const AXIS_BITS: u32 = 21;
const AXIS_MAX: i64 = (1 << AXIS_BITS) - 1;

/// The (x, y) column of a cell key.
fn column(key: u64) -> (i64, i64) {
    (
        (key >> (2 * AXIS_BITS)) as i64,
        (key >> AXIS_BITS) as i64 & AXIS_MAX,
    )
}

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
            column_starts: Vec::new(),
            columns: (0, 0),
        };
        let keys: Vec<u64> = points.iter().map(|p| grid.key(grid.coords(*p))).collect();
        let (nx, ny) = keys.iter().fold((0, 0), |(nx, ny), &key| {
            let (x, y) = column(key);
            (nx.max(x + 1), ny.max(y + 1))
        });
        match nx * ny > TABLE_MAX {
            true => grid.sort_by_key(&keys),
            false => grid.sort_by_column(&keys, (nx, ny)),
        }
        grid
    }

    /// Sorts the points by (key, index) with a counting sort by column, then by key within
    /// each column (a few cells), and indexes the columns: no sort of every point, and the
    /// column table is formed on the way.
    fn sort_by_column(&mut self, keys: &[u64], (nx, ny): (i64, i64)) {
        let index = |key: u64| {
            let (x, y) = column(key);
            (x * ny + y) as usize
        };
        // Counted one column ahead, summed, then each column's cursor: once the points are
        // placed, entry c is where column c ends.
        let mut table = vec![0u32; (nx * ny + 1) as usize];
        for &key in keys {
            table[index(key) + 1] += 1;
        }
        for c in 1..table.len() {
            table[c] += table[c - 1];
        }
        let mut order = vec![0u32; keys.len()];
        for (i, &key) in keys.iter().enumerate() {
            let at = &mut table[index(key)];
            order[*at as usize] = i as u32;
            *at += 1;
        }
        // Column by column: its points by key (a stable sort keeps index order within a
        // cell), its cells, and the table's entry turned from the column's end among the
        // points to its start among the cells.
        let mut start = 0;
        for c in 0..table.len() - 1 {
            let end = table[c] as usize;
            table[c] = self.cells.len() as u32;
            order[start..end].sort_by_key(|&i| keys[i as usize]);
            for at in start..end {
                self.push_sorted(keys[order[at] as usize], at);
            }
            start = end;
        }
        let last = table.len() - 1;
        table[last] = self.cells.len() as u32;
        self.order = order;
        self.column_starts = table;
        self.columns = (nx, ny);
    }

    /// Sorts the points by (key, index) where the grid has too many columns for a table:
    /// each column is then found by binary search.
    fn sort_by_key(&mut self, keys: &[u64]) {
        let mut keyed: Vec<(u64, u32)> = keys
            .iter()
            .enumerate()
            .map(|(i, &k)| (k, i as u32))
            .collect();
        keyed.sort_unstable();
        self.order = keyed.iter().map(|&(_, i)| i).collect();
        for (at, &(key, _)) in keyed.iter().enumerate() {
            self.push_sorted(key, at);
        }
    }

    /// Adds the point at `at` of the sorted order, of cell `key`, to the cells: the last
    /// cell's run grows, or a new cell starts.
    fn push_sorted(&mut self, key: u64, at: usize) {
        match self.cells.last_mut() {
            Some(last) if last.0 == key => last.2 = at as u32 + 1,
            _ => self.cells.push((key, at as u32, at as u32 + 1)),
        }
    }

    /// The cell of `p`: truncated, not floored (no call to `floor` per point). The two agree
    /// for points of the grid, at or above `origin`; a query corner below it lands in cell 0
    /// either way once clamped, and a query wholly below it visits cell 0 as well, which a
    /// superset allows.
    fn coords(&self, p: Vec3) -> [i64; 3] {
        let c = (p - self.origin) / self.cell;
        [c.x as i64, c.y as i64, c.z as i64]
    }

    fn key(&self, c: [i64; 3]) -> u64 {
        c.iter().fold(0u64, |key, &a| {
            (key << AXIS_BITS) | a.clamp(0, AXIS_MAX) as u64
        })
    }

    /// Names the points anew, point i as `labels[i]` (ascending with i, so each cell's are
    /// still visited in index order): a grid over a subset answers with the whole set's
    /// indices.
    pub fn relabel(&mut self, labels: &[u32]) {
        for i in self.order.iter_mut() {
            *i = labels[*i as usize];
        }
    }

    /// The receivers of each occupied cell, each cell's in index order, the cells in the
    /// order of their first (lowest) receiver: a pass over them reads per-receiver arrays
    /// about in sequence (a lightmap's texels row band by row band), where key order jumps
    /// across the whole atlas from one cell to the next.
    pub fn cells_by_first(&self) -> Vec<&[u32]> {
        let mut cells: Vec<&[u32]> = self
            .cells
            .iter()
            .map(|&(_, start, end)| &self.order[start as usize..end as usize])
            .collect();
        // No two cells share a receiver: the order is the same for any sort.
        cells.sort_unstable_by_key(|cell| cell[0]);
        cells
    }

    /// Calls `visit` with every receiver in a cell that the sphere of `radius` about `p`
    /// overlaps (a superset of those within `radius`), in a fixed order.
    #[inline(always)]
    pub fn visit(&self, p: Vec3, radius: f32, mut visit: impl FnMut(u32)) {
        self.visit_cells(p, radius, |_, members| {
            members.iter().for_each(|&i| visit(i))
        });
    }

    /// [`Grid::visit`] a cell at a time: `visit(cell, members)` for each occupied cell the
    /// sphere overlaps, `cell` its index in [`Grid::cell_members`]' order.
    #[inline(always)]
    pub fn visit_cells(&self, p: Vec3, radius: f32, mut visit: impl FnMut(usize, &[u32])) {
        let lo = self.coords(p - Vec3::splat(radius));
        let hi = self.coords(p + Vec3::splat(radius));
        // Cells of one (x, y) are consecutive keys: the column's run, or one search, finds
        // the run of z.
        let table = !self.column_starts.is_empty();
        let (nx, ny) = match table {
            true => self.columns,
            false => (AXIS_MAX + 1, AXIS_MAX + 1),
        };
        for x in lo[0].max(0)..=hi[0].min(nx - 1) {
            for y in lo[1].max(0)..=hi[1].min(ny - 1) {
                let first = self.key([x, y, lo[2]]);
                let last = self.key([x, y, hi[2]]);
                let column = match table {
                    true => {
                        let c = (x * ny + y) as usize;
                        self.column_starts[c] as usize..self.column_starts[c + 1] as usize
                    }
                    false => 0..self.cells.len(),
                };
                let cells = &self.cells[column.clone()];
                let from = column.start + cells.partition_point(|c| c.0 < first);
                for (at, &(key, start, end)) in self.cells.iter().enumerate().skip(from) {
                    if key > last {
                        break;
                    }
                    visit(at, &self.order[start as usize..end as usize]);
                }
            }
        }
    }

    /// The cells' side.
    pub fn cell(&self) -> f32 {
        self.cell
    }

    /// Each occupied cell's receivers, in index order, in the order [`Grid::visit_cells`]
    /// numbers the cells.
    pub fn cell_members(&self) -> impl Iterator<Item = &[u32]> {
        (self.cells.iter()).map(|&(_, start, end)| &self.order[start as usize..end as usize])
    }
}

/// One [`Grid`] per group of points, each with cells sized to its own points' spacing. The
/// filter's wide pass never weighs a point of another group (another object or material),
/// so a query reads its own group's points alone; and an atlas packs objects at texel sizes
/// of their own, so one cell size for all would make a small-texelled object's queries read
/// whole cells of points beyond their reach.
pub struct GroupedGrid {
    /// The groups, ascending, and for each its grid (of the points' own indices).
    groups: Vec<u32>,
    grids: Vec<Grid>,
}

impl GroupedGrid {
    /// Grids over `points` by their `groups`, each of cells `scale` times the median of its
    /// points' `spacing`.
    pub fn new(points: &[Vec3], groups: &[u32], spacing: &[f32], scale: f32) -> Self {
        let mut by_group: Vec<u32> = (0..points.len() as u32).collect();
        by_group.sort_by_key(|&i| groups[i as usize]);
        let mut grouped = GroupedGrid {
            groups: Vec::new(),
            grids: Vec::new(),
        };
        // Each group's points in ascending index order (the sort is stable).
        for members in by_group.chunk_by(|&a, &b| groups[a as usize] == groups[b as usize]) {
            let mut spacings: Vec<f32> = members.iter().map(|&i| spacing[i as usize]).collect();
            let mid = spacings.len() / 2;
            let typical = *spacings.select_nth_unstable_by(mid, f32::total_cmp).1;
            let at: Vec<Vec3> = members.iter().map(|&i| points[i as usize]).collect();
            let mut grid = Grid::new(&at, (scale * typical).max(1e-12));
            grid.relabel(members);
            grouped.groups.push(groups[members[0] as usize]);
            grouped.grids.push(grid);
        }
        grouped
    }

    /// [`Grid::visit`] of `group`'s points.
    #[inline(always)]
    pub fn visit(&self, group: u32, p: Vec3, radius: f32, visit: impl FnMut(u32)) {
        if let Ok(g) = self.groups.binary_search(&group) {
            self.grids[g].visit(p, radius, visit);
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

    #[test]
    fn the_counting_sort_orders_as_the_sort_by_key() {
        let mut rng = crate::math::sampling::Pcg32::new(9, 10);
        // Two layers of a sheet and a scatter: many points per cell and column.
        let points: Vec<Vec3> = (0..3000)
            .map(|i| match i % 3 {
                2 => Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()),
                k => Vec3::new(rng.next_f32(), 0.3 * k as f32, rng.next_f32()),
            })
            .collect();
        let grid = Grid::new(&points, 0.07);
        assert!(!grid.column_starts.is_empty());
        let keys: Vec<u64> = points.iter().map(|p| grid.key(grid.coords(*p))).collect();
        let mut sorted = Grid {
            cells: Vec::new(),
            order: Vec::new(),
            column_starts: Vec::new(),
            ..grid.clone()
        };
        sorted.sort_by_key(&keys);
        assert_eq!(grid.order, sorted.order);
        assert_eq!(grid.cells, sorted.cells);
        // Each column's entry starts its cells.
        let ny = grid.columns.1;
        for (k, c) in grid.cells.iter().enumerate() {
            let (x, y) = column(c.0);
            let at = (x * ny + y) as usize;
            let run = grid.column_starts[at] as usize..grid.column_starts[at + 1] as usize;
            assert!(run.contains(&k));
        }
    }

    #[test]
    fn a_grouped_query_finds_its_own_group_within_its_radius() {
        let mut rng = crate::math::sampling::Pcg32::new(3, 4);
        let points: Vec<Vec3> = (0..3000)
            .map(|_| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32() * 0.1))
            .collect();
        // Three groups at texel sizes 4 × apart.
        let groups: Vec<u32> = (0..points.len()).map(|i| [7, 2, 9][i % 3]).collect();
        let spacing: Vec<f32> = groups.iter().map(|&g| 0.01 * g as f32).collect();
        let grid = GroupedGrid::new(&points, &groups, &spacing, 3.5);
        for i in (0..points.len()).step_by(89) {
            let (p, g) = (points[i], groups[i]);
            let mut found = Vec::new();
            grid.visit(g, p, 0.08, |j| {
                assert_eq!(groups[j as usize], g);
                if points[j as usize].distance(p) <= 0.08 {
                    found.push(j)
                }
            });
            found.sort_unstable();
            let truth: Vec<u32> = (0..points.len() as u32)
                .filter(|&j| groups[j as usize] == g && points[j as usize].distance(p) <= 0.08)
                .collect();
            assert_eq!(found, truth);
        }
    }
}
