//! Incremental Bowyer–Watson construction of the 3D Delaunay tetrahedralization.
//!
//! Invariant: between insertions the structure is a triangulation of the 3-sphere: finite
//! tetrahedra tile the convex hull of the inserted points, one ghost tetrahedron (with the
//! infinite vertex [`INF`]) sits on each hull face, every tetrahedron is positive and
//! locally Delaunay under the symbolic perturbation of [`predicates`], and `nbrs` is
//! symmetric (`nbrs[t][i] = t2 * 4 + j` and `nbrs[t2][j] = t * 4 + i`).

use glam::DVec3;

use std::cmp::Ordering;

use super::exact_int::Grid;
use super::predicates::{self, Sign};
use super::sort::brio_hilbert_order;
use super::{NO_NEIGHBOUR, TetError, TetMesh};
use crate::progress::Progress;

/// The vertex at infinity of ghost tetrahedra (never in a finished [`TetMesh`]).
const INF: u32 = u32::MAX;
/// `tets[t][0]` of a free slot.
const DEAD: u32 = u32::MAX - 1;
/// Largest number of distinct points (vertex ids stay below [`DEAD`]).
pub const MAX_POINTS: usize = (u32::MAX - 2) as usize;
/// Insertions between two progress reports / cancellation checks.
const CHECK_EVERY: usize = 4096;
/// Empty slot of the edge table.
const EMPTY: u64 = u64::MAX;

/// The Delaunay tetrahedralization of `points`; see [`super::delaunay`].
pub fn build(mut points: Vec<DVec3>, progress: &dyn Progress) -> Result<TetMesh, TetError> {
    if points.len() > MAX_POINTS {
        return Err(TetError::TooManyPoints {
            count: points.len(),
            max: MAX_POINTS,
        });
    }
    if let Some(index) = points.iter().position(|p| !p.is_finite()) {
        return Err(TetError::NonFinite { index });
    }
    // -0.0 and 0.0 are one coordinate: make them one bit pattern before sorting.
    for p in &mut points {
        *p += DVec3::ZERO;
    }
    let (mut vertex_of_input, scratch) = merge_duplicates(&mut points);
    let duplicates_merged = vertex_of_input.len() - points.len();
    if points.len() < 4 {
        return Err(TetError::TooFewPoints {
            distinct: points.len(),
        });
    }
    // Vertices are numbered in insertion order, so the points the construction touches
    // one after the other are neighbours in memory too.
    let mut order = brio_hilbert_order(&points);
    // In place (no second copy of the points): points[k] = old points[order[k]], then
    // order becomes its inverse, the new id of each old vertex.
    let mut done = vec![0u64; points.len().div_ceil(64)];
    permute_in_place(&mut points, &order, &mut done);
    done.fill(0);
    invert_in_place(&mut order, &mut done);
    drop(done);
    for v in &mut vertex_of_input {
        *v = order[*v as usize];
    }
    drop(order);
    // Freed only now, after the other sort temporaries: with glibc, freeing a large block
    // raises the size below which later blocks come from the heap, and freed heap blocks
    // stay resident. Kept until here, the permutation above was mapped and is returned.
    drop(scratch);
    let shift = exact_shift(&points);
    for p in &mut points {
        *p -= shift;
    }
    let built = Builder::run(&points, progress);
    for p in &mut points {
        *p += shift;
    }
    let (tets, neighbours) = built?;
    Ok(TetMesh {
        points,
        tets,
        neighbours,
        vertex_of_input,
        duplicates_merged,
    })
}

/// `items[k] = old items[order[k]]` for a permutation `order`, following its cycles
/// (`done`: one zeroed bit per item).
fn permute_in_place<T: Copy>(items: &mut [T], order: &[u32], done: &mut [u64]) {
    for start in 0..items.len() {
        if bit(done, start as u32) {
            continue;
        }
        let first = items[start];
        let mut k = start;
        loop {
            set_bit(done, k as u32, true);
            let src = order[k] as usize;
            if src == start {
                items[k] = first;
                break;
            }
            items[k] = items[src];
            k = src;
        }
    }
}

/// Replaces the permutation `order` by its inverse, following its cycles (`done`: one
/// zeroed bit per item).
fn invert_in_place(order: &mut [u32], done: &mut [u64]) {
    for start in 0..order.len() as u32 {
        if bit(done, start) {
            continue;
        }
        let mut prev = start;
        let mut cur = order[start as usize];
        loop {
            let next = order[cur as usize];
            order[cur as usize] = prev;
            set_bit(done, cur, true);
            if cur == start {
                break;
            }
            prev = cur;
            cur = next;
        }
    }
}

