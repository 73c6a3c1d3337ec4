//! What a derived model says about itself, as plain data: its names
//! (coordinates, parameters, bodies, points, constraint items, row
//! suffixes), where each item's elements sit (families, body and point
//! references, rows, the pattern of `G`), what its counts must satisfy
//! (the references' index expressions as written, the directions checked
//! not zero) and its equations as pre-rendered templates.
//!
//! One writer for both back ends: `model!` writes a [`Description`] into
//! its expansion as a `static` literal (every [`Text`] and [`List`]
//! borrowed), a model read from text builds it at run time (owned), and
//! ezy-core's `model::describe` renders either into a `ModelInfo`, its
//! `check_counts` and its `equations` at the current counts.

use std::borrow::Cow;

use crate::ast::{Affine, ModelDef, doc_of, split_unit};
use crate::check::{PointRef, Resolved};
use crate::kinematics::{self, Derived, Kind, own_index};
use crate::sym::{Arena, Id, Sym};

/// A string that is either a literal of generated code or built at run
/// time.
pub type Text = Cow<'static, str>;

/// A list that is either a literal of generated code or built at run time.
pub type List<T> = Cow<'static, [T]>;

/// An integer index `var? + count? + c`: an [`Affine`] without its span,
/// its count by position.
#[derive(Clone, Debug, PartialEq)]
pub struct Ix {
    /// Whether the loop value of the item's family is added.
    pub var: bool,
    /// The count added, by its position among the counts.
    pub count: Option<usize>,
    /// The constant.
    pub c: i64,
    /// As written, with the family's variable (`i - 1`, `N`).
    pub shown: Text,
}

impl Ix {
    /// The value at loop value `v` and counts `counts` (one per count, in
    /// declaration order).
    pub fn at(&self, v: i64, counts: &[i64]) -> i64 {
        let mut x = self.c;
        if self.var {
            x += v;
        }
        if let Some(c) = self.count {
            x += counts[c];
        }
        x
    }
}

/// A body element: the body item (index into [`Description::bodies`])
/// and, for a family body, which element.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyAt {
    /// The body item.
    pub item: usize,
    /// Its element's index (a family body only).
    pub index: Option<Ix>,
}

/// A point element: the point item (index into [`Description::points`])
/// and, for a family point, which element.
#[derive(Clone, Debug, PartialEq)]
pub struct PointAt {
    /// The point item.
    pub item: usize,
    /// Its element's index (a family point only).
    pub index: Option<Ix>,
}

/// A `for` family: its elements `start..end` at the counts.
#[derive(Clone, Debug, PartialEq)]
pub struct Family {
    /// The first element's index.
    pub start: Ix,
    /// One past the last element's index.
    pub end: Ix,
    /// `START..END` as written.
    pub range: Text,
}

/// A parameter (a real) or a count, with its documentation.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    /// Its name, the generated struct's field.
    pub name: Text,
    /// The declared value.
    pub default: f64,
    /// The unit from the `[...]` at the end of its doc comment (`""` if
    /// none; always `""` for a count).
    pub unit: Text,
    /// Its doc comment without the unit.
    pub doc: Text,
    /// Whether it is a count.
    pub count: bool,
}

/// A parameter defined by an expression of others (`param I = m * r *
/// r;`): not settable, its expression stands wherever it is named.
#[derive(Clone, Debug, PartialEq)]
pub struct DerivedParam {
    /// Its name.
    pub name: Text,
    /// Its expression as written (tokens spaced: `m * r * r`).
    pub formula: Text,
    /// The unit from the `[...]` at the end of its doc comment (`""` if
    /// none).
    pub unit: Text,
    /// Its doc comment without the unit.
    pub doc: Text,
}

/// A derived expression for `ezy equations`: text and LaTeX templates
/// of the runtime's `render_equation` ([`crate::equation_templates`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Template {
    /// Plain text, with markers.
    pub text: Text,
    /// LaTeX, with markers.
    pub latex: Text,
    /// The family indices (`Sym::Index(k)`) the templates name, as
    /// [`crate::index_marker`]s to replace by the element's values.
    pub named: List<usize>,
    /// Where exactly one is named: the expression at that index's values
    /// 0, 1 and -1, simplified (`x - 0*L` is `x`), as `(text, latex)`;
    /// empty otherwise.
    pub at: List<(Text, Text)>,
}

