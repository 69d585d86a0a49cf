//! Which axis-aligned boxes overlap, with memory proportional to the number of boxes
//! whatever their sizes and positions: the broad phase of the particle and fast engines
//! and of the world's start checks and overlap readings.
//!
//! Usually a uniform hash grid whose cell is the largest box (at most 2 m), each box in
//! the few cells it touches: the particle backend's grid since it was written, kept so
//! that its contacts come out in the same order (its tolerances were measured with it).
//! When that grid would file more than [`MAX_CELLS_PER_AXIS`]³ cells per box on average
//! (one 1 km capsule made a billion 2 m cells and aborted), a hierarchical hash grid
//! instead (after Eitz & Lixu, "Hierarchical Spatial Hashing for Real-time Collision
//! Detection", 2007): levels of cubic cells, each twice the size of the one below,
//! starting from the median box size. Each box goes into the one level whose cells are at
//! least as large as its longest side, where it touches at most [`MAX_CELLS_PER_AXIS`]³
//! cells, so a 1 km body or one flying at 10 km/s costs what a hand costs. Two boxes of
//! one level meet in a shared cell; a box meets the larger ones by looking up its own few
//! cells at each larger level in use.

use glam::Vec3;
use rayon::prelude::*;

/// Most cells one box is filed under per axis: 2 when its longest side fits a cell, the
/// third absorbs rounding in the division. A box is in at most 27 cells.
const MAX_CELLS_PER_AXIS: i64 = 3;

/// Grid entries from which a search is shared among threads: below it the hand-over costs
/// more than the search (a pile of four humanoids files about 200).
const PARALLEL_ENTRIES: usize = 4096;
/// Shares of the search per thread, so that a thread whose cells hold more pairs does
/// not hold up the rest.
const SHARES_PER_THREAD: usize = 4;

/// Smallest base cell, metres: finer cells only add levels.
const MIN_CELL_M: f32 = 1.0e-3;

/// Bounds of the uniform grid's cell, metres: the largest box, but a very large one spans
/// several cells rather than making every cell huge.
const UNIFORM_CELL_M: (f32, f32) = (0.05, 2.0);

/// A cell: its level and integer coordinates there (saturated for coordinates beyond
/// `i64`'s range, which only makes far boxes share a cell and fail the exact test).
type Key = (u8, [i64; 3]);

/// Reusable buffers of the grid; one per user, so steps do not allocate.
#[derive(Default)]
pub(crate) struct BroadPhase {
    /// Each box's level, or `u8::MAX` for a box that is not finite (it meets nothing).
    level: Vec<u8>,
    /// (cell, box) per cell of each box.
    entries: Vec<(Key, u32)>,
    /// The entries bucketed by hashed cell: bucket `h` is `sorted[starts[h]..starts[h + 1]]`.
    sorted: Vec<(Key, u32)>,
    starts: Vec<u32>,
    /// Number of buckets less one (a power of two less one).
    mask: usize,
    /// The levels in use, ascending.
    levels: Vec<u8>,
    /// Scratch for the median.
    sizes: Vec<f32>,
    /// Side of level 0's cells, metres, and its inverse.
    base: f32,
    inv_base: f32,
    /// Whether every box is on level 0 (the uniform grid; no cap on its cells).
    uniform: bool,
    /// Each thread share's pairs, in a search shared among threads.
    found: Vec<Vec<(u32, u32)>>,
}

/// The cells from `a` to `b` (inclusive corners), x outermost.
fn span(a: [i64; 3], b: [i64; 3]) -> impl Iterator<Item = [i64; 3]> {
    (a[0]..=b[0])
        .flat_map(move |x| (a[1]..=b[1]).flat_map(move |y| (a[2]..=b[2]).map(move |z| [x, y, z])))
}

/// The lowest corner of the overlap of boxes `a` and `b`, if they overlap or touch.
#[inline]
fn overlap(boxes: &[(Vec3, Vec3)], a: usize, b: usize) -> Option<Vec3> {
    let (lo, hi) = (boxes[a].0.max(boxes[b].0), boxes[a].1.min(boxes[b].1));
    (!lo.cmpgt(hi).any()).then_some(lo)
}