/// Merges points with exactly equal coordinates in place (first occurrence kept, input
/// order preserved) and returns the vertex of each input point, and a spent scratch buffer
/// for the caller to drop when its other temporaries are gone.
fn merge_duplicates(points: &mut Vec<DVec3>) -> (Vec<u32>, Vec<u32>) {
    use rayon::prelude::*;
    let n = points.len();
    let mut sorted: Vec<u32> = (0..n as u32).collect();
    {
        let p: &[DVec3] = points;
        sorted.par_sort_unstable_by(|&i, &j| {
            predicates::lex_cmp(p[i as usize], p[j as usize]).then(i.cmp(&j))
        });
    }
    // First: the representative (smallest input index) of each point.
    let mut vertex_of_input = vec![0u32; n];
    let mut run_start = 0;
    for k in 0..n {
        let i = sorted[k] as usize;
        if k > 0 && points[i] != points[sorted[k - 1] as usize] {
            run_start = k;
        }
        vertex_of_input[i] = sorted[run_start];
    }
    // Then: representatives numbered in input order, duplicates pointed at them.
    let mut next = 0u32;
    for i in 0..n {
        let rep = vertex_of_input[i] as usize;
        if rep == i {
            vertex_of_input[i] = next;
            points[next as usize] = points[i];
            next += 1;
        } else {
            vertex_of_input[i] = vertex_of_input[rep];
        }
    }
    points.truncate(next as usize);
    (vertex_of_input, sorted)
}

/// A per-axis translation under which every coordinate difference `x - shift` is exact
/// (Sterbenz: `s/2 <= x <= 2s`), so predicates on shifted points equal those on the input;
/// zero on axes where no such shift exists (coordinates spanning zero are small anyway).
fn exact_shift(points: &[DVec3]) -> DVec3 {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for &p in points {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let mut shift = DVec3::ZERO;
    for k in 0..3 {
        let (a, b) = (lo[k], hi[k]);
        let centre = 0.5 * a + 0.5 * b;
        if (a > 0.0 && b <= 2.5 * a) || (b < 0.0 && a >= 2.5 * b) {
            shift[k] = centre;
        }
    }
    shift
}

/// One tetrahedron during construction: 32 bytes, aligned so that its vertices and
/// neighbour links share one cache line (the cavity search reads both together).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
struct Cell {
    /// Vertex ids; ghosts have [`INF`] last; `[DEAD, ..]` for free slots.
    v: [u32; 4],
    /// `t2 * 4 + j` across the face opposite vertex `i`.
    n: [u32; 4],
}

/// Construction state: flat arrays of tetrahedra and reused buffers.
struct Builder<'a> {
    pts: &'a [DVec3],
    /// The points as integers on one binary grid, when they share one (lattices, UTM
    /// well data): exact predicates then skip the per-call float-to-integer conversion.
    grid: Option<Grid>,
    /// With a grid (where co-spherical ties are common): the lexicographic rank of each
    /// vertex, so the symbolic perturbation compares integers. Empty otherwise.
    lex_rank: Vec<u32>,
    /// The tetrahedra, vertices and neighbour links side by side.
    cells: Vec<Cell>,
    free: Vec<u32>,
    /// Bit per tetrahedron: in the current cavity.
    in_cavity: Vec<u64>,
    /// Bit per tetrahedron: tested against the current point and not in conflict.
    tested: Vec<u64>,
    cavity: Vec<u32>,
    tested_list: Vec<u32>,
    /// New tetrahedra: vertices, apex position, link to the outside of the cavity.
    pending: Vec<([u32; 4], u32, u32)>,
    new_tets: Vec<u32>,
    edge_table: Vec<(u64, u32)>,
    last: u32,
    rng: u64,
}

#[inline]
fn bit(bits: &[u64], t: u32) -> bool {
    bits[(t >> 6) as usize] & (1u64 << (t & 63)) != 0
}

#[inline]
fn set_bit(bits: &mut [u64], t: u32, on: bool) {
    let w = &mut bits[(t >> 6) as usize];
    if on {
        *w |= 1u64 << (t & 63);
    } else {
        *w &= !(1u64 << (t & 63));
    }
}

