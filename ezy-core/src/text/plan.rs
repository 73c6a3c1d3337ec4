//! A derived model turned into data the runtime can hold (no syntax
//! tree, no span: plain indices, names and [`Tape`]s) and the layout of
//! its elements at given family counts, after ezy-derive's
//! `emit::layout`, which does the same in generated code.

use ezy_lang::Derivation;
use ezy_lang::ast::{Affine, ModelDef, doc_of, split_unit};
use ezy_lang::kinematics::{Kind, own_index};
use ezy_lang::sym::{Arena, Id};

use super::fused::Fused;
use super::tape::Tape;
use crate::model::info::ParamInfo;

/// An integer index `var? + count? + c` ([`Affine`] without its span).
#[derive(Clone, Debug)]
pub(super) struct Ix {
    var: bool,
    /// The count, by its position among the counts.
    count: Option<usize>,
    c: i64,
    /// As written, with the family's variable.
    pub(super) shown: String,
}

impl Ix {
    fn new(def: &ModelDef, a: &Affine, var: &str) -> Self {
        let count = a.count.as_ref().map(|n| def.counts.iter().position(|c| c.name == *n).expect("checked count"));
        Self { var: a.var, count, c: a.c, shown: a.show(var) }
    }

    /// The value at loop value `v` and counts `counts`.
    pub(super) fn at(&self, v: i64, counts: &[i64]) -> i64 {
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

/// A body element: the body item and, for a family body, which element.
#[derive(Clone, Debug)]
pub(super) struct BodyAt {
    pub(super) item: usize,
    pub(super) index: Option<Ix>,
}

/// A point element: the point item and, for a family point, which element.
#[derive(Clone, Debug)]
pub(super) struct PointAt {
    pub(super) item: usize,
    pub(super) index: Option<Ix>,
}

/// A `for` family.
#[derive(Clone, Debug)]
pub(super) struct Family {
    pub(super) start: Ix,
    pub(super) end: Ix,
    /// `START..END` as written.
    pub(super) range: String,
}

/// Most family indices one item's expressions may name (`i`, `i - 1`,
/// `N`, ...): an element's index values live on the stack.
pub(super) const MAX_INDICES: usize = 16;

/// Most bodies one constraint item touches (a joint's two).
pub(super) const MAX_SLOTS: usize = 4;

/// A body item.
#[derive(Debug)]
pub(super) struct BodyPlan {
    pub(super) name: String,
    pub(super) family: Option<usize>,
    pub(super) coords: [String; 3],
    pub(super) mass_param: Option<&'static str>,
    pub(super) inertia_param: Option<&'static str>,
    /// `(m, m, I)` with the own index as `Sym::Index(0)`.
    pub(super) mass: Tape,
    pub(super) mass_ids: [Id; 3],
}

/// A point item.
#[derive(Debug)]
pub(super) struct PointPlan {
    pub(super) name: String,
    pub(super) family: Option<usize>,
    /// The body element it sits on (at loop value `v` for a family point).
    pub(super) body: BodyAt,
    /// World position, velocity and body-frame offsets (2 each).
    pub(super) pos: Tape,
    pub(super) vel: Tape,
    pub(super) local: Tape,
    pub(super) vel_ids: [Id; 2],
}

/// What a constraint item is, with what `info` and `check_counts` need.
#[derive(Clone, Debug)]
pub(super) enum ItemKind {
    Hinge {
        point: PointAt,
        other: Option<PointAt>,
    },
    Slider {
        heading: bool,
        point: PointAt,
        other: Option<PointAt>,
    },
    /// The group of the hinge it drives.
    Drive {
        hinge_group: usize,
    },
    Skate {
        point: PointAt,
    },
}

/// A constraint item (single or a family): its element kernels.
#[derive(Debug)]
pub(super) struct GroupPlan {
    pub(super) kind: Kind,
    pub(super) item_kind: ItemKind,
    pub(super) name: String,
    pub(super) family: Option<usize>,
    pub(super) slots: Vec<BodyAt>,
    /// Values of `Sym::Index(k)` at an element.
    pub(super) indices: Vec<Ix>,
    pub(super) rows: usize,
    /// `(row, local column)` of its structural nonzeros, row-major.
    pub(super) pattern: Vec<(usize, usize)>,
    pub(super) suffixes: Vec<&'static str>,
    /// `phi`; `G`'s values; both; `G`'s values and `gamma`.
    pub(super) phi: Tape,
    pub(super) g: Tape,
    pub(super) phi_g: Tape,
    pub(super) terms: Tape,
    /// The direction as written `(tx, ty)` where it names the family's
    /// index (checked not zero at every element), with its text.
    pub(super) direction: Option<(Tape, String)>,
    /// For `ezy equations`: `phi`, the velocity rows, `G`'s values,
    /// `gamma`.
    pub(super) eq_phi: Vec<Id>,
    pub(super) eq_velocity: Vec<Id>,
    pub(super) eq_g: Vec<Id>,
    pub(super) eq_gamma: Vec<Id>,
}

impl GroupPlan {
    pub(super) fn holonomic(&self) -> bool {
        self.kind != Kind::Skate
    }

    /// "hinge", "slider", "slot", "drive" or "skate".
    pub(super) fn kind_word(&self) -> &'static str {
        match self.item_kind {
            ItemKind::Hinge { .. } => "hinge",
            ItemKind::Slider { heading: false, .. } => "slot",
            ItemKind::Slider { .. } => "slider",
            ItemKind::Drive { .. } => "drive",
            ItemKind::Skate { .. } => "skate",
        }
    }
}

/// A model without families as straight-line code over the global
/// coordinates, one tape per function (what `model!` emits for it, from
/// the same expressions in the same order: the same numbers, bit for
/// bit). The outputs of each tape in the order of the function's
/// arguments (`phi_g`: `phi`, then `G`'s values; `terms`: `G`'s values,
/// then `gamma`).
#[derive(Debug)]
pub(super) struct Straight {
    pub(super) phi: Tape,
    pub(super) jacobian: Tape,
    pub(super) g: Tape,
    pub(super) phi_g: Tape,
    pub(super) terms: Tape,
    pub(super) points: Tape,
    pub(super) vel: Tape,
    /// Every body's first column, `3 b` (the tapes' "slots").
    pub(super) cols: Vec<usize>,
    /// For each column `k` of `G` with nonzeros, `(k, [(entry, row)])` in
    /// the pattern's order: `v -= W^-1 G^T x` summed as `model!` sums it.
    pub(super) by_column: Vec<(usize, Vec<(usize, usize)>)>,
    /// `A = G W^-1 G^T`'s lower triangle summed as `model!` sums it: per
    /// entry `a[i nc + j]`, `j <= i`, its index and its terms
    /// `values[e1] * values[e2] * winv[k]` (a range of `normal_terms`).
    pub(super) normal: Vec<(usize, std::ops::Range<usize>)>,
    pub(super) normal_terms: Vec<[usize; 3]>,
    /// The minimal coordinates ezy-lang derived, or why there are none.
    pub(super) minimal: Result<MinimalPlan, String>,
}

/// Minimal coordinates of a model read from text: the layout's data and
/// the tapes of `minimal_expand` (eliminated coordinates, global rates,
/// `B`, `c` and the frames' cos and sin, in that order) and
/// `minimal_state` (the first two).
#[derive(Debug)]
pub(super) struct MinimalPlan {
    pub(super) coords: Vec<usize>,
    pub(super) speeds: Vec<usize>,
    /// `(skate, velocity index)` and the coefficients' tape.
    pub(super) pivots: Vec<(String, usize)>,
    pub(super) pivot_values: Tape,
    /// Where `q_dep`'s outputs go.
    pub(super) q_dep: Vec<usize>,
    pub(super) expand: Tape,
    pub(super) state: Tape,
    /// The fused right-hand side.
    pub(super) fused: Fused,
}

impl Straight {
    fn new(m: &mut Derivation) -> Self {
        let st = ezy_lang::straight::straight_form(&mut m.derived, &m.def, &m.resolved);
        let nh = st.phi.len();
        let nnz_h = st.pattern.iter().filter(|(r, _)| *r < nh).count();
        // after the straight-line form, as `model!` derives them
        let minimal =
            ezy_lang::minimal::derive(&mut m.derived.ar, &m.def, &m.resolved, &st.phi, &st.pattern, &st.values, st.nc)
                .map(|mm| {
                    // Maggi's terms for the fused right-hand side, the
                    // hinges in `ModelInfo::hinges`' order (no families: a
                    // body's slot is its index), as `model!` derives them
                    let mass: Vec<Id> = m.derived.mass.iter().flatten().copied().collect();
                    let hinges: Vec<(usize, Option<usize>)> = m
                        .derived
                        .groups
                        .iter()
                        .filter(|g| g.kind == Kind::Hinge)
                        .map(|g| (g.slots[0].0, g.slots.get(1).map(|b| b.0)))
                        .collect();
                    let maggi = ezy_lang::minimal::maggi(&mut m.derived.ar, &mm, &mass, &hinges);
                    let ar = &m.derived.ar;
                    let fused = Fused::new(ar, &mm, &maggi);
                    let mut outputs: Vec<Id> = mm.q_dep.iter().map(|p| p.1).collect();
                    outputs.extend(&mm.qd);
                    let state = Tape::new(ar, &outputs);
                    outputs.extend(&mm.b);
                    outputs.extend(&mm.c);
                    outputs.extend(&mm.frames);
                    MinimalPlan {
                        coords: mm.coords.clone(),
                        speeds: mm.speeds.clone(),
                        pivots: mm.pivots.iter().map(|(n, k, _)| (n.clone(), *k)).collect(),
                        pivot_values: Tape::new(ar, &mm.pivots.iter().map(|p| p.2).collect::<Vec<_>>()),
                        q_dep: mm.q_dep.iter().map(|p| p.0).collect(),
                        expand: Tape::new(ar, &outputs),
                        state,
                        fused,
                    }
                })
                .map_err(|why| format!("model {} has no minimal coordinates: {why}", m.def.name));
        let ar = &m.derived.ar;
        let nc = st.gamma.len();
        let rows: Vec<Vec<(usize, usize)>> = (0..nc)
            .map(|r| st.pattern.iter().enumerate().filter(|(_, p)| p.0 == r).map(|(e, p)| (e, p.1)).collect())
            .collect();
        let (mut normal, mut normal_terms) = (Vec::new(), Vec::new());
        for i in 0..nc {
            for j in 0..=i {
                let start = normal_terms.len();
                for &(e1, k) in &rows[i] {
                    normal_terms.extend(rows[j].iter().filter(|r| r.1 == k).map(|&(e2, _)| [e1, e2, k]));
                }
                normal.push((i * nc + j, start..normal_terms.len()));
            }
        }
        Self {
            phi: Tape::new(ar, &st.phi),
            jacobian: Tape::new(ar, &st.values[..nnz_h]),
            g: Tape::new(ar, &st.values),
            phi_g: Tape::new(ar, &[st.phi.as_slice(), &st.values].concat()).with_split(nh),
            terms: Tape::new(ar, &[st.values.as_slice(), &st.gamma].concat()).with_split(st.values.len()),
            points: Tape::new(ar, &st.points),
            vel: Tape::new(ar, &st.vel),
            cols: (0..st.nq / 3).map(|b| 3 * b).collect(),
            by_column: (0..st.nq)
                .map(|k| (k, st.pattern.iter().enumerate().filter(|(_, p)| p.1 == k).map(|(e, p)| (e, p.0)).collect()))
                .filter(|(_, entries): &(usize, Vec<(usize, usize)>)| !entries.is_empty())
                .collect(),
            normal,
            normal_terms,
            minimal,
        }
    }