/// Share `k` of `count` of the indices `0..len`, in order.
fn share_of(len: usize, count: usize, k: usize) -> std::ops::Range<usize> {
    let per = len.div_ceil(count);
    (k * per).min(len)..((k + 1) * per).min(len)
}

/// The uniform grid's hash (level 0 adds nothing to it).
fn hash(key: &Key, mask: usize) -> usize {
    let (l, [x, y, z]) = *key;
    let h = (x as u32).wrapping_mul(73_856_093)
        ^ (y as u32).wrapping_mul(19_349_663)
        ^ (z as u32).wrapping_mul(83_492_791)
        ^ (l as u32).wrapping_mul(2_654_435_761);
    h as usize & mask
}

impl BroadPhase {
    /// Side of the cells of `level`, metres.
    fn cell(&self, level: u8) -> f64 {
        self.base as f64 * 2f64.powi(level as i32)
    }

    /// The cell of `p` at `level`. Level 0 in f32 as the uniform grid always did; `as`
    /// saturates, so coordinates past the integers' range share the outermost cell.
    fn cell_of(&self, p: Vec3, level: u8) -> [i64; 3] {
        if level == 0 {
            (p * self.inv_base)
                .floor()
                .as_ivec3()
                .to_array()
                .map(i64::from)
        } else {
            let c = self.cell(level);
            p.as_dvec3().to_array().map(|v| (v / c).floor() as i64)
        }
    }

    /// The cells of `level` that box `[lo, hi]` touches: every one on the uniform grid
    /// (whose total [`BroadPhase::place`] bounded), else at most [`MAX_CELLS_PER_AXIS`]
    /// per axis (a box is only filed, or looked up, at levels whose cells hold it).
    fn cells(&self, lo: Vec3, hi: Vec3, level: u8) -> impl Iterator<Item = [i64; 3]> + use<> {
        let (a, mut b) = (self.cell_of(lo, level), self.cell_of(hi, level));
        if !self.uniform {
            for k in 0..3 {
                b[k] = b[k].min(a[k].saturating_add(MAX_CELLS_PER_AXIS - 1));
            }
        }
        span(a, b)
    }

