//! The checks of a gait optimization's request, before any work.

use super::evaluate::Setup;
use super::fourier::FourierGait;
use super::{GaitOptimization, MAX_EVALUATIONS, Measure, Order};
use crate::geometry::{Geometry, GeometryError};
use crate::model::Model;

/// Checks the request before any work, and builds the evaluation's setup.
pub(super) fn check<M: Model>(g: &Geometry<M>, problem: &GaitOptimization) -> Result<Setup, GeometryError> {
    let fail = |reason: String| Err(GeometryError::Request { reason });
    let ns = g.n_shape();
    if ns == 0 {
        return Err(GeometryError::Model {
            reason: format!(
                "model {} has no shape coordinates (no hinges): there is no gait to optimize",
                g.info().name
            ),
        });
    }
    if !g.is_kinematic() {
        return Err(GeometryError::Model {
            reason: format!(
                "model {}: its skates leave {} momentum component(s) free ({}), so a cycle's net motion depends on more than the gait's curve; gait optimization over the geometry takes kinematic systems (three independent skate rows); a mixed system's gait is optimized over its simulated gait, its drives' Fourier coefficients a design (`design::gait::DriveGait`)",
                g.info().name,
                g.n_momentum(),
                g.momentum_names().join(", ")
            ),
        });
    }
    let start = &problem.start;
    if start.n_shape() != ns {
        return fail(format!(
            "the start gait has {} shape coordinates; the model has {ns} ({})",
            start.n_shape(),
            g.shape_names().join(", ")
        ));
    }
    // the fields are public: the start's own checks again
    FourierGait::new(start.coefficients.clone(), start.order, start.period)?;
    let nc = ns * start.per_coordinate();
    if problem.free.len() != nc {
        return fail(format!("`free` has {} entries for the start's {nc} coefficients", problem.free.len()));
    }
    let free: Vec<usize> = (0..nc).filter(|&j| problem.free[j]).collect();
    if free.is_empty() {
        return fail("every coefficient is held: nothing to optimize".into());
    }
    let limit = problem.coefficient_limit;
    if !(limit.is_finite() && limit > 0.0) {
        return fail(format!("coefficient limit {limit}: give a positive number of radians"));
    }
    let flat = start.flat();
    if let Some(&j) = free.iter().find(|&&j| flat[j].abs() > limit) {
        return fail(format!(
            "the start's {} = {} is beyond the coefficient limit +-{}",
            start.coefficient_label(&g.shape_names(), j),
            flat[j],
            crate::names::fmt_value(limit)
        ));
    }
    if problem.objective.order == Order::Second && ns != 2 {
        return fail(format!(
            "the second order takes two shape coordinates (the bracket's area integral); the model has {ns}"
        ));
    }
    if let Measure::Along([x, y]) = problem.objective.measure
        && !(x.is_finite() && y.is_finite() && x.hypot(y) > 0.0)
    {
        return fail(format!("direction ({x}, {y}): give a finite, nonzero vector"));
    }
    let metric = metric(problem.metric.as_deref(), ns)?;
    bounds(g, &problem.bounds)?;
    if let Some(m) = problem.margin
        && !(m > 0.0 && m < 1.0)
    {
        return fail(format!("rank margin {m}: give a number in (0, 1) (the margin is a ratio of singular values)"));
    }
    if let Some(b) = problem.budget
        && !(b.is_finite() && b > 0.0)
    {
        return fail(format!("path length budget {b}: give a positive number of radians"));
    }
    if !(2..=MAX_EVALUATIONS).contains(&problem.max_evaluations) {
        return fail(format!(
            "a budget of {} evaluations: give between 2 and {MAX_EVALUATIONS}",
            problem.max_evaluations
        ));
    }
    if !(problem.xtol > 0.0 && problem.xtol < 1.0) {
        return fail(format!("xtol {}: give a number of radians in (0, 1)", problem.xtol));
    }
    Ok(Setup {
        ns,
        omega: start.omega(),
        period: start.period,
        base: flat,
        free,
        samples: (40 * start.order).max(200),
        metric,
        goal: problem.objective,
        margin_gradients: problem.margin.is_some(),
    })
}

/// The cost's metric: the identity, or `given` checked symmetric
/// positive definite (by Cholesky).
fn metric(given: Option<&[f64]>, ns: usize) -> Result<Vec<f64>, GeometryError> {
    let Some(m) = given else {
        return Ok((0..ns * ns).map(|k| if k % (ns + 1) == 0 { 1.0 } else { 0.0 }).collect());
    };
    let fail = |why: String| {
        Err(GeometryError::Request {
            reason: format!(
                "the cost's metric: {why}; it must be symmetric positive definite, else a gait could grow along a direction of zero cost and the cost would not bound it"
            ),
        })
    };
    if m.len() != ns * ns {
        return fail(format!("{} entries for {ns} shape coordinates ({} wanted)", m.len(), ns * ns));
    }
    if let Some(k) = m.iter().position(|v| !v.is_finite()) {
        return fail(format!("entry {k} is {}", m[k]));
    }
    let top = m.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    for i in 0..ns {
        for j in 0..i {
            if (m[i * ns + j] - m[j * ns + i]).abs() > 1e-12 * top {
                return fail(format!("entries ({i}, {j}) and ({j}, {i}) differ"));
            }
        }
    }
    // Cholesky: every pivot > 0 (relative to the largest entry)
    let mut l = m.to_vec();
    for j in 0..ns {
        let d = l[j * ns + j] - (0..j).map(|k| l[j * ns + k] * l[j * ns + k]).sum::<f64>();
        if d.partial_cmp(&(1e-12 * top)) != Some(std::cmp::Ordering::Greater) {
            return fail(format!("it is not positive definite (pivot {j} is {d:.3e})"));
        }
        let d = d.sqrt();
        l[j * ns + j] = d;
        for i in j + 1..ns {
            l[i * ns + j] = (l[i * ns + j] - (0..j).map(|k| l[i * ns + k] * l[j * ns + k]).sum::<f64>()) / d;
        }
    }
    Ok(m.to_vec())
}

/// Checks the ranges: at most one per shape coordinate, finite, lower
/// below upper.
fn bounds<M: Model>(g: &Geometry<M>, bounds: &[Option<(f64, f64)>]) -> Result<(), GeometryError> {
    let names = g.shape_names();
    if bounds.len() > names.len() {
        return Err(GeometryError::Request {
            reason: format!("{} ranges for {} shape coordinates", bounds.len(), names.len()),
        });
    }
    for (k, b) in bounds.iter().enumerate() {
        if let Some((lo, hi)) = *b
            && !(lo.is_finite() && hi.is_finite() && lo < hi)
        {
            return Err(GeometryError::Request {
                reason: format!(
                    "the range of {}: [{lo}, {hi}]; give finite bounds, the lower below the upper",
                    names[k]
                ),
            });
        }
    }
    Ok(())
}
