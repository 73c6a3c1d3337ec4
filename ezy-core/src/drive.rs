//! Drives: hinges whose angle follows a prescribed function of time `u(t)`
//! (rheonomic constraints, as in the Twistcar literature: Chakon & Or
//! 2017, see docs/physics.md §2 and §11). The macro emits
//! the row `phi_a - phi_b` of `phi(q)` and `G`; the runtime makes it
//! `phi_row(q) - u(t) = 0`, so the velocity constraint becomes
//! `G_row qd = u'(t)` and the acceleration constraint
//! `G_row qdd = -gamma_row + u''(t)`. The drive's torque is `tau = -lambda_row`
//! (`+tau` on the hinge's first body, as a motor) and its power `tau u'(t)`
//! is integrated into the work state `W_<drive>`, so the energy ledger
//! stays closed.

use crate::effects::waveform::Waveform;

/// A drive resolved against a model: its row and the prescribed angle.
#[derive(Debug, Clone, PartialEq)]
pub struct Drive {
    /// The model's drive name.
    pub name: String,
    /// Its row in `phi` and `G`.
    pub row: usize,
    /// The prescribed hinge angle `u(t)` \[rad\].
    pub angle: Waveform,
}

/// `phi[row] -= u(t)` for every drive: the rheonomic residual.
pub fn shift_positions(drives: &[Drive], t: f64, phi: &mut [f64]) {
    for d in drives {
        phi[d.row] -= d.angle.eval(t);
    }
}

/// `r[row] -= u'(t)` for every drive: the residual of `G qd = u'(t)`.
pub fn shift_velocities(drives: &[Drive], t: f64, r: &mut [f64]) {
    for d in drives {
        r[d.row] -= d.angle.eval3(t)[1];
    }
}

/// Checks that a prescribed angle is smooth over `[0, t_end]` \[s\]: no
/// `table` (its slope jumps at the knots), and a `spline` held at its
/// ends whose knots cover the run (past them its rate would jump to
/// zero); each term of a sum so.
///
/// # Errors
/// What is wrong, for the angle's key.
pub fn check_angle(angle: &Waveform, t_end: f64) -> Result<(), String> {
    match angle {
        Waveform::Table(_) => {
            Err("a table's slope jumps at its knots, which a prescribed motion cannot follow; give a `spline`".into())
        }
        Waveform::Sum(terms) => {
            angle.validate()?;
            terms
                .iter()
                .enumerate()
                .try_for_each(|(k, w)| check_angle(w, t_end).map_err(|e| format!("term {k} of the sum: {e}")))
        }
        Waveform::Spline(sp)
            if matches!(
                sp.data().extrapolate,
                crate::effects::waveform::Extrapolate::Hold | crate::effects::waveform::Extrapolate::None
            ) =>
        {
            let t = &sp.data().t;
            let (first, last) = (t[0], t[t.len() - 1]);
            if first > 0.0 || last < t_end {
                Err(format!(
                    "the spline's knots cover [{first}, {last}] s but the run covers [0, {t_end}] s; outside its knots the angle would stop abruptly (or give `extrapolate = \"linear\"` or `\"periodic\"`)"
                ))
            } else {
                Ok(())
            }
        }
        _ => angle.validate(),
    }
}
