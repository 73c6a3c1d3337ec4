//! The straight-line form of a model without families: every derived
//! expression renamed from its item's local coordinates to the global
//! ones (`q[3 b + k]` for body `b`), with `G`'s global pattern. What
//! `model!` emits as straight-line code and what a model read from text
//! evaluates as one tape per function, built here once so that both
//! evaluate the same expressions in the same order (the same numbers,
//! bit for bit).

use std::collections::HashMap;

use crate::ast::ModelDef;
use crate::check::{BodyRef, Resolved};
use crate::kinematics::Derived;
use crate::sym::{Arena, Id, Sym};

/// Straight-line form: every output renamed to global coordinates (a
/// model without families: all columns are known at compile time).
pub struct Straight {
    /// `G` entries in pattern order, `phi` rows, `gamma` rows, point
    /// positions and velocities (x, y per point), all global.
    pub values: Vec<Id>,
    pub phi: Vec<Id>,
    pub gamma: Vec<Id>,
    pub points: Vec<Id>,
    pub vel: Vec<Id>,
    /// `G`'s structural nonzeros `(row, column)`, row-major per item.
    pub pattern: Vec<(usize, usize)>,
    /// Coordinates and constraint rows.
    pub nq: usize,
    pub nc: usize,
}

/// Every output of `d` renamed to global coordinates (new nodes in the
/// arena), with `G`'s global pattern.
pub fn straight_form(d: &mut Derived, def: &ModelDef, res: &Resolved) -> Straight {
    let body_col = |b: &BodyRef| 3 * b.0;
    let mut st = Straight {
        values: Vec::new(),
        phi: Vec::new(),
        gamma: Vec::new(),
        points: Vec::new(),
        vel: Vec::new(),
        pattern: Vec::new(),
        nq: 3 * def.bodies.len(),
        nc: 0,
    };
    let groups = std::mem::take(&mut d.groups);
    let mut row = 0;
    for g in &groups {
        let cols: Vec<usize> = g.slots.iter().map(body_col).collect();
        let rename = |s: Sym| match s {
            Sym::Q(k) => Sym::Q(cols[k / 3] + k % 3),
            Sym::Qd(k) => Sym::Qd(cols[k / 3] + k % 3),
            p => p,
        };
        let mut memo = HashMap::new();
        let mut sub = |ar: &mut Arena, id: Id| ar.subst(id, &rename, &mut memo);
        if g.holonomic() {
            for &p in &g.phi {
                let x = sub(&mut d.ar, p);
                st.phi.push(x);
            }
        }
        for (r, c) in g.local_pattern(&d.ar) {
            st.pattern.push((row + r, cols[c / 3] + c % 3));
            let x = sub(&mut d.ar, g.g[r][c]);
            st.values.push(x);
        }
        for &x in &g.gamma {
            let x = sub(&mut d.ar, x);
            st.gamma.push(x);
        }
        row += g.rows();
    }
    d.groups = groups;
    st.nc = row;
    for (pi, p) in d.points.iter().enumerate() {
        // a model without families: the point's body is a single body
        let col = 3 * res.point_body[pi];
        let rename = |s: Sym| match s {
            Sym::Q(k) => Sym::Q(col + k),
            Sym::Qd(k) => Sym::Qd(col + k),
            p => p,
        };
        let mut memo = HashMap::new();
        for k in 0..2 {
            let (a, b) = (p.pos[k], p.vel[k]);
            let a = d.ar.subst(a, &rename, &mut memo);
            let b = d.ar.subst(b, &rename, &mut memo);
            st.points.push(a);
            st.vel.push(b);
        }
    }
    st
}