    fn tapes(&self) -> impl Iterator<Item = &Tape> {
        let minimal =
            self.minimal.iter().flat_map(|m| [&m.pivot_values, &m.expand, &m.state].into_iter().chain(m.fused.tapes()));
        [&self.phi, &self.jacobian, &self.g, &self.phi_g, &self.terms, &self.points, &self.vel]
            .into_iter()
            .chain(minimal)
    }
}

/// Everything a [`super::RuntimeModel`] evaluates and describes.
#[derive(Debug)]
pub(super) struct Plan {
    pub(super) name: &'static str,
    pub(super) doc: &'static str,
    /// The real parameters, then the counts.
    pub(super) params: Vec<ParamInfo>,
    pub(super) n_real: usize,
    pub(super) families: Vec<Family>,
    pub(super) bodies: Vec<BodyPlan>,
    pub(super) points: Vec<PointPlan>,
    pub(super) groups: Vec<GroupPlan>,
    /// Each skate's blade direction: its group and `(tx, ty)`.
    pub(super) blades: Vec<(usize, Tape)>,
    /// The expressions, for `ezy equations`.
    pub(super) ar: Arena,
    /// Registers the largest tape needs.
    pub(super) registers: usize,
    /// A family element's own index, `i` (`Sym::Index(0)` of the masses,
    /// points and blades).
    pub(super) own: Ix,
    /// A model without families: its straight-line tapes.
    pub(super) straight: Option<Straight>,
    /// The machine code of the tapes' compiled kernels, once compiled (or
    /// why they could not be).
    pub(super) code: std::sync::OnceLock<Result<Code, String>>,
}

/// The JIT's code (nothing in a build without it).
#[cfg(feature = "jit")]
pub(super) type Code = super::tape::jit::Code;
#[cfg(not(feature = "jit"))]
#[derive(Debug)]
pub(super) struct Code;

/// An interned name that lives as long as the program: [`ParamInfo`] and
/// [`crate::ModelInfo`] hold `&'static str` (a compiled model's names are
/// literals). Each distinct name is stored once, however many models are
/// read.
pub(super) fn intern(s: &str) -> &'static str {
    use std::collections::HashSet;
    use std::sync::{Mutex, OnceLock};
    static NAMES: OnceLock<Mutex<HashSet<&'static str>>> = OnceLock::new();
    let mut names = NAMES.get_or_init(Default::default).lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some(&n) = names.get(s) {
        return n;
    }
    let n: &'static str = Box::leak(s.to_owned().into_boxed_str());
    names.insert(n);
    n
}

