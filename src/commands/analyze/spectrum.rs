//! The spectra `ezy analyze` prints, said in words: each multiplier 1
//! (or eigenvalue 0) attributed to its cause (the plane's rigid motions,
//! a cyclic coordinate, its free rate, an autonomous cycle's time shift,
//! the family of solutions through this one), the verdict on the rest,
//! and a multiplier below what the period map's integration resolves
//! printed as unresolved rather than as a value. Trivial multipliers:
//! Seydel, *Practical Bifurcation and Stability Analysis*, 3rd ed., §7.4;
//! cyclic variables: Marsden & Ratiu, *Introduction to Mechanics and
//! Symmetry*, §8.5.

use ezy_core::analysis::{Generator, PeriodicOrbit, Stability, c64};

use crate::session::{complex, complex_to};

/// `ln |mu|` within this of 0 counts as on the unit circle, as the
/// orbit's classification counts it (`Stability::of_multipliers`).
const ON_CIRCLE: f64 = 1e-6;

/// The indices of the `n` smallest of `keys` (ties in order), as the
/// classification leaves out the family's `n` nearest the neutral value.
fn nearest(keys: impl Iterator<Item = f64>, n: usize) -> Vec<usize> {
    let mut order: Vec<(usize, f64)> = keys.enumerate().collect();
    order.sort_by(|a, b| a.1.total_cmp(&b.1));
    order.into_iter().take(n).map(|(i, _)| i).collect()
}

/// A steady motion's eigenvalues \[1/s\] as printed, the `family` ones
/// nearest the imaginary axis marked as the family's (a change of speed
/// or of a conserved quantity that leads to a neighbouring steady motion,
/// not a perturbation that grows or decays).
pub(super) fn steady_eigenvalues(eigenvalues: &[c64], family: usize) -> Vec<String> {
    let marked = nearest(eigenvalues.iter().map(|z| z.re.abs()), family);
    eigenvalues
        .iter()
        .enumerate()
        .map(|(i, z)| {
            let text = complex(*z);
            if marked.contains(&i) { format!("{text} (along the family of steady motions)") } else { text }
        })
        .collect()
}

/// A periodic orbit's multipliers as printed, at `decimals` decimals:
/// the family's marked, and any whose modulus is below `resolution`
/// (the period map's tolerance) times the largest modulus (at least 1)
/// printed `< 1e-11 (unresolved)`: its variational equations are
/// integrated to about that, so its digits are noise (a multiplier of
/// 1.6e-15 was printed 1.2e-13). One that rounds to 0 at `decimals` but
/// is resolved is printed in exponent form to the digits it holds above
/// that level.
pub(super) fn multipliers(p: &PeriodicOrbit, decimals: usize, resolution: f64) -> Vec<String> {
    let top = p.multipliers.iter().fold(1.0f64, |m, z| m.max(z.re.hypot(z.im)));
    let floor = resolution * top;
    let family = nearest(p.multipliers.iter().map(|z| z.re.hypot(z.im).max(1e-300).ln().abs()), p.family);
    p.multipliers
        .iter()
        .enumerate()
        .map(|(i, z)| {
            let text = multiplier(*z, decimals, floor);
            if family.contains(&i) { format!("{text} (along the family of orbits)") } else { text }
        })
        .collect()
}

/// One multiplier: `< 1e-11 (unresolved)` below `floor`; in exponent
/// form where it rounds to 0 at `decimals`; else to `decimals`.
fn multiplier(z: c64, decimals: usize, floor: f64) -> String {
    let modulus = z.re.hypot(z.im);
    if !modulus.is_finite() {
        return "not finite (unresolved)".to_string();
    }
    if modulus < floor {
        // the power of ten at or above the floor (1e-11 for 1e-11)
        return format!("< 1e{} (unresolved)", (floor.log10() - 1e-9).ceil() as i32);
    }
    if (modulus * 10f64.powi(decimals.min(6) as i32)).round() != 0.0 {
        return complex_to(z, decimals);
    }
    // the digits above the floor: 2 for 2.13e-10 over 1e-11
    let digits = ((modulus / floor).log10().floor() as usize + 1).clamp(1, 6) - 1;
    let part = |v: f64| format!("{v:.digits$e}");
    if z.im.abs() < floor {
        part(z.re)
    } else {
        format!("{}{}{}i", part(z.re), if z.im < 0.0 { "-" } else { "+" }, part(z.im.abs()))
    }
}