/// A body item.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    /// Its name (a family element's index follows it: `link3`).
    pub name: Text,
    /// Its family, by index into [`Description::families`].
    pub family: Option<usize>,
    /// Its coordinates' names, `(x, y, phi)`.
    pub coords: [Text; 3],
    /// The parameter its mass is, if written as one.
    pub mass_param: Option<Text>,
    /// The parameter its inertia is, if written as one.
    pub inertia_param: Option<Text>,
    /// Its mass diagonal `(m, m, I)`.
    pub mass: List<Template>,
}

/// A point item.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// Its name.
    pub name: Text,
    /// Its family.
    pub family: Option<usize>,
    /// The body element it sits on (at loop value `v` for a family point).
    pub body: BodyAt,
    /// Its velocity `(x, y)` \[m/s\].
    pub velocity: List<Template>,
}

/// What a constraint item is, with the elements it names.
#[derive(Clone, Debug, PartialEq)]
pub enum Item {
    /// A hinge: its point on the first body, and the other body's (none
    /// for the ground).
    Hinge {
        /// The hinge's point (where it is drawn).
        point: PointAt,
        /// The other body's point.
        other: Option<PointAt>,
    },
    /// A slider (`heading`) or a slot: the moving point and the guiding
    /// one (none for a ground line).
    Slider {
        /// Whether the heading row exists (a slider, not a slot).
        heading: bool,
        /// The moving point.
        point: PointAt,
        /// The guiding point.
        other: Option<PointAt>,
    },
    /// A drive: the group of the hinge it drives (element `e` of a family
    /// drive drives element `e` of its hinge family).
    Drive {
        /// Index into [`Description::groups`].
        hinge_group: usize,
    },
    /// A skate: its contact point.
    Skate {
        /// The contact point.
        point: PointAt,
    },
}

impl Item {
    /// The item's kind in messages: "hinge", "slider", "slot", "drive" or
    /// "skate".
    pub fn word(&self) -> &'static str {
        match self {
            Item::Hinge { .. } => "hinge",
            Item::Slider { heading: false, .. } => "slot",
            Item::Slider { .. } => "slider",
            Item::Drive { .. } => "drive",
            Item::Skate { .. } => "skate",
        }
    }

    /// Its kind.
    pub fn kind(&self) -> Kind {
        match self {
            Item::Hinge { .. } => Kind::Hinge,
            Item::Slider { .. } => Kind::Slider,
            Item::Drive { .. } => Kind::Drive,
            Item::Skate { .. } => Kind::Skate,
        }
    }

    /// Whether its rows are holonomic (all but a skate's).
    pub fn holonomic(&self) -> bool {
        self.kind() != Kind::Skate
    }
}

/// A constraint item (single or a family): its rows of `G` per element.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    /// What it is.
    pub item: Item,
    /// Its name.
    pub name: Text,
    /// Its family.
    pub family: Option<usize>,
    /// The bodies it touches: slot `s` has local columns `3s..3s+3`.
    pub slots: List<BodyAt>,
    /// Values of `Sym::Index(k)` at an element.
    pub indices: List<Ix>,
    /// Rows per element.
    pub rows: usize,
    /// `(row, local column)` of its structural nonzeros, row-major.
    pub pattern: List<(usize, usize)>,
    /// Its rows' name suffixes (`.x`, `.y`; `.n`, `.phi`; `` for drives
    /// and skates).
    pub suffixes: List<&'static str>,
    /// Where its direction as written names the family's index, that
    /// direction's words in messages (``direction `along (c, s)` ``),
    /// checked not zero at every element.
    pub direction: Option<Text>,
    /// `phi` (holonomic items), the velocity rows, `G`'s values at the
    /// pattern and `gamma`, for `ezy equations`.
    pub phi: List<Template>,
    /// The velocity rows `G_i qd`.
    pub velocity: List<Template>,
    /// `G`'s values at [`Group::pattern`].
    pub jacobian: List<Template>,
    /// `gamma`.
    pub gamma: List<Template>,
}