/// The index `a` of an item of family `f` (none: of no family), shown
/// with the family's variable.
fn ix(def: &ModelDef, a: &Affine, f: Option<usize>) -> Ix {
    Ix::new(def, a, &f.map(|f| def.families[f].var.to_string()).unwrap_or_default())
}

/// A point (by its item and index) named by an item of family `f`.
fn point_at(def: &ModelDef, (p, index): &(usize, Option<Affine>), f: Option<usize>) -> PointAt {
    PointAt { item: *p, index: index.as_ref().map(|a| ix(def, a, f)) }
}

/// The model's parameters, then its counts, with their documentation
/// and units.
fn param_infos(def: &ModelDef) -> Vec<ParamInfo> {
    let mut params: Vec<ParamInfo> = def
        .params
        .iter()
        .map(|p| {
            let (doc, unit) = split_unit(&doc_of(&p.attrs));
            ParamInfo {
                name: intern(&p.name.to_string()),
                default: p.value,
                unit: intern(&unit),
                doc: intern(&doc),
                count: false,
            }
        })
        .collect();
    params.extend(def.counts.iter().map(|c| {
        let (doc, _) = split_unit(&doc_of(&c.attrs));
        ParamInfo {
            name: intern(&c.name.to_string()),
            default: c.value as f64,
            unit: "",
            doc: intern(&doc),
            count: true,
        }
    }));
    params
}