impl<'a> Builder<'a> {
    #[allow(clippy::type_complexity)]
    fn run(
        pts: &'a [DVec3],
        progress: &dyn Progress,
    ) -> Result<(Vec<[u32; 4]>, Vec<[u32; 4]>), TetError> {
        let first = initial_simplex(pts)?;
        // Uniform points give ~6.7 tetrahedra per point; pages are touched only when used.
        let estimate = pts.len().saturating_mul(7) + 64;
        let mut b = Builder {
            pts,
            grid: None,
            lex_rank: Vec::new(),
            cells: Vec::with_capacity(estimate),
            free: Vec::new(),
            // Sized once for the estimate (zeroed pages are not resident until written):
            // growing them step by step would leave the outgrown copies resident.
            in_cavity: vec![0; estimate.div_ceil(64)],
            tested: vec![0; estimate.div_ceil(64)],
            cavity: Vec::new(),
            tested_list: Vec::new(),
            pending: Vec::new(),
            new_tets: Vec::new(),
            edge_table: Vec::new(),
            last: 0,
            rng: 0x2545_F491_4F6C_DD1D,
        };
        b.grid = Grid::new(pts);
        if b.grid.is_some() {
            b.lex_rank = lex_ranks(pts);
        }
        b.start(first);
        let total = pts.len();
        for v in 0..total as u32 {
            if (v as usize).is_multiple_of(CHECK_EVERY) {
                if progress.is_cancelled() {
                    return Err(TetError::Cancelled);
                }
                progress.report("tetrahedralize", v as f64 / total as f64);
            }
            if !first.contains(&v) {
                b.insert(v);
            }
        }
        progress.report("tetrahedralize", 1.0);
        let cells = std::mem::take(&mut b.cells);
        drop(b);
        Ok(Builder::finish(cells))
    }

    #[inline]
    fn p(&self, v: u32) -> DVec3 {
        self.pts[v as usize]
    }

    /// [`predicates::orient`] of four vertices.
    #[inline]
    fn orient(&self, a: u32, b: u32, c: u32, d: u32) -> Sign {
        if let Some(g) = &self.grid
            && g.orient_is_cheap()
        {
            let (pa, pb, pc, pd) = (self.p(a), self.p(b), self.p(c), self.p(d));
            return Sign::of(f64::from(g.orient(pa, pb, pc, pd)));
        }
        let (pa, pb, pc, pd) = (self.p(a), self.p(b), self.p(c), self.p(d));
        if let Some(s) = predicates::orient_filter(pa, pb, pc, pd) {
            return s;
        }
        match &self.grid {
            Some(g) => Sign::of(f64::from(g.orient(pa, pb, pc, pd))),
            None => predicates::orient_exact(pa, pb, pc, pd),
        }
    }

    /// [`predicates::insphere`] of five vertices.
    #[inline]
    fn insphere(&self, [a, b, c, d]: [u32; 4], e: u32) -> Sign {
        let (pa, pb, pc, pd, pe) = (self.p(a), self.p(b), self.p(c), self.p(d), self.p(e));
        if let Some(s) = predicates::insphere_filter(pa, pb, pc, pd, pe) {
            return s;
        }
        match &self.grid {
            Some(g) => Sign::of(f64::from(g.insphere(pa, pb, pc, pd, pe))),
            None => predicates::insphere_exact(pa, pb, pc, pd, pe),
        }
    }

    /// [`predicates::in_sphere_perturbed`] of the positive tetrahedron `t` and vertex `q`.
    fn in_sphere_perturbed(&self, t: [u32; 4], q: u32) -> bool {
        match self.insphere(t, q) {
            Sign::Positive => return true,
            Sign::Negative => return false,
            Sign::Zero => {}
        }
        let ids = [t[0], t[1], t[2], t[3], q];
        let greater = |i: usize, k: usize| {
            if self.lex_rank.is_empty() {
                predicates::lex_cmp(self.p(ids[i]), self.p(ids[k])) == Ordering::Greater
            } else {
                self.lex_rank[ids[i] as usize] > self.lex_rank[ids[k] as usize]
            }
        };
        let mut done = [false; 5];
        for _ in 0..5 {
            let mut k = 5;
            for (i, &is_done) in done.iter().enumerate() {
                if !is_done && (k == 5 || greater(i, k)) {
                    k = i;
                }
            }
            done[k] = true;
            if k == 4 {
                return false;
            }
            let mut r = t;
            r[k] = q;
            match self.orient(r[0], r[1], r[2], r[3]) {
                Sign::Positive => return true,
                Sign::Negative => return false,
                Sign::Zero => {}
            }
        }
        false
    }