/// Everything a model says about itself, for any counts.
#[derive(Clone, Debug, PartialEq)]
pub struct Description {
    /// The model's name.
    pub name: Text,
    /// The first sentence of its doc comment.
    pub doc: Text,
    /// The real parameters, then the counts.
    pub params: List<Param>,
    /// The parameters defined by expressions, in declaration order.
    pub derived: List<DerivedParam>,
    /// Its `for` families.
    pub families: List<Family>,
    /// Its bodies.
    pub bodies: List<Body>,
    /// Its points.
    pub points: List<Point>,
    /// Its constraint items, in row order.
    pub groups: List<Group>,
    /// A family element's own index, `i` (`Sym::Index(0)` of the masses
    /// and the points' velocities).
    pub own: Ix,
}

/// The index `a` of an item of family `f` (none: of no family), shown
/// with the family's variable.
fn ix(def: &ModelDef, a: &Affine, f: Option<usize>) -> Ix {
    let var = f.map(|f| def.families[f].var.to_string()).unwrap_or_default();
    let count = a.count.as_ref().map(|n| def.counts.iter().position(|c| c.name == *n).expect("checked count"));
    Ix { var: a.var, count, c: a.c, shown: a.show(&var).into() }
}

/// A point (by its item and index) named by an item of family `f`.
fn point_at(def: &ModelDef, (p, index): &PointRef, f: Option<usize>) -> PointAt {
    PointAt { item: *p, index: index.as_ref().map(|a| ix(def, a, f)) }
}

/// The templates of derived expressions, rendered in the order they are
/// asked for (the forms at fixed index values add nodes to a copy of the
/// arena, as the numbers of `ezy equations` have always been made).
struct Templates {
    ar: Arena,
}

impl Templates {
    /// The template of `id`, whose family indices are `n_indices`.
    fn of(&mut self, id: Id, n_indices: usize) -> Template {
        let (text, latex) = crate::equation_templates(&self.ar, id);
        let named: Vec<usize> = (0..n_indices)
            .filter(|&k| {
                let m = crate::index_marker(k);
                text.contains(&m) || latex.contains(&m)
            })
            .collect();
        let at = match named[..] {
            [k] => [0i64, 1, -1]
                .map(|v| {
                    let value = self.ar.cst(v as f64);
                    let at = self.ar.replace(id, &|s| (s == Sym::Index(k)).then_some(value), &mut Default::default());
                    let (t, x) = crate::equation_templates(&self.ar, at);
                    (Text::from(t), Text::from(x))
                })
                .to_vec(),
            _ => Vec::new(),
        };
        Template { text: text.into(), latex: latex.into(), named: named.into(), at: at.into() }
    }

    fn all(&mut self, ids: &[Id], n_indices: usize) -> List<Template> {
        ids.iter().map(|&id| self.of(id, n_indices)).collect::<Vec<_>>().into()
    }
}

/// The parameters, then the counts, with their documentation and units.
fn params(def: &ModelDef) -> Vec<Param> {
    let reals = def.params.iter().map(|p| {
        let (doc, unit) = split_unit(&doc_of(&p.attrs));
        Param { name: p.name.to_string().into(), default: p.value, unit: unit.into(), doc: doc.into(), count: false }
    });
    let counts = def.counts.iter().map(|c| {
        let (doc, _) = split_unit(&doc_of(&c.attrs));
        Param {
            name: c.name.to_string().into(),
            default: c.value as f64,
            unit: "".into(),
            doc: doc.into(),
            count: true,
        }
    });
    reals.chain(counts).collect()
}

/// What a constraint group is: its item and its name.
fn item_of(def: &ModelDef, res: &Resolved, d: &Derived, g: &kinematics::Group) -> (Text, Item) {
    let f = g.family;
    match g.kind {
        Kind::Hinge => {
            let (a, b) = &res.hinge_points[g.item];
            let other = b.as_ref().map(|b| point_at(def, b, f));
            (def.hinges[g.item].name.to_string().into(), Item::Hinge { point: point_at(def, a, f), other })
        }
        Kind::Slider => {
            let (a, b) = &res.slider_points[g.item];
            let other = b.as_ref().map(|b| point_at(def, b, f));
            let heading = def.sliders[g.item].heading;
            (def.sliders[g.item].name.to_string().into(), Item::Slider { heading, point: point_at(def, a, f), other })
        }
        Kind::Drive => {
            let h = res.drive_hinge[g.item];
            let hinge_group = d.groups.iter().position(|x| x.kind == Kind::Hinge && x.item == h).expect("hinge group");
            (def.drives[g.item].name.to_string().into(), Item::Drive { hinge_group })
        }
        Kind::Skate => {
            let point = point_at(def, &res.skate_point[g.item], f);
            (def.skates[g.item].name.to_string().into(), Item::Skate { point })
        }
    }
}