/// The plans of the model's points: where each sits, its tapes.
fn point_plans(m: &Derivation) -> Vec<PointPlan> {
    let (def, res, d) = (&m.def, &m.resolved, &m.derived);
    def.points
        .iter()
        .enumerate()
        .map(|(pi, p)| {
            let pd = &d.points[pi];
            let body = if p.family.is_some() {
                BodyAt { item: res.point_body[pi], index: Some(ix(def, &own_index(), p.family)) }
            } else {
                BodyAt { item: res.point_body[pi], index: res.point_body_index[pi].as_ref().map(|a| ix(def, a, None)) }
            };
            PointPlan {
                name: p.name.to_string(),
                family: p.family,
                body,
                pos: Tape::new(&d.ar, &pd.pos),
                vel: Tape::new(&d.ar, &pd.vel),
                local: Tape::new(&d.ar, &pd.local),
                vel_ids: pd.vel,
            }
        })
        .collect()
}

/// What a constraint group is: its item's kind and name, with the points
/// (or hinge) it names.
fn item_of(m: &Derivation, g: &ezy_lang::kinematics::Group) -> (String, ItemKind) {
    let (def, res, d) = (&m.def, &m.resolved, &m.derived);
    let f = g.family;
    match g.kind {
        Kind::Hinge => {
            let (a, b) = &res.hinge_points[g.item];
            let other = b.as_ref().map(|b| point_at(def, b, f));
            (def.hinges[g.item].name.to_string(), ItemKind::Hinge { point: point_at(def, a, f), other })
        }
        Kind::Slider => {
            let (a, b) = &res.slider_points[g.item];
            let other = b.as_ref().map(|b| point_at(def, b, f));
            let heading = def.sliders[g.item].heading;
            (def.sliders[g.item].name.to_string(), ItemKind::Slider { heading, point: point_at(def, a, f), other })
        }
        Kind::Drive => {
            let h = res.drive_hinge[g.item];
            let hinge_group = d.groups.iter().position(|x| x.kind == Kind::Hinge && x.item == h).expect("hinge group");
            (def.drives[g.item].name.to_string(), ItemKind::Drive { hinge_group })
        }
        Kind::Skate => {
            let point = point_at(def, &res.skate_point[g.item], f);
            (def.skates[g.item].name.to_string(), ItemKind::Skate { point })
        }
    }
}

