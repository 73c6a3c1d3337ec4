//! The tables `ezy geometry` writes: connection.csv, curvature.csv,
//! momentum.csv, gait.csv and gait-path.csv.

use ezy_core::AnyModel;
use ezy_core::geometry::Geometry;

use super::Found;
use crate::output::csv::{number, record};
use crate::output::transaction::{Transaction, TransactionError};

/// Every file this command may write (retired before the new ones).
pub(super) const FILES: &[&str] = &["connection.csv", "curvature.csv", "momentum.csv", "gait.csv", "gait-path.csv"];

/// A derivative's name: `alpha1` -> `alpha1d`.
fn rate(name: &str) -> String {
    format!("{name}d")
}

/// Writes the tables of `found` into `tx`.
///
/// # Errors
/// The transaction's.
pub(super) fn write(tx: &mut Transaction, geo: &Geometry<AnyModel>, found: &Found) -> Result<(), TransactionError> {
    tx.retire(&FILES.iter().map(|s| (*s).to_string()).collect::<Vec<_>>());
    let names = geo.shape_names();
    let (ns, m) = (names.len(), geo.n_momentum());
    let pnames = geo.momentum_names();
    // connection.csv: the shape, A row by row, Gamma row by row, the margin
    let mut head = names.clone();
    for c in ["u", "v", "w"] {
        head.extend(names.iter().map(|s| format!("A_{c}_{s}")));
    }
    for c in ["u", "v", "w"] {
        head.extend(pnames.iter().map(|p| format!("Gamma_{c}_{p}")));
    }
    head.push("rank_margin".into());
    let mut text = record(head);
    let ok = || found.shapes.iter().zip(&found.curvature).filter_map(|(r, c)| c.as_ref().ok().map(|c| (r, c)));
    for (r, c) in ok() {
        let mut cells: Vec<String> = r.iter().map(|v| number(*v)).collect();
        cells.extend(c.connection.a.iter().map(|v| number(*v)));
        cells.extend(c.connection.gamma.iter().map(|v| number(*v)));
        cells.push(number(c.connection.rank_margin));
        text.push_str(&record(cells));
    }
    tx.write("connection.csv", text.as_bytes())?;
    // curvature.csv: the height functions of every pair
    if ns >= 2 {
        let mut head = names.clone();
        for i in 0..ns {
            for j in i + 1..ns {
                for c in ["x", "y", "theta"] {
                    head.push(format!("DA_{c}_{}_{}", names[i], names[j]));
                }
            }
        }
        let mut text = record(head);
        for (r, c) in ok() {
            let mut cells: Vec<String> = r.iter().map(|v| number(*v)).collect();
            cells.extend(c.height.iter().flat_map(|h| h.iter().map(|v| number(*v))));
            text.push_str(&record(cells));
        }
        tx.write("curvature.csv", text.as_bytes())?;
    }
    // momentum.csv: p_j' = sum c z_a z_b, z = [r', p]
    if m > 0 {
        let mut z: Vec<String> = names.iter().map(|s| rate(s)).collect();
        z.extend(pnames.iter().cloned());
        let mut head = names.clone();
        if let Some(terms) = found.momentum.iter().find(|t| !t.is_empty()) {
            for p in &pnames {
                head.extend(terms.iter().map(|t| format!("{p}:{}*{}", z[t.a], z[t.b])));
            }
        }
        let mut text = record(head);
        for (r, terms) in found.shapes.iter().zip(&found.momentum) {
            if terms.is_empty() {
                continue;
            }
            let mut cells: Vec<String> = r.iter().map(|v| number(*v)).collect();
            for j in 0..m {
                cells.extend(terms.iter().map(|t| number(t.value[j])));
            }
            text.push_str(&record(cells));
        }
        tx.write("momentum.csv", text.as_bytes())?;
    }
    // gait.csv and gait-path.csv
    if let Some((gait, p, sim)) = &found.gait {
        let mut head = vec!["method".to_string(), "dx".into(), "dy".into(), "dtheta".into()];
        head.extend(pnames.iter().map(|n| format!("{n}_end")));
        let mut text = record(head);
        // one row per method; the momentum at the end where it has one
        let mut row = |label: &str, v: &[f64; 3], pend: Option<&[f64]>| {
            let mut cells = vec![label.to_string()];
            cells.extend(v.iter().map(|x| number(*x)));
            match pend {
                Some(pend) => cells.extend(pend.iter().map(|x| number(*x))),
                None => cells.extend(std::iter::repeat_n(String::new(), m)),
            }
            text.push_str(&record(cells));
        };
        row("first-order", &p.first, None);
        if let Some(s) = &p.second {
            row("second-order", s, None);
        }
        row("reconstructed", &p.reconstructed, Some(&p.momentum.1));
        if let Ok(s) = sim {
            row("simulated", &s.net, Some(&s.momentum));
        }
        tx.write("gait.csv", text.as_bytes())?;
        let mut head = vec!["t".to_string()];
        head.extend(names.iter().cloned());
        head.extend(["x_reconstructed", "y_reconstructed", "theta_reconstructed"].map(String::from));
        if sim.is_ok() {
            head.extend(["x_simulated", "y_simulated", "theta_simulated"].map(String::from));
        }
        let mut text = record(head);
        for (i, pt) in p.path.iter().enumerate() {
            let (r, _) = gait.at(pt[0]);
            let mut cells = vec![number(pt[0])];
            cells.extend(r.iter().map(|v| number(*v)));
            cells.extend(pt[1..].iter().map(|v| number(*v)));
            if let Ok(s) = sim {
                match s.path.get(i) {
                    Some(q) => cells.extend(q[1..].iter().map(|v| number(*v))),
                    None => cells.extend(std::iter::repeat_n(String::new(), 3)),
                }
            }
            text.push_str(&record(cells));
        }
        tx.write("gait-path.csv", text.as_bytes())?;
    }
    Ok(())
}