    #[inline]
    fn next_random(&mut self) -> u32 {
        // xorshift64
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        (self.rng >> 32) as u32
    }

    fn alloc(&mut self) -> u32 {
        if let Some(t) = self.free.pop() {
            return t;
        }
        let t = self.cells.len() as u32;
        self.cells.push(Cell {
            v: [DEAD; 4],
            n: [NO_NEIGHBOUR; 4],
        });
        let words = self.cells.len().div_ceil(64);
        if self.in_cavity.len() < words {
            self.in_cavity.resize(words, 0);
            self.tested.resize(words, 0);
        }
        t
    }

    /// The first tetrahedron and its four ghosts.
    fn start(&mut self, [a, b, c, d]: [u32; 4]) {
        let (a, b) = if self.orient(a, b, c, d) == Sign::Positive {
            (a, b)
        } else {
            (b, a)
        };
        let finite = [a, b, c, d];
        let t0 = self.alloc();
        self.cells[t0 as usize].v = finite;
        for f in 0..4 {
            let g = self.alloc();
            let mut tv = finite;
            tv[f] = INF;
            // Swapping two other vertices puts the infinite vertex outside the face.
            tv.swap((f + 1) % 4, (f + 2) % 4);
            // Ghosts keep the infinite vertex last (two swaps keep the orientation).
            if f != 3 {
                tv.swap(f, 3);
                let others: Vec<usize> = (0..3).filter(|&i| i != f).collect();
                tv.swap(others[0], others[1]);
            }
            self.cells[g as usize].v = tv;
        }
        // Match the 20 faces pairwise.
        let faces: Vec<([u32; 3], u32)> = (0..5u32)
            .flat_map(|t| (0..4u32).map(move |i| (t, i)))
            .map(|(t, i)| {
                let tv = self.cells[t as usize].v;
                let mut key = [0u32; 3];
                let mut n = 0;
                for (k, &v) in tv.iter().enumerate() {
                    if k as u32 != i {
                        key[n] = v;
                        n += 1;
                    }
                }
                key.sort_unstable();
                (key, t * 4 + i)
            })
            .collect();
        for x in &faces {
            for y in &faces {
                if x.0 == y.0 && x.1 >> 2 != y.1 >> 2 {
                    self.cells[(x.1 >> 2) as usize].n[(x.1 & 3) as usize] = y.1;
                }
            }
        }
        self.last = t0;
    }

    /// Does vertex `v` conflict with tetrahedron `t` (inside its perturbed circumsphere,
    /// or for a ghost, strictly beyond its hull face or on it inside the face's
    /// circumcircle)?
    #[inline]
    fn conflict(&self, t: u32, v: u32) -> bool {
        let tv = self.cells[t as usize].v;
        if tv[3] == INF {
            match self.orient(tv[0], tv[1], tv[2], v) {
                Sign::Positive => true,
                Sign::Negative => false,
                Sign::Zero => {
                    let [a, b, c] = [tv[0], tv[1], tv[2]].map(|u| self.p(u));
                    predicates::in_circle_coplanar_perturbed(a, b, c, self.p(v))
                }
            }
        } else {
            self.in_sphere_perturbed(tv, v)
        }
    }

