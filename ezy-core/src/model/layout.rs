//! Where a model's elements sit at given family counts: each family's
//! range, each item's first column of `q`, row of `G` and entry of its
//! pattern, from its [`Description`] (what `model!` also generates as
//! `__ezy_layout` for its numeric functions, checked equal by
//! [`Layout::agrees`]; a model read from text computes it once per change
//! of a count and keeps it).

use ezy_lang::description::{BodyAt, Description, PointAt};
use ezy_lang::kinematics::Kind;

/// Offsets of every item at some counts.
#[derive(Clone, Debug, Default)]
pub(crate) struct Layout {
    /// The counts' values.
    pub(crate) counts: Vec<i64>,
    pub(crate) f_start: Vec<i64>,
    pub(crate) f_len: Vec<usize>,
    pub(crate) body_off: Vec<usize>,
    pub(crate) body_index: Vec<usize>,
    pub(crate) point_index: Vec<usize>,
    pub(crate) row: Vec<usize>,
    pub(crate) val: Vec<usize>,
    pub(crate) item_index: Vec<usize>,
    pub(crate) nq: usize,
    pub(crate) nc: usize,
    pub(crate) nh: usize,
    pub(crate) nnz: usize,
    pub(crate) nnz_h: usize,
    pub(crate) n_bodies: usize,
    pub(crate) n_points: usize,
}

impl Layout {
    /// The layout of `desc` at `counts` (one per count, in order).
    pub(crate) fn new(desc: &Description, counts: &[i64]) -> Self {
        let mut l = Layout { counts: counts.to_vec(), ..Layout::default() };
        for fam in desc.families.iter() {
            let (start, end) = (fam.start.at(0, counts), fam.end.at(0, counts));
            l.f_start.push(start);
            l.f_len.push(usize::try_from(end.saturating_sub(start)).unwrap_or(0));
        }
        let (mut off, mut bi) = (0usize, 0usize);
        for b in desc.bodies.iter() {
            let n = l.len(b.family);
            l.body_off.push(off);
            l.body_index.push(bi);
            off = off.saturating_add(n.saturating_mul(3));
            bi = bi.saturating_add(n);
        }
        let mut pi = 0usize;
        for p in desc.points.iter() {
            l.point_index.push(pi);
            pi = pi.saturating_add(l.len(p.family));
        }
        let (mut row, mut val, mut kinds) = (0usize, 0usize, [0usize; Kind::COUNT]);
        for g in desc.groups.iter() {
            let n = l.len(g.family);
            let k = g.item.kind().index();
            l.row.push(row);
            l.val.push(val);
            l.item_index.push(kinds[k]);
            row = row.saturating_add(g.rows.saturating_mul(n));
            val = val.saturating_add(g.pattern.len().saturating_mul(n));
            kinds[k] = kinds[k].saturating_add(n);
            if g.item.holonomic() {
                (l.nh, l.nnz_h) = (row, val);
            }
        }
        (l.nq, l.n_bodies, l.n_points, l.nc, l.nnz) = (off, bi, pi, row, val);
        l
    }

    /// Number of elements of an item of `family` (1 for a single item).
    pub(crate) fn len(&self, family: Option<usize>) -> usize {
        family.map_or(1, |f| self.f_len[f])
    }

    /// `(e, v)` for each element of an item of `family`: its position and
    /// its index value (`(0, 0)` once for a single item).
    pub(crate) fn elements(&self, family: Option<usize>) -> impl Iterator<Item = (usize, i64)> + use<> {
        let (start, len) = family.map_or((0, 1), |f| (self.f_start[f], self.f_len[f]));
        (0..len).map(move |e| (e, start + e as i64))
    }

    /// Position of a body element in its family at loop value `v` (0 for
    /// a single body); outside `0..len` where a count makes it refer to an
    /// element that does not exist (`check_counts` refuses those).
    fn body_pos(&self, desc: &Description, b: &BodyAt, v: i64) -> i64 {
        match (desc.bodies[b.item].family, &b.index) {
            (Some(f), Some(ix)) => ix.at(v, &self.counts) - self.f_start[f],
            _ => 0,
        }
    }

    /// First column of `q` of a body element at loop value `v`.
    pub(crate) fn body_column(&self, desc: &Description, b: &BodyAt, v: i64) -> usize {
        self.body_off[b.item] + 3 * self.body_pos(desc, b, v) as usize
    }

    /// Index of a body element among all bodies at loop value `v`.
    pub(crate) fn body_index(&self, desc: &Description, b: &BodyAt, v: i64) -> usize {
        self.body_index[b.item] + self.body_pos(desc, b, v) as usize
    }

    /// Index of a point element among all points at loop value `v`.
    pub(crate) fn point_index(&self, desc: &Description, p: &PointAt, v: i64) -> usize {
        let pos = match (desc.points[p.item].family, &p.index) {
            (Some(f), Some(ix)) => ix.at(v, &self.counts) - self.f_start[f],
            _ => 0,
        };
        self.point_index[p.item] + pos as usize
    }

    /// Whether `generated`, a compiled model's `__ezy_layout` at the same
    /// counts, is this layout.
    ///
    /// # Errors
    /// The first field that differs, with both values.
    pub(crate) fn agrees<const NF: usize, const NB: usize, const NP: usize, const NG: usize>(
        &self,
        generated: &super::info::Layout<NF, NB, NP, NG>,
    ) -> Result<(), String> {
        let g = generated;
        let lists: [(&str, Vec<i64>, Vec<i64>); 8] = [
            ("f_start", self.f_start.clone(), g.f_start.to_vec()),
            ("f_len", wide(&self.f_len), wide(&g.f_len)),
            ("body_off", wide(&self.body_off), wide(&g.body_off)),
            ("body_index", wide(&self.body_index), wide(&g.body_index)),
            ("point_index", wide(&self.point_index), wide(&g.point_index)),
            ("row", wide(&self.row), wide(&g.row)),
            ("val", wide(&self.val), wide(&g.val)),
            ("item_index", wide(&self.item_index), wide(&g.item_index)),
        ];
        let sizes = [
            ("nq", self.nq, g.nq),
            ("nc", self.nc, g.nc),
            ("nh", self.nh, g.nh),
            ("nnz", self.nnz, g.nnz),
            ("nnz_h", self.nnz_h, g.nnz_h),
            ("n_bodies", self.n_bodies, g.n_bodies),
            ("n_points", self.n_points, g.n_points),
        ];
        let differs = lists.iter().find(|(_, a, b)| a != b).map(|(n, a, b)| format!("{n}: {a:?} against {b:?}"));
        let differs =
            differs.or_else(|| sizes.iter().find(|(_, a, b)| a != b).map(|(n, a, b)| format!("{n}: {a} against {b}")));
        match differs {
            None => Ok(()),
            Some(d) => {
                Err(format!("the description's layout and `__ezy_layout` differ at counts {:?}: {d}", self.counts))
            }
        }
    }
}

/// Offsets as `i64`, to compare with the family starts in one list.
fn wide(xs: &[usize]) -> Vec<i64> {
    xs.iter().map(|&x| x as i64).collect()
}