/// The plan of one constraint group: its item, the bodies and indices it
/// touches, its tapes and its equations.
fn group_plan(m: &Derivation, g: &ezy_lang::kinematics::Group) -> GroupPlan {
    let (def, d) = (&m.def, &m.derived);
    let f = g.family;
    let (name, item_kind) = item_of(m, g);
    let pattern = g.local_pattern(&d.ar);
    let values: Vec<Id> = pattern.iter().map(|&(r, c)| g.g[r][c]).collect();
    let holonomic = g.holonomic();
    let phi: Vec<Id> = if holonomic { g.phi.clone() } else { Vec::new() };
    let cat = |parts: &[&[Id]]| Tape::new(&d.ar, &parts.concat());
    let direction = g.direction.filter(|[tx, ty]| {
        let index = |s| matches!(s, ezy_lang::sym::Sym::Index(_));
        d.ar.mentions(*tx, &index) || d.ar.mentions(*ty, &index)
    });
    let direction = direction.map(|[tx, ty]| {
        let (word, along) = match g.kind {
            Kind::Skate => ("blade direction `along", &def.skates[g.item].along),
            _ => ("direction `along", &def.sliders[g.item].along),
        };
        let (ax, ay) = (&along[0], &along[1]);
        let written = format!("{word} ({}, {})`", quote::quote!(#ax), quote::quote!(#ay));
        (Tape::new(&d.ar, &[tx, ty]), written)
    });
    GroupPlan {
        kind: g.kind,
        item_kind,
        name,
        family: f,
        slots: g.slots.iter().map(|b| BodyAt { item: b.0, index: b.1.as_ref().map(|a| ix(def, a, f)) }).collect(),
        indices: g.indices.iter().map(|a| ix(def, a, f)).collect(),
        rows: g.rows(),
        suffixes: g.suffixes.clone(),
        phi: cat(&[&phi]),
        g: cat(&[&values]),
        phi_g: cat(&[&phi, &values]).with_split(phi.len()),
        terms: cat(&[&values, &g.gamma]).with_split(values.len()),
        direction,
        eq_phi: phi,
        eq_velocity: g.velocity.clone(),
        eq_g: values,
        eq_gamma: g.gamma.clone(),
        pattern,
    }
}

impl Plan {
    /// The plan of a derived model.
    ///
    /// # Errors
    /// An item naming more than [`MAX_INDICES`] family indices or touching
    /// more than [`MAX_SLOTS`] bodies (the grammar makes neither; a
    /// message, not a panic, should that change).
    pub(super) fn new(m: &mut Derivation) -> Result<Self, String> {
        let (def, d) = (&m.def, &m.derived);
        let is_static = def.families.is_empty() && def.counts.is_empty();
        let param_of = |e: &syn::Expr| match e {
            syn::Expr::Path(p) => p
                .path
                .get_ident()
                .filter(|id| def.params.iter().any(|q| q.name == **id))
                .map(|id| intern(&id.to_string())),
            _ => None,
        };
        let families = def
            .families
            .iter()
            .enumerate()
            .map(|(f, fam)| Family {
                start: ix(def, &fam.start, Some(f)),
                end: ix(def, &fam.end, Some(f)),
                range: format!("{}..{}", fam.start.show(""), fam.end.show("")),
            })
            .collect();
        let bodies = def
            .bodies
            .iter()
            .enumerate()
            .map(|(bi, b)| BodyPlan {
                name: b.name.to_string(),
                family: b.family,
                coords: b.coords.clone().map(|c| c.to_string()),
                mass_param: param_of(&b.mass),
                inertia_param: param_of(&b.inertia),
                mass: Tape::new(&d.ar, &d.mass[bi]),
                mass_ids: d.mass[bi],
            })
            .collect();
        let groups = d.groups.iter().map(|g| group_plan(m, g)).collect::<Vec<_>>();
        let blades = (0..def.skates.len())
            .map(|ki| {
                // the plan's groups are the derivation's, in its order
                let gi =
                    d.groups.iter().position(|g| g.kind == Kind::Skate && g.item == ki).expect("one group per skate");
                (gi, Tape::new(&d.ar, &d.blades[ki]))
            })
            .collect::<Vec<_>>();
        let mut plan = Plan {
            name: intern(&def.name.to_string()),
            doc: intern(doc_of(&def.attrs).split(". ").next().unwrap_or("").trim_end_matches('.')),
            n_real: def.params.len(),
            params: param_infos(def),
            families,
            bodies,
            points: point_plans(m),
            groups,
            blades,
            ar: d.ar.clone(),
            registers: 0,
            own: ix(def, &own_index(), None),
            straight: None,
            code: std::sync::OnceLock::new(),
        };
        // the straight-line form renames into the arena: after every
        // element kernel, as `model!` does, so that its nodes are the ones
        // `model!` makes
        if is_static {
            plan.straight = Some(Straight::new(m));
        }
        plan.registers = plan.tapes().map(Tape::registers).max().unwrap_or(0);
        for g in &plan.groups {
            if g.indices.len() > MAX_INDICES || g.slots.len() > MAX_SLOTS {
                return Err(format!(
                    "{} `{}` names {} family indices and touches {} bodies; ezy reads at most {MAX_INDICES} and {MAX_SLOTS}",
                    g.kind_word(),
                    g.name,
                    g.indices.len(),
                    g.slots.len()
                ));
            }
        }
        Ok(plan)
    }

    /// Every tape.
    fn tapes(&self) -> impl Iterator<Item = &Tape> {
        let bodies = self.bodies.iter().map(|b| &b.mass);
        let points = self.points.iter().flat_map(|p| [&p.pos, &p.vel, &p.local]);
        let groups = self
            .groups
            .iter()
            .flat_map(|g| [&g.phi, &g.g, &g.phi_g, &g.terms].into_iter().chain(g.direction.as_ref().map(|(t, _)| t)));
        let straight = self.straight.iter().flat_map(Straight::tapes);
        bodies.chain(points).chain(groups).chain(self.blades.iter().map(|(_, t)| t)).chain(straight)
    }

    /// Compiles every tape to machine code, once (the first call compiles,
    /// later ones return its outcome).
    ///
    /// # Errors
    /// Why there is no JIT: a build without the `jit` feature, a host
    /// without a Cranelift back end, or code Cranelift refused.
    pub(super) fn compile(&self) -> Result<(), String> {
        let code = self.code.get_or_init(|| {
            #[cfg(feature = "jit")]
            {
                use super::tape::jit::{MAX_MODEL_OPS, MAX_OPS};
                let mut budget = MAX_MODEL_OPS;
                let tapes: Vec<&Tape> = self
                    .tapes()
                    // those that read no coordinate run once per setup
                    // (masses, local geometry, the fused table), on the
                    // register machine
                    .filter(|t| t.reads_state())
                    .filter(|t| {
                        let take = t.ops() <= MAX_OPS.min(budget);
                        if take {
                            budget -= t.ops();
                        }
                        take
                    })
                    .collect();
                let (code, kernels) = super::tape::jit::compile(&tapes)?;
                for (t, k) in tapes.iter().zip(kernels) {
                    t.set_kernel(k);
                }
                Ok(code)
            }
            #[cfg(not(feature = "jit"))]
            Err("this build of ezy-core has no `jit` feature".to_owned())
        });
        code.as_ref().map(|_| ()).map_err(Clone::clone)
    }

    /// Operations in all tapes (the size of the model's code).
    pub(super) fn ops(&self) -> usize {
        self.tapes().map(Tape::ops).sum()
    }
}