    /// Visibility walk from the last created tetrahedron to one in conflict with vertex
    /// `q`: a finite tetrahedron containing `q`, or a ghost whose hull face `q` is strictly
    /// beyond. The face the walk came through is not tested again.
    fn locate(&mut self, q: u32) -> u32 {
        let mut t = self.last;
        if self.cells[t as usize].v[3] == INF {
            t = self.cells[t as usize].n[3] >> 2;
        }
        let mut from = 4;
        'walk: loop {
            let cell = self.cells[t as usize];
            if cell.v[3] == INF {
                return t;
            }
            let start = self.next_random();
            for s in 0..4u32 {
                let f = ((start + s) & 3) as usize;
                if f == from {
                    continue;
                }
                let mut r = cell.v;
                r[f] = q;
                if self.orient(r[0], r[1], r[2], r[3]) == Sign::Negative {
                    let link = cell.n[f];
                    t = link >> 2;
                    from = (link & 3) as usize;
                    continue 'walk;
                }
            }
            return t;
        }
    }

    /// Inserts vertex `v`: grows the conflict cavity breadth-first and stars it from `v`,
    /// writing the new tetrahedra over the cavity's slots first.
    fn insert(&mut self, v: u32) {
        let t0 = self.locate(v);
        self.cavity.clear();
        self.tested_list.clear();
        self.pending.clear();
        set_bit(&mut self.in_cavity, t0, true);
        self.cavity.push(t0);
        let mut i = 0;
        while i < self.cavity.len() {
            let t = self.cavity[i];
            i += 1;
            let cell = self.cells[t as usize];
            for f in 0..4 {
                let link = cell.n[f];
                let t2 = link >> 2;
                if bit(&self.in_cavity, t2) {
                    continue;
                }
                if !bit(&self.tested, t2) {
                    if self.conflict(t2, v) {
                        set_bit(&mut self.in_cavity, t2, true);
                        self.cavity.push(t2);
                        continue;
                    }
                    set_bit(&mut self.tested, t2, true);
                    self.tested_list.push(t2);
                }
                let mut tv = cell.v;
                tv[f] = v;
                self.pending.push((tv, f as u32, link));
            }
        }
        for k in 0..self.tested_list.len() {
            set_bit(&mut self.tested, self.tested_list[k], false);
        }
        for k in 0..self.cavity.len() {
            set_bit(&mut self.in_cavity, self.cavity[k], false);
        }
        self.new_tets.clear();
        for k in 0..self.pending.len() {
            let (tv, f, link) = self.pending[k];
            let s = if k < self.cavity.len() {
                self.cavity[k]
            } else {
                self.alloc()
            };
            self.cells[s as usize] = Cell {
                v: tv,
                n: [NO_NEIGHBOUR; 4],
            };
            self.cells[s as usize].n[f as usize] = link;
            self.cells[(link >> 2) as usize].n[(link & 3) as usize] = s * 4 + f;
            self.new_tets.push(s);
        }
        for k in self.pending.len()..self.cavity.len() {
            let t = self.cavity[k];
            self.cells[t as usize].v[0] = DEAD;
            self.free.push(t);
        }
        self.link_new_tets();
        self.last = self
            .new_tets
            .iter()
            .copied()
            .find(|&s| self.cells[s as usize].v[3] != INF)
            .unwrap_or(self.new_tets[0]);
    }

    /// Links the new tetrahedra to each other: two of them share a face through the new
    /// vertex exactly when they share the cavity-boundary edge opposite it.
    fn link_new_tets(&mut self) {
        /// For the new vertex at position `f`: the three faces through it (opposite `j`)
        /// and the two positions of the edge each is keyed by.
        const FACES_THROUGH: [[(u32, usize, usize); 3]; 4] = [
            [(1, 2, 3), (2, 1, 3), (3, 1, 2)],
            [(0, 2, 3), (2, 0, 3), (3, 0, 2)],
            [(0, 1, 3), (1, 0, 3), (3, 0, 1)],
            [(0, 1, 2), (1, 0, 2), (2, 0, 1)],
        ];
        let size = (self.new_tets.len() * 4).next_power_of_two().max(16);
        if self.edge_table.len() < size {
            self.edge_table.resize(size, (EMPTY, 0));
        }
        let mask = size - 1;
        self.edge_table[..size].fill((EMPTY, 0));
        for k in 0..self.new_tets.len() {
            let s = self.new_tets[k];
            let (tv, apex, _) = self.pending[k];
            for &(j, a, b) in &FACES_THROUGH[apex as usize] {
                let (x, y) = (tv[a], tv[b]);
                let key = (u64::from(x.min(y)) << 32) | u64::from(x.max(y));
                let mut h = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40) as usize & mask;
                loop {
                    let (slot_key, slot_link) = self.edge_table[h];
                    if slot_key == EMPTY {
                        self.edge_table[h] = (key, s * 4 + j);
                        break;
                    }
                    if slot_key == key {
                        self.cells[s as usize].n[j as usize] = slot_link;
                        self.cells[(slot_link >> 2) as usize].n[(slot_link & 3) as usize] =
                            s * 4 + j;
                        break;
                    }
                    h = (h + 1) & mask;
                }
            }
        }
    }

    /// Strips ghosts and free slots in place (moving tetrahedra from the end into holes)
    /// and returns the finite tetrahedra with hull faces marked [`NO_NEIGHBOUR`], as the
    /// two arrays of a [`TetMesh`]. The construction array is released from its end while
    /// the outputs fill from theirs, so memory stays near 32 bytes per tetrahedron.
    fn finish(mut cells: Vec<Cell>) -> (Vec<[u32; 4]>, Vec<[u32; 4]>) {
        for t in 0..cells.len() {
            if cells[t].v[0] == DEAD {
                continue;
            }
            if cells[t].v[3] == INF {
                let link = cells[t].n[3];
                cells[(link >> 2) as usize].n[(link & 3) as usize] = NO_NEIGHBOUR;
                cells[t].v[0] = DEAD;
            }
        }
        let live = cells.iter().filter(|c| c.v[0] != DEAD).count();
        let mut top = cells.len();
        for d in 0..live {
            if cells[d].v[0] != DEAD {
                continue;
            }
            loop {
                top -= 1;
                if cells[top].v[0] != DEAD {
                    break;
                }
            }
            cells[d] = cells[top];
            for i in 0..4 {
                let link = cells[d].n[i];
                if link != NO_NEIGHBOUR {
                    cells[(link >> 2) as usize].n[(link & 3) as usize] = d as u32 * 4 + i as u32;
                }
            }
        }
        cells.truncate(live);
        cells.shrink_to_fit();
        // Zeroed outputs are not resident until written.
        let mut tets = vec![[0u32; 4]; live];
        let mut nbrs = vec![[0u32; 4]; live];
        const CHUNK: usize = 1 << 16;
        let mut end = live;
        while end > 0 {
            let start = end.saturating_sub(CHUNK);
            for t in start..end {
                tets[t] = cells[t].v;
                nbrs[t] = cells[t].n;
            }
            cells.truncate(start);
            cells.shrink_to_fit();
            end = start;
        }
        (tets, nbrs)
    }
}