/// A group's direction's words in messages where its direction names the
/// family's index (`None` where there is nothing to check).
fn direction_words(def: &ModelDef, d: &Derived, g: &kinematics::Group) -> Option<Text> {
    let [tx, ty] = g.direction?;
    let index = |s: Sym| matches!(s, Sym::Index(_));
    if !(d.ar.mentions(tx, &index) || d.ar.mentions(ty, &index)) {
        return None;
    }
    let (word, along) = match g.kind {
        Kind::Skate => ("blade direction `along", &def.skates[g.item].along),
        _ => ("direction `along", &def.sliders[g.item].along),
    };
    let (ax, ay) = (&along[0], &along[1]);
    Some(format!("{word} ({}, {})`", quote::quote!(#ax), quote::quote!(#ay)).into())
}

/// The description of a checked and derived model.
pub fn describe(def: &ModelDef, res: &Resolved, d: &Derived) -> Description {
    let param_of = |e: &syn::Expr| match e {
        syn::Expr::Path(p) => p
            .path
            .get_ident()
            .filter(|id| def.params.iter().any(|q| q.name == **id))
            .map(|id| Text::from(id.to_string())),
        _ => None,
    };
    let mut templates = Templates { ar: d.ar.clone() };
    let families: Vec<Family> = def
        .families
        .iter()
        .enumerate()
        .map(|(f, fam)| Family {
            start: ix(def, &fam.start, Some(f)),
            end: ix(def, &fam.end, Some(f)),
            range: format!("{}..{}", fam.start.show(""), fam.end.show("")).into(),
        })
        .collect();
    // the templates in the order `ezy equations` lists them: masses,
    // each group's rows, the points' velocities
    let bodies: Vec<Body> = def
        .bodies
        .iter()
        .enumerate()
        .map(|(bi, b)| Body {
            name: b.name.to_string().into(),
            family: b.family,
            coords: b.coords.clone().map(|c| c.to_string().into()),
            mass_param: param_of(&b.mass),
            inertia_param: param_of(&b.inertia),
            mass: templates.all(&d.mass[bi], 1),
        })
        .collect();
    let groups: Vec<Group> = d.groups.iter().map(|g| group(def, res, d, g, &mut templates)).collect();
    let points: Vec<Point> = def
        .points
        .iter()
        .enumerate()
        .map(|(pi, p)| {
            let index = match p.family {
                Some(_) => Some(ix(def, &own_index(), p.family)),
                None => res.point_body_index[pi].as_ref().map(|a| ix(def, a, None)),
            };
            Point {
                name: p.name.to_string().into(),
                family: p.family,
                body: BodyAt { item: res.point_body[pi], index },
                velocity: templates.all(&d.points[pi].vel, 1),
            }
        })
        .collect();
    Description {
        name: def.name.to_string().into(),
        doc: doc_of(&def.attrs).split(". ").next().unwrap_or("").trim_end_matches('.').to_string().into(),
        params: params(def).into(),
        derived: def
            .derived
            .iter()
            .map(|d| {
                let (doc, unit) = split_unit(&doc_of(&d.attrs));
                let formula = quote::ToTokens::to_token_stream(&d.expr).to_string();
                DerivedParam {
                    name: d.name.to_string().into(),
                    formula: formula.into(),
                    unit: unit.into(),
                    doc: doc.into(),
                }
            })
            .collect::<Vec<_>>()
            .into(),
        families: families.into(),
        bodies: bodies.into(),
        points: points.into(),
        groups: groups.into(),
        own: ix(def, &own_index(), None),
    }
}

/// The description of one constraint group (its templates made with
/// `templates`, in the order `ezy equations` lists them).
fn group(def: &ModelDef, res: &Resolved, d: &Derived, g: &kinematics::Group, templates: &mut Templates) -> Group {
    let f = g.family;
    let (name, item) = item_of(def, res, d, g);
    let pattern = g.local_pattern(&d.ar);
    let n = g.indices.len();
    // an item without bodies has no equations (none is written so)
    let (phi, velocity, jacobian, gamma) = if g.slots.is_empty() {
        Default::default()
    } else {
        let phi = if g.holonomic() { templates.all(&g.phi, n) } else { List::default() };
        let velocity = templates.all(&g.velocity, n);
        let values: Vec<Id> = pattern.iter().map(|&(r, c)| g.g[r][c]).collect();
        (phi, velocity, templates.all(&values, n), templates.all(&g.gamma, n))
    };
    Group {
        item,
        name,
        family: f,
        slots: g.slots.iter().map(|b| BodyAt { item: b.0, index: b.1.as_ref().map(|a| ix(def, a, f)) }).collect(),
        indices: g.indices.iter().map(|a| ix(def, a, f)).collect(),
        rows: g.rows(),
        pattern: pattern.into(),
        suffixes: g.suffixes.clone().into(),
        direction: direction_words(def, d, g),
        phi,
        velocity,
        jacobian,
        gamma,
    }
}

#[cfg(test)]
mod tests {
    use super::{Description, Item, describe};

    /// A snake of `N` links whose blades turn with the link's index.
    const SNAKE: &str = "
        pub struct Snake {
            count N = 5;
            param l = 0.3;
            for i in 1..N + 1 {
                body link[i](x, y, phi) { mass: 1.0, inertia: 0.01 }
                point S[i] on link[i] at (0, 0);
                point B[i] on link[i] at (-l / 2, 0);
                point F[i] on link[i] at (l / 2, 0);
                skate S[i]: S[i] along (cos(i), sin(i));
            }
            for i in 2..N + 1 {
                hinge J[i]: B[i - 1] = F[i];
            }
        }";

    fn snake() -> Description {
        let m = crate::derive_text(SNAKE).unwrap_or_else(|e| panic!("{e}"));
        describe(&m.def, &m.resolved, &m.derived)
    }

    /// Every reference keeps its index as written, with the family's
    /// variable, and the range of its family; the hinge's points are
    /// `B[i - 1]` and `F[i]`.
    #[test]
    fn references_keep_their_indices_as_written() {
        let d = snake();
        assert_eq!(d.families.iter().map(|f| &*f.range).collect::<Vec<_>>(), ["1..N + 1", "2..N + 1"]);
        let j = d.groups.iter().find(|g| g.name == "J").expect("the hinge");
        let Item::Hinge { point, other: Some(other) } = &j.item else { panic!("J is a hinge to a body: {:?}", j.item) };
        let shown = |p: &super::PointAt| {
            (&*d.points[p.item].name, p.index.as_ref().map(|ix| ix.shown.to_string()).unwrap_or_default())
        };
        assert_eq!(shown(point), ("B", "i - 1".to_string()));
        assert_eq!(shown(other), ("F", "i".to_string()));
        let b = point.index.as_ref().expect("a family point");
        assert_eq!(b.at(4, &[5]), 3, "B[i - 1] at i = 4");
        assert_eq!((j.item.word(), j.family, j.rows, j.suffixes.to_vec()), ("hinge", Some(1), 2, vec![".x", ".y"]));
    }

    /// A blade that turns with the index is checked at every element and
    /// named as written; a template that names one index carries its
    /// forms at 0, 1 and -1, the index gone from them.
    #[test]
    fn an_index_in_a_direction_is_checked_and_rendered_per_element() {
        let d = snake();
        let s = d.groups.iter().find(|g| g.name == "S").expect("the skate");
        assert_eq!((s.item.word(), s.item.holonomic()), ("skate", false));
        let words = s.direction.as_deref().expect("a blade that names `i` is checked");
        assert!(words.starts_with("blade direction `along (cos"), "{words}");
        let j = d.groups.iter().find(|g| g.name == "J").expect("the hinge");
        assert!(j.direction.is_none());
        let mut one = 0;
        for t in s.velocity.iter().chain(s.jacobian.iter()).chain(j.phi.iter()) {
            match &t.named[..] {
                [k] => {
                    one += 1;
                    let marker = crate::index_marker(*k);
                    assert!(t.text.contains(&marker), "{}", t.text);
                    assert_eq!(t.at.len(), 3);
                    assert!(t.at.iter().all(|(x, l)| !x.contains(&marker) && !l.contains(&marker)), "{:?}", t.at);
                }
                _ => assert!(t.at.is_empty()),
            }
        }
        assert!(one > 0, "the skate's rows name `i`");
    }
}
