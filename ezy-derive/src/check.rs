//! Validation of a parsed model. Every error is spanned at the user's token
//! and all of them are reported at once (after serde_derive's `Ctxt`).

use std::collections::HashMap;

use syn::Ident;

use crate::ast::{HingeTarget, ModelDef};

/// Collects errors; `finish` combines them into one.
#[derive(Default)]
pub struct Errors {
    first: Option<syn::Error>,
    count: usize,
}

impl Errors {
    /// Adds an error.
    pub fn push(&mut self, e: syn::Error) {
        self.count += 1;
        match &mut self.first {
            Some(first) => first.combine(e),
            None => self.first = Some(e),
        }
    }
    /// Number of errors so far.
    pub fn count(&self) -> usize {
        self.count
    }
    /// Adds an error at `tokens`.
    pub fn at<T: quote::ToTokens>(&mut self, tokens: T, msg: impl std::fmt::Display) {
        self.push(syn::Error::new_spanned(tokens, msg));
    }
    /// `Err` with every error pushed so far, if any.
    pub fn finish(self) -> syn::Result<()> {
        self.first.map_or(Ok(()), Err)
    }
}

/// Names resolved to indices.
pub struct Resolved {
    /// Body index of every point.
    pub point_body: Vec<usize>,
    /// Points joined by every hinge (second is `None` for the ground).
    pub hinge_points: Vec<(usize, Option<usize>)>,
    /// Points of every slider: the moving point and the guiding point
    /// (`None` for a ground line).
    pub slider_points: Vec<(usize, Option<usize>)>,
    /// Hinge (index) of every drive.
    pub drive_hinge: Vec<usize>,
    /// Contact point of every skate.
    pub skate_point: Vec<usize>,
}

fn check_unique<'a>(errs: &mut Errors, kind: &str, names: impl Iterator<Item = &'a Ident>) {
    let mut seen: HashMap<String, &Ident> = HashMap::new();
    for n in names {
        if seen.insert(n.to_string(), n).is_some() {
            errs.at(n, format!("duplicate {kind} name `{n}`"));
        }
    }
}

fn known(names: &[String]) -> String {
    if names.is_empty() { "none".to_string() } else { names.join(", ") }
}

/// Checks names and references; returns the resolved indices.
pub fn check(def: &ModelDef, errs: &mut Errors) -> Resolved {
    check_unique(errs, "parameter", def.params.iter().map(|p| &p.name));
    check_unique(errs, "body", def.bodies.iter().map(|b| &b.name));
    check_unique(errs, "point", def.points.iter().map(|p| &p.name));
    check_unique(errs, "hinge", def.hinges.iter().map(|h| &h.name));
    check_unique(errs, "skate", def.skates.iter().map(|s| &s.name));
    check_unique(
        errs,
        "joint or drive",
        def.hinges
            .iter()
            .map(|h| &h.name)
            .chain(def.sliders.iter().map(|s| &s.name))
            .chain(def.drives.iter().map(|d| &d.name)),
    );
    check_unique(errs, "coordinate", def.bodies.iter().flat_map(|b| b.coords.iter()));
    for p in &def.params {
        if !p.value.is_finite() {
            errs.push(syn::Error::new(p.value_span, format!("parameter `{}` must be finite", p.name)));
        }
    }
    if def.bodies.is_empty() {
        errs.at(
            &def.name,
            format!("model `{}` has no body; add `body NAME(x, y, phi) {{ mass: .., inertia: .. }}`", def.name),
        );
    }
    let body_names: Vec<String> = def.bodies.iter().map(|b| b.name.to_string()).collect();
    let point_names: Vec<String> = def.points.iter().map(|p| p.name.to_string()).collect();
    let point_body: Vec<usize> = def
        .points
        .iter()
        .map(|p| {
            body_names.iter().position(|b| p.body == b).unwrap_or_else(|| {
                errs.at(
                    &p.body,
                    format!(
                        "point `{}` refers to unknown body `{}`; known bodies: {}",
                        p.name,
                        p.body,
                        known(&body_names)
                    ),
                );
                usize::MAX
            })
        })
        .collect();
    let find_point = |errs: &mut Errors, owner: &str, name: &Ident| -> usize {
        point_names.iter().position(|p| name == p).unwrap_or_else(|| {
            errs.at(name, format!("{owner} refers to unknown point `{name}`; known points: {}", known(&point_names)));
            usize::MAX
        })
    };
    // the two points a joint relates: distinct, on different bodies
    let joint = |errs: &mut Errors, kind: &str, name: &Ident, point: &Ident, target: &HingeTarget| {
        let owner = format!("{kind} `{name}`");
        let a = find_point(errs, &owner, point);
        let b = match target {
            HingeTarget::Point(p) => {
                let b = find_point(errs, &owner, p);
                if a != usize::MAX && b != usize::MAX {
                    if a == b {
                        errs.at(p, format!("{kind} `{name}` joins point `{p}` to itself"));
                    } else if point_body[a] != usize::MAX && point_body[a] == point_body[b] {
                        errs.at(
                            p,
                            format!(
                                "{kind} `{name}` joins two points of the same body `{}`; a {kind} joins two bodies (or a body and `ground(x, y)`)",
                                body_names[point_body[a]]
                            ),
                        );
                    }
                }
                Some(b)
            }
            HingeTarget::Ground { .. } => None,
        };
        (a, b)
    };
    let hinge_points = def.hinges.iter().map(|h| joint(errs, "hinge", &h.name, &h.point, &h.target)).collect();
    let slider_points = def.sliders.iter().map(|s| joint(errs, "slider", &s.name, &s.point, &s.target)).collect();
    let hinge_names: Vec<String> = def.hinges.iter().map(|h| h.name.to_string()).collect();
    let drive_hinge = def
        .drives
        .iter()
        .map(|d| {
            hinge_names.iter().position(|h| d.hinge == h).unwrap_or_else(|| {
                errs.at(
                    &d.hinge,
                    format!(
                        "drive `{}` refers to unknown hinge `{}`; known hinges: {}",
                        d.name,
                        d.hinge,
                        known(&hinge_names)
                    ),
                );
                usize::MAX
            })
        })
        .collect();
    let skate_point = def.skates.iter().map(|s| find_point(errs, &format!("skate `{}`", s.name), &s.point)).collect();
    Resolved { point_body, hinge_points, slider_points, drive_hinge, skate_point }
}
