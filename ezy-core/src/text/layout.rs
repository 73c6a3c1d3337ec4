//! Where a model read from text has its elements at given family counts:
//! each family's range, each item's first column of `q`, row of `G` and
//! entry of its pattern (what `model!` generates as `__ezy_layout`, here
//! computed once per change of a count and kept with the model).

use super::plan::{BodyAt, Plan, PointAt};

/// Offsets of every item at some counts.
#[derive(Clone, Debug, Default)]
pub(super) struct Layout {
    /// The counts' values.
    pub(super) counts: Vec<i64>,
    pub(super) f_start: Vec<i64>,
    pub(super) f_len: Vec<usize>,
    pub(super) body_off: Vec<usize>,
    pub(super) body_index: Vec<usize>,
    pub(super) point_index: Vec<usize>,
    pub(super) row: Vec<usize>,
    pub(super) val: Vec<usize>,
    pub(super) item_index: Vec<usize>,
    pub(super) nq: usize,
    pub(super) nc: usize,
    pub(super) nh: usize,
    pub(super) nnz: usize,
    pub(super) nnz_h: usize,
    pub(super) n_bodies: usize,
    pub(super) n_points: usize,
}

impl Layout {
    /// The layout of `plan` at `counts` (one per count, in order).
    pub(super) fn new(plan: &Plan, counts: &[i64]) -> Self {
        let mut l = Layout { counts: counts.to_vec(), ..Layout::default() };
        for fam in &plan.families {
            let (start, end) = (fam.start.at(0, counts), fam.end.at(0, counts));
            l.f_start.push(start);
            l.f_len.push(usize::try_from(end.saturating_sub(start)).unwrap_or(0));
        }
        let (mut off, mut bi) = (0usize, 0usize);
        for b in &plan.bodies {
            let n = l.len(b.family);
            l.body_off.push(off);
            l.body_index.push(bi);
            off = off.saturating_add(n.saturating_mul(3));
            bi = bi.saturating_add(n);
        }
        let mut pi = 0usize;
        for p in &plan.points {
            l.point_index.push(pi);
            pi = pi.saturating_add(l.len(p.family));
        }
        let (mut row, mut val, mut kinds) = (0usize, 0usize, [0usize; 4]);
        for g in &plan.groups {
            let n = l.len(g.family);
            let k = g.kind as usize;
            l.row.push(row);
            l.val.push(val);
            l.item_index.push(kinds[k]);
            row = row.saturating_add(g.rows.saturating_mul(n));
            val = val.saturating_add(g.pattern.len().saturating_mul(n));
            kinds[k] = kinds[k].saturating_add(n);
            if g.holonomic() {
                (l.nh, l.nnz_h) = (row, val);
            }
        }
        (l.nq, l.n_bodies, l.n_points, l.nc, l.nnz) = (off, bi, pi, row, val);
        l
    }

    /// Number of elements of an item of `family` (1 for a single item).
    pub(super) fn len(&self, family: Option<usize>) -> usize {
        family.map_or(1, |f| self.f_len[f])
    }

    /// `(e, v)` for each element of an item of `family`: its position and
    /// its index value (`(0, 0)` once for a single item).
    pub(super) fn elements(&self, family: Option<usize>) -> impl Iterator<Item = (usize, i64)> + use<> {
        let (start, len) = family.map_or((0, 1), |f| (self.f_start[f], self.f_len[f]));
        (0..len).map(move |e| (e, start + e as i64))
    }

    /// Position of a body element in its family at loop value `v` (0 for
    /// a single body); outside `0..len` where a count makes it refer to an
    /// element that does not exist (`check_counts` refuses those).
    fn body_pos(&self, plan: &Plan, b: &BodyAt, v: i64) -> i64 {
        match (plan.bodies[b.item].family, &b.index) {
            (Some(f), Some(ix)) => ix.at(v, &self.counts) - self.f_start[f],
            _ => 0,
        }
    }

    /// First column of `q` of a body element at loop value `v`.
    pub(super) fn body_column(&self, plan: &Plan, b: &BodyAt, v: i64) -> usize {
        self.body_off[b.item] + 3 * self.body_pos(plan, b, v) as usize
    }

    /// Index of a body element among all bodies at loop value `v`.
    pub(super) fn body_index(&self, plan: &Plan, b: &BodyAt, v: i64) -> usize {
        self.body_index[b.item] + self.body_pos(plan, b, v) as usize
    }

    /// Index of a point element among all points at loop value `v`.
    pub(super) fn point_index(&self, plan: &Plan, p: &PointAt, v: i64) -> usize {
        let pos = match (plan.points[p.item].family, &p.index) {
            (Some(f), Some(ix)) => ix.at(v, &self.counts) - self.f_start[f],
            _ => 0,
        };
        self.point_index[p.item] + pos as usize
    }
}
