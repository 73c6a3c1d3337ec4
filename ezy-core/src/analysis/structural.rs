//! Structural Floquet multipliers: the multipliers 1 that a scene's
//! structure makes exact at every parameter value, found and left out of
//! a periodic orbit's classification, of continuation and of the
//! bifurcation tests (where their rounding, `ln |mu| = +-1e-12`, was
//! taken for a multiplier crossing the unit circle at every step).
//!
//! A cyclic coordinate `q[k]` (an internal rotor's angle: nothing depends
//! on it, [`super::Analysis::symmetry`]) is shifted by the flow as it is
//! given: the period map `P` keeps its direction `e_k` (`P e_k = e_k`).
//! Where nothing else feels its rate either (a balanced rotor driven by a
//! torque given in time), a change of the rate `e_{nq+k}` only turns the
//! angle on by `T` per period: `P e_{nq+k} = e_{nq+k} + T e_k`. Both
//! directions span a subspace `P` keeps, a Jordan block of the
//! multiplier 1 (Marsden & Ratiu, *Introduction to Mechanics and
//! Symmetry*, §8.5 on cyclic variables; Seydel, *Practical Bifurcation and
//! Stability Analysis*, 3rd ed., §7.4 on trivial multipliers). The
//! multipliers that can change are those of the quotient by it.

use faer::Mat;

/// A multiplier 1 left out of an orbit's classification, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StructuralMultiplier {
    /// The coordinate (index into `q`) whose direction it belongs to.
    pub coordinate: usize,
    /// Whether it is the coordinate's rate (`qd[coordinate]`, nothing
    /// else feeling it) rather than the cyclic coordinate itself.
    pub rate: bool,
}

impl StructuralMultiplier {
    /// `1 (th: cyclic)` or `1 (thd: the rate of cyclic th, which nothing
    /// else feels)`, `coords` the model's coordinate names.
    pub fn describe(&self, coords: &[String]) -> String {
        let name = coords.get(self.coordinate).cloned().unwrap_or_else(|| format!("q{}", self.coordinate));
        if self.rate {
            format!("1 ({}: the rate of cyclic {name}, which nothing else feels)", crate::names::velocity_name(&name))
        } else {
            format!("1 ({name}: cyclic)")
        }
    }
}

/// How far a unit direction may lie outside the constraints' tangent
/// space, or a column of the period map from the Jordan block's form,
/// and still count (relative to the map's size): the period map is
/// integrated to about 1e-11.
const TOL: f64 = 1e-7;

/// The structural directions of the period map `p` (2nq x 2nq, on the
/// state `[q, qd]`) for the cyclic coordinates `cyclic` (bit k: `q[k]`),
/// with `tangent` an orthonormal basis of the constraints' tangent space:
/// each cyclic coordinate's direction (in the tangent space), and its
/// rate's where `P e_{nq+k} - e_{nq+k}` lies along `e_k`.
pub(crate) fn directions(p: &Mat<f64>, tangent: &Mat<f64>, cyclic: u64) -> (Vec<Vec<f64>>, Vec<StructuralMultiplier>) {
    let n2 = p.nrows();
    let nq = n2 / 2;
    let size = (0..n2).flat_map(|i| (0..n2).map(move |j| (i, j))).fold(1.0f64, |m, (i, j)| m.max(p[(i, j)].abs()));
    let unit = |k: usize| -> Vec<f64> { (0..n2).map(|i| if i == k { 1.0 } else { 0.0 }).collect() };
    // |e - T T^T e| for a unit e: its distance from the tangent space
    let outside = |k: usize| -> f64 {
        let c: Vec<f64> = (0..tangent.ncols()).map(|j| tangent[(k, j)]).collect();
        (0..n2)
            .map(|i| {
                let proj = (0..tangent.ncols()).map(|j| tangent[(i, j)] * c[j]).sum::<f64>();
                (if i == k { 1.0 } else { 0.0 }) - proj
            })
            .fold(0.0f64, |m, v| m.max(v.abs()))
    };
    let (mut dirs, mut found) = (Vec::new(), Vec::new());
    for k in (0..nq.min(64)).filter(|k| cyclic >> k & 1 == 1) {
        if outside(k) > TOL {
            continue;
        }
        dirs.push(unit(k));
        found.push(StructuralMultiplier { coordinate: k, rate: false });
        let s = nq + k;
        if outside(s) > TOL {
            continue;
        }
        let off = (0..n2)
            .filter(|&i| i != k)
            .map(|i| (p[(i, s)] - if i == s { 1.0 } else { 0.0 }).abs())
            .fold(0.0f64, f64::max);
        if off <= TOL * size {
            dirs.push(unit(s));
            found.push(StructuralMultiplier { coordinate: k, rate: true });
        }
    }
    (dirs, found)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rotor's angle and free rate (a Jordan block) are structural; a
    /// rate that the rest feels (a damped rotor's) is not.
    #[test]
    fn a_free_rotors_angle_and_rate_are_structural() {
        // q = (x, th), qd = (xd, thd): th cyclic (bit 1)
        let t = 2.0;
        let mut p = Mat::<f64>::identity(4, 4);
        p[(0, 0)] = 0.5;
        p[(1, 3)] = t;
        let tangent = Mat::<f64>::identity(4, 4);
        let (d, s) = directions(&p, &tangent, 0b10);
        assert_eq!(d.len(), 2);
        assert_eq!(
            s,
            vec![
                StructuralMultiplier { coordinate: 1, rate: false },
                StructuralMultiplier { coordinate: 1, rate: true }
            ]
        );
        let names = vec!["x".to_string(), "th".to_string()];
        assert_eq!(s[0].describe(&names), "1 (th: cyclic)");
        assert!(s[1].describe(&names).starts_with("1 (thd: the rate of cyclic th"));
        // the rate decays and moves x: only the angle is structural
        p[(3, 3)] = 0.9;
        p[(0, 3)] = 0.1;
        let (d, s) = directions(&p, &tangent, 0b10);
        assert_eq!((d.len(), s.len()), (1, 1));
        // a cyclic direction outside the tangent space is none
        let tangent = Mat::from_fn(4, 3, |i, j| if i == [0, 2, 3][j] { 1.0 } else { 0.0 });
        let (d, _) = directions(&p, &tangent, 0b10);
        assert!(d.is_empty());
    }
}