    /// The entries of cell `key`.
    fn bucket(&self, key: Key) -> impl Iterator<Item = u32> + '_ {
        let h = hash(&key, self.mask);
        let (s, e) = (self.starts[h] as usize, self.starts[h + 1] as usize);
        self.sorted[s..e]
            .iter()
            .filter(move |(k, _)| *k == key)
            .map(|&(_, b)| b)
    }

    /// Calls `emit(i, j)`, `i < j`, once for every pair of boxes (`(lo, hi)`, world
    /// space) that overlap or touch. Boxes with a non-finite corner meet nothing.
    ///
    /// Memory: at most [`MAX_CELLS_PER_AXIS`]³ entries per box and twice as many hash
    /// buckets, whatever the boxes. Time: linear in the boxes and the levels in use, plus
    /// the pairs that share a cell (boxes piled on one spot all meet, as they should).
    ///
    /// Large searches are shared among the threads of the current rayon pool, each
    /// taking a share of the cells; the pairs still come in the order one thread finds
    /// them, so whatever uses them runs the same on any number of threads.
    pub(crate) fn find(&mut self, boxes: &[(Vec3, Vec3)], mut emit: impl FnMut(usize, usize)) {
        self.place(boxes);
        self.fill(boxes);
        if self.entries.is_empty() {
            return;
        }
        let threads = rayon::current_num_threads();
        if threads == 1 || self.entries.len() < PARALLEL_ENTRIES {
            for h in 0..=self.mask {
                self.bucket_pairs(boxes, h, &mut emit);
            }
            for a in 0..boxes.len() {
                self.larger_pairs(boxes, a, &mut emit);
            }
            return;
        }
        let mut found = std::mem::take(&mut self.found);
        found.resize_with(threads * SHARES_PER_THREAD, Vec::new);
        let (buckets, count) = (self.mask + 1, found.len());
        let this = &*self;
        found.par_iter_mut().enumerate().for_each(|(k, out)| {
            out.clear();
            let mut push = |a: usize, b: usize| out.push((a as u32, b as u32));
            for h in share_of(buckets, count, k) {
                this.bucket_pairs(boxes, h, &mut push);
            }
        });
        for &(a, b) in found.iter().flatten() {
            emit(a as usize, b as usize);
        }
        if self.levels.len() > 1 {
            found.par_iter_mut().enumerate().for_each(|(k, out)| {
                out.clear();
                let mut push = |a: usize, b: usize| out.push((a as u32, b as u32));
                for a in share_of(boxes.len(), count, k) {
                    this.larger_pairs(boxes, a, &mut push);
                }
            });
            for &(a, b) in found.iter().flatten() {
                emit(a as usize, b as usize);
            }
        }
        self.found = found;
    }

    /// Pairs of boxes of one level that share a cell of bucket `h`; each pair once, in the
    /// cell holding the lowest corner of their overlap.
    fn bucket_pairs(&self, boxes: &[(Vec3, Vec3)], h: usize, emit: &mut impl FnMut(usize, usize)) {
        let bucket = &self.sorted[self.starts[h] as usize..self.starts[h + 1] as usize];
        for (i, &(ka, a)) in bucket.iter().enumerate() {
            for &(kb, b) in &bucket[i + 1..] {
                if ka != kb || a == b {
                    continue;
                }
                let (a, b) = (a.min(b) as usize, a.max(b) as usize);
                if let Some(lo) = overlap(boxes, a, b)
                    && self.cell_of(lo, ka.0) == ka.1
                {
                    emit(a, b);
                }
            }
        }
    }

    /// Box `a` against the larger ones, through its own cells at their levels.
    fn larger_pairs(&self, boxes: &[(Vec3, Vec3)], a: usize, emit: &mut impl FnMut(usize, usize)) {
        let la = self.level[a];
        if la == u8::MAX {
            return;
        }
        let (lo, hi) = boxes[a];
        for &m in self.levels.iter().filter(|&&m| m > la) {
            for cell in self.cells(lo, hi, m) {
                let key = (m, cell);
                for b in self.bucket(key) {
                    let b = b as usize;
                    if let Some(lo) = overlap(boxes, a, b)
                        && self.cell_of(lo, m) == cell
                    {
                        emit(a.min(b), a.max(b));
                    }
                }
            }
        }
    }

    /// The grid for these boxes: the uniform one when it files at most
    /// [`MAX_CELLS_PER_AXIS`]³ cells per box, else levels from the median box size; and
    /// each box's level.
    fn place(&mut self, boxes: &[(Vec3, Vec3)]) {
        let finite =
            |(lo, hi): &(Vec3, Vec3)| lo.is_finite() && hi.is_finite() && lo.cmple(*hi).all();
        let largest = boxes
            .iter()
            .filter(|b| finite(b))
            .map(|(lo, hi)| (*hi - *lo).max_element())
            .fold(0.0f32, f32::max);
        self.base = largest.clamp(UNIFORM_CELL_M.0, UNIFORM_CELL_M.1);
        self.inv_base = 1.0 / self.base;
        let budget = MAX_CELLS_PER_AXIS.pow(3) as u64 * boxes.len() as u64;
        let mut filed = 0u64;
        for b in boxes.iter().filter(|b| finite(b)) {
            let (lo, hi) = (self.cell_of(b.0, 0), self.cell_of(b.1, 0));
            let count = (0..3).fold(1u64, |n, k| {
                n.saturating_mul(hi[k].saturating_sub(lo[k]).saturating_add(1) as u64)
            });
            filed = filed.saturating_add(count);
        }
        self.uniform = filed <= budget;
        self.level.clear();
        self.levels.clear();
        if self.uniform {
            self.level
                .extend(boxes.iter().map(|b| if finite(b) { 0 } else { u8::MAX }));
            self.levels.push(0);
            return;
        }
        self.sizes.clear();
        self.sizes.extend(
            boxes
                .iter()
                .filter(|b| finite(b))
                .map(|(lo, hi)| (*hi - *lo).max_element()),
        );
        let mid = self.sizes.len() / 2;
        let (_, median, _) = self.sizes.select_nth_unstable_by(mid, f32::total_cmp);
        self.base = median.max(MIN_CELL_M);
        self.inv_base = 1.0 / self.base;
        for b in boxes {
            let level = if finite(b) {
                let ratio = (b.1 - b.0).max_element() as f64 / self.base as f64;
                if ratio <= 1.0 {
                    0
                } else {
                    // f32 boxes are below 2^128 m and the base at least 2^-10 m.
                    ratio.log2().ceil().min(200.0) as u8
                }
            } else {
                u8::MAX
            };
            self.level.push(level);
        }
        self.levels
            .extend(self.level.iter().copied().filter(|&l| l != u8::MAX));
        self.levels.sort_unstable();
        self.levels.dedup();
    }

    /// The entries of every box, bucketed by hashed cell (a counting sort).
    fn fill(&mut self, boxes: &[(Vec3, Vec3)]) {
        self.entries.clear();
        for (b, &(lo, hi)) in boxes.iter().enumerate() {
            let level = self.level[b];
            if level == u8::MAX {
                continue;
            }
            let cells = self.cells(lo, hi, level);
            self.entries
                .extend(cells.map(|cell| ((level, cell), b as u32)));
        }
        let buckets = (self.entries.len() * 2).next_power_of_two();
        let mask = buckets - 1;
        self.mask = mask;
        self.starts.clear();
        self.starts.resize(buckets + 2, 0);
        for (key, _) in &self.entries {
            self.starts[hash(key, mask) + 2] += 1;
        }
        for h in 0..buckets {
            self.starts[h + 2] += self.starts[h + 1];
        }
        // `starts[h + 1]` is now where bucket h begins; filling moves it to where it ends,
        // which is where bucket h + 1 begins.
        self.sorted.clear();
        self.sorted
            .resize(self.entries.len(), ((0, [0; 3]), u32::MAX));
        for &(key, b) in &self.entries {
            let slot = &mut self.starts[hash(&key, mask) + 1];
            self.sorted[*slot as usize] = (key, b);
            *slot += 1;
        }
    }

    /// Grid entries and hash buckets of the last search: what bounds its memory.
    pub(crate) fn footprint(&self) -> (usize, usize) {
        (self.entries.len(), self.mask + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (no dependency for a test).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            ((self.0 >> 40) as f32) / (1u64 << 24) as f32
        }
    }

    fn brute(boxes: &[(Vec3, Vec3)]) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for a in 0..boxes.len() {
            for b in a + 1..boxes.len() {
                let ok = |(lo, hi): (Vec3, Vec3)| lo.is_finite() && hi.is_finite();
                let (lo, hi) = (boxes[a].0.max(boxes[b].0), boxes[a].1.min(boxes[b].1));
                if ok(boxes[a]) && ok(boxes[b]) && !lo.cmpgt(hi).any() {
                    out.push((a, b));
                }
            }
        }
        out
    }

    fn found(grid: &mut BroadPhase, boxes: &[(Vec3, Vec3)]) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        grid.find(boxes, |a, b| out.push((a, b)));
        out.sort_unstable();
        out
    }

    #[test]
    fn finds_exactly_the_overlapping_pairs_once_at_any_sizes() {
        let mut rng = Lcg(7);
        let mut boxes = Vec::new();
        for k in 0..400 {
            let c = Vec3::new(rng.next(), rng.next(), rng.next()) * 20.0;
            // Sizes over five decades, a few boxes far bigger than the rest.
            let size = if k % 50 == 0 {
                300.0 * rng.next()
            } else {
                0.01 * 10f32.powf(3.0 * rng.next())
            };
            let half = Vec3::new(rng.next(), rng.next(), rng.next()) * size;
            boxes.push((c - half, c + half));
        }
        boxes.push((Vec3::splat(f32::NAN), Vec3::ONE));
        boxes.push((Vec3::splat(1e30), Vec3::splat(1.0001e30)));
        let mut grid = BroadPhase::default();
        let got = found(&mut grid, &boxes);
        let mut dedup = got.clone();
        dedup.dedup();
        assert_eq!(got.len(), dedup.len(), "a pair was reported twice");
        assert_eq!(got, brute(&boxes));
    }

    #[test]
    fn a_search_shared_among_threads_finds_the_same_pairs_in_the_same_order() {
        // Enough boxes to share the search, on a uniform grid and (a few huge boxes
        // among them) on levels: one thread and three must emit the very same sequence,
        // and it must be the exact set of overlapping pairs.
        for huge in [false, true] {
            let mut rng = Lcg(if huge { 5 } else { 3 });
            let boxes: Vec<(Vec3, Vec3)> = (0..2500)
                .map(|k| {
                    let c = Vec3::new(rng.next(), rng.next(), rng.next()) * 12.0;
                    let size = if huge && k % 100 == 0 { 40.0 } else { 0.3 };
                    let half = Vec3::new(rng.next(), rng.next(), rng.next()) * size;
                    (c - half, c + half)
                })
                .collect();
            let run = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let mut grid = BroadPhase::default();
                let mut out = Vec::new();
                pool.install(|| grid.find(&boxes, |a, b| out.push((a, b))));
                assert!(
                    grid.footprint().0 >= PARALLEL_ENTRIES,
                    "too few entries to share"
                );
                assert_eq!(grid.uniform, !huge);
                out
            };
            let one = run(1);
            assert_eq!(one, run(3), "huge boxes: {huge}");
            let mut sorted = one;
            sorted.sort_unstable();
            assert_eq!(sorted, brute(&boxes), "huge boxes: {huge}");
        }
    }

    #[test]
    fn a_crowd_of_similar_boxes_uses_the_uniform_grid_and_finds_the_same_pairs() {
        let mut rng = Lcg(11);
        let boxes: Vec<(Vec3, Vec3)> = (0..300)
            .map(|_| {
                let c = Vec3::new(rng.next(), rng.next(), rng.next()) * 6.0;
                let half = Vec3::new(rng.next(), rng.next(), rng.next()) * 0.3;
                (c - half, c + half)
            })
            .collect();
        let mut grid = BroadPhase::default();
        assert_eq!(found(&mut grid, &boxes), brute(&boxes));
        assert!(grid.uniform);
        assert!(grid.footprint().0 <= 27 * boxes.len());
    }

    #[test]
    fn memory_is_bounded_by_the_box_count_not_their_size() {
        // A regression: one 1 km capsule among a ragdoll's parts made the
        // old grid file it under a billion 2 m cells.
        let mut boxes: Vec<(Vec3, Vec3)> = (0..15)
            .map(|k| {
                let c = Vec3::new(0.0, 0.1 * k as f32, 0.0);
                (c - 0.15, c + 0.15)
            })
            .collect();
        boxes.push((Vec3::splat(-1000.0), Vec3::splat(1000.0)));
        // And bodies thrown at 10 km/s, their boxes grown by four steps of motion.
        boxes.push((Vec3::ZERO, Vec3::new(700.0, 0.3, 0.3)));
        boxes.push((Vec3::new(-3.0e4, -1.0, -1.0), Vec3::new(1.0, 1.0, 1.0)));
        let mut grid = BroadPhase::default();
        let pairs = found(&mut grid, &boxes);
        let (entries, buckets) = grid.footprint();
        assert!(!grid.uniform);
        let n = boxes.len();
        let most = MAX_CELLS_PER_AXIS.pow(3) as usize * n;
        assert!(entries <= most, "{entries} entries for {n} boxes");
        assert!(buckets <= 4 * most, "{buckets} buckets");
        assert_eq!(pairs, brute(&boxes));
    }
}