/// The verdict on the multipliers printed (the family's left out), in
/// words: `all 2 multipliers inside the unit circle`, `1 multiplier
/// outside the unit circle`, `none outside the unit circle, 1 on it`.
pub(super) fn verdict(p: &PeriodicOrbit) -> String {
    let family = nearest(p.multipliers.iter().map(|z| z.re.hypot(z.im).max(1e-300).ln().abs()), p.family);
    let rates: Vec<f64> = p
        .multipliers
        .iter()
        .enumerate()
        .filter(|(i, _)| !family.contains(i))
        .map(|(_, z)| z.re.hypot(z.im).max(1e-300).ln())
        .collect();
    let outside = rates.iter().filter(|r| **r > ON_CIRCLE).count();
    let on = rates.iter().filter(|r| r.abs() <= ON_CIRCLE).count();
    match p.stability {
        _ if rates.is_empty() => "no multiplier left to decide".to_string(),
        Stability::Stable => format!("all {} {} inside the unit circle", rates.len(), plural(rates.len())),
        Stability::Unstable => format!("{outside} {} outside the unit circle", plural(outside)),
        Stability::Neutral => format!("none outside the unit circle, {on} on it"),
    }
}

/// `multiplier` or `multipliers`.
fn plural(n: usize) -> &'static str {
    if n == 1 { "multiplier" } else { "multipliers" }
}

/// The multipliers 1 the scene's structure makes exact, each with its
/// cause: the plane's rigid motions (the orbit repeats moved by one, so
/// moving it gives the same orbit moved), each cyclic coordinate and
/// the free rate of one, and an autonomous cycle's time shift (the
/// flow's own direction); `none` where there are none.
pub(super) fn ones(p: &PeriodicOrbit, limit_cycle: bool, coords: &[String]) -> String {
    let mut out: Vec<String> = p.structural.iter().map(|m| m.describe(coords)).collect();
    out.extend(p.symmetry.generators().into_iter().filter_map(|g| match g {
        Generator::TranslateX => Some("1 (x: the plane's translation)".to_string()),
        Generator::TranslateY => Some("1 (y: the plane's translation)".to_string()),
        Generator::Rotate => Some("1 (heading: the plane's rotation)".to_string()),
        Generator::Shift(_) => None,
    }));
    if limit_cycle {
        out.push("1 (the time shift: the cycle started later is the same cycle)".to_string());
    }
    if out.is_empty() { "none".to_string() } else { out.join(", ") }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each form at hand-worked values: a resolved multiplier to the
    /// decimals, a small resolved one to its digits above the floor, one
    /// below the floor unresolved, and one not finite said so.
    #[test]
    fn a_multiplier_is_printed_to_what_it_holds() {
        let z = |re: f64| c64::new(re, 0.0);
        assert_eq!(multiplier(z(0.4968737), 6, 1e-11), "0.496874");
        assert_eq!(multiplier(z(2.1298697e-10), 6, 1e-11), "2.1e-10");
        assert_eq!(multiplier(z(3.7e-8), 6, 1e-11), "3.700e-8");
        assert_eq!(multiplier(z(7.43e-13), 6, 1e-11), "< 1e-11 (unresolved)");
        assert_eq!(multiplier(z(7.43e-13), 6, 2e-11), "< 1e-10 (unresolved)");
        assert_eq!(multiplier(z(f64::NAN), 6, 1e-11), "not finite (unresolved)");
        assert_eq!(multiplier(c64::new(1e-9, -2e-9), 6, 1e-11), "1.00e-9-2.00e-9i");
        assert_eq!(nearest([3.0, 0.5, 1.0].into_iter(), 2), vec![1, 2]);
    }
}