/// The rank of each point in the lexicographic order of `(x, y, z)` (distinct points).
fn lex_ranks(pts: &[DVec3]) -> Vec<u32> {
    use rayon::prelude::*;
    let mut sorted: Vec<u32> = (0..pts.len() as u32).collect();
    sorted.par_sort_unstable_by(|&i, &j| predicates::lex_cmp(pts[i as usize], pts[j as usize]));
    let mut rank = vec![0u32; pts.len()];
    for (k, &v) in sorted.iter().enumerate() {
        rank[v as usize] = k as u32;
    }
    rank
}

/// Four affinely independent vertices, the first ones in insertion order (vertex ids), so
/// the first tetrahedron comes from the first BRIO round.
fn initial_simplex(pts: &[DVec3]) -> Result<[u32; 4], TetError> {
    let p = |v: u32| pts[v as usize];
    let n = pts.len() as u32;
    let (a, b) = (0, 1);
    let c = (2..n)
        .find(|&c| !predicates::collinear(p(a), p(b), p(c)))
        .ok_or(TetError::AllCoplanar)?;
    let d = (2..n)
        .find(|&d| predicates::orient(p(a), p(b), p(c), p(d)) != Sign::Zero)
        .ok_or(TetError::AllCoplanar)?;
    Ok([a, b, c, d])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn in_place_permutation_and_inverse_match_the_copying_versions() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for n in [1usize, 2, 3, 64, 65, 1000] {
            // A random permutation (Fisher-Yates with xorshift).
            let mut order: Vec<u32> = (0..n as u32).collect();
            for i in (1..n).rev() {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                order.swap(i, (state % (i as u64 + 1)) as usize);
            }
            let items: Vec<u64> = (0..n as u64).map(|i| i * 7 + 3).collect();
            let expected: Vec<u64> = order.iter().map(|&k| items[k as usize]).collect();
            let mut inverse = vec![0u32; n];
            for (k, &v) in order.iter().enumerate() {
                inverse[v as usize] = k as u32;
            }
            let mut done = vec![0u64; n.div_ceil(64)];
            let mut permuted = items.clone();
            permute_in_place(&mut permuted, &order, &mut done);
            assert_eq!(permuted, expected);
            done.fill(0);
            invert_in_place(&mut order, &mut done);
            assert_eq!(order, inverse);
        }
    }
}
