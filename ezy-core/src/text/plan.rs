//! A derived model turned into data the runtime can hold (no syntax
//! tree, no span): its [`Description`] (names, indices and where each
//! item's elements sit, what `model!` writes as a `static`) and the
//! [`Tape`]s of its expressions.

use ezy_lang::Derivation;
use ezy_lang::description::Description;
use ezy_lang::kinematics::Kind;
use ezy_lang::sym::Id;

use super::fused::Fused;
use super::tape::Tape;
use crate::model::describe::param_infos;
use crate::model::info::ParamInfo;

/// Most family indices one item's expressions may name (`i`, `i - 1`,
/// `N`, ...): an element's index values live on the stack.
pub(super) const MAX_INDICES: usize = 16;

/// Most bodies one constraint item touches (a joint's two).
pub(super) const MAX_SLOTS: usize = 4;

/// A body item's tape: `(m, m, I)` with the own index as `Sym::Index(0)`.
#[derive(Debug)]
pub(super) struct BodyPlan {
    pub(super) mass: Tape,
}

/// A point item's tapes: world position, velocity and body-frame offsets
/// (2 each).
#[derive(Debug)]
pub(super) struct PointPlan {
    pub(super) pos: Tape,
    pub(super) vel: Tape,
    pub(super) local: Tape,
}

/// A constraint item's (single or a family's) element kernels; where its
/// elements sit is its group of the [`Description`].
#[derive(Debug)]
pub(super) struct GroupPlan {
    pub(super) kind: Kind,
    /// `phi`; `G`'s values; both; `G`'s values and `gamma`.
    pub(super) phi: Tape,
    pub(super) g: Tape,
    pub(super) phi_g: Tape,
    pub(super) terms: Tape,
    /// The direction as written `(tx, ty)` where it names the family's
    /// index (checked not zero at every element by `check_counts`).
    pub(super) direction: Option<Tape>,
}

impl GroupPlan {
    pub(super) fn holonomic(&self) -> bool {
        self.kind != Kind::Skate
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
    /// What it says about itself (`model::describe` renders it).
    pub(super) desc: Description,
    /// The real parameters, then the counts.
    pub(super) params: Vec<ParamInfo>,
    pub(super) n_real: usize,
    pub(super) bodies: Vec<BodyPlan>,
    pub(super) points: Vec<PointPlan>,
    pub(super) groups: Vec<GroupPlan>,
    /// Each skate's blade direction: its group and `(tx, ty)`.
    pub(super) blades: Vec<(usize, Tape)>,
    /// Registers the largest tape needs.
    pub(super) registers: usize,
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

/// The tapes of one constraint group (`direction`: whether its
/// description checks its direction).
fn group_plan(m: &Derivation, g: &ezy_lang::kinematics::Group, direction: bool) -> GroupPlan {
    let d = &m.derived;
    let values: Vec<Id> = g.local_pattern(&d.ar).iter().map(|&(r, c)| g.g[r][c]).collect();
    let phi: Vec<Id> = if g.holonomic() { g.phi.clone() } else { Vec::new() };
    let cat = |parts: &[&[Id]]| Tape::new(&d.ar, &parts.concat());
    GroupPlan {
        kind: g.kind,
        phi: cat(&[&phi]),
        g: cat(&[&values]),
        phi_g: cat(&[&phi, &values]).with_split(phi.len()),
        terms: cat(&[&values, &g.gamma]).with_split(values.len()),
        direction: direction.then(|| Tape::new(&d.ar, &g.direction.expect("a checked direction is written"))),
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
        // the description first, before the straight-line form adds to the
        // arena, as `model!` makes it
        let desc = ezy_lang::description::describe(&m.def, &m.resolved, &m.derived);
        for g in desc.groups.iter() {
            if g.indices.len() > MAX_INDICES || g.slots.len() > MAX_SLOTS {
                return Err(format!(
                    "{} `{}` names {} family indices and touches {} bodies; ezy reads at most {MAX_INDICES} and {MAX_SLOTS}",
                    g.item.word(),
                    g.name,
                    g.indices.len(),
                    g.slots.len()
                ));
            }
        }
        let (def, d) = (&m.def, &m.derived);
        let is_static = def.families.is_empty() && def.counts.is_empty();
        let bodies = d.mass.iter().map(|mass| BodyPlan { mass: Tape::new(&d.ar, mass) }).collect();
        let points = d
            .points
            .iter()
            .map(|p| PointPlan {
                pos: Tape::new(&d.ar, &p.pos),
                vel: Tape::new(&d.ar, &p.vel),
                local: Tape::new(&d.ar, &p.local),
            })
            .collect();
        let groups =
            d.groups.iter().zip(desc.groups.iter()).map(|(g, gd)| group_plan(m, g, gd.direction.is_some())).collect();
        let blades = (0..def.skates.len())
            .map(|ki| {
                // the plan's groups are the derivation's, in its order
                let gi =
                    d.groups.iter().position(|g| g.kind == Kind::Skate && g.item == ki).expect("one group per skate");
                (gi, Tape::new(&d.ar, &d.blades[ki]))
            })
            .collect::<Vec<_>>();
        let mut plan = Plan {
            n_real: def.params.len(),
            params: param_infos(&desc),
            desc,
            bodies,
            points,
            groups,
            blades,
            registers: 0,
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
        Ok(plan)
    }

    /// Every tape.
    fn tapes(&self) -> impl Iterator<Item = &Tape> {
        let bodies = self.bodies.iter().map(|b| &b.mass);
        let points = self.points.iter().flat_map(|p| [&p.pos, &p.vel, &p.local]);
        let groups =
            self.groups.iter().flat_map(|g| [&g.phi, &g.g, &g.phi_g, &g.terms].into_iter().chain(g.direction.as_ref()));
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
                use super::fused::jit::Spec;
                use super::tape::jit::{MAX_MODEL_OPS, MAX_OPS};
                let mut budget = MAX_MODEL_OPS;
                let mut take = |ops: usize| {
                    let take = ops <= MAX_OPS.min(budget);
                    if take {
                        budget -= ops;
                    }
                    take
                };
                // the whole fused right-hand side, in place of its tapes'
                // kernels
                let specs: Vec<Spec<'_>> = self
                    .straight
                    .iter()
                    .filter_map(|st| {
                        let m = st.minimal.as_ref().ok()?;
                        Spec::new(&m.fused, &m.coords, &m.speeds, &st.cols)
                    })
                    .filter(|s| take(s.ops()))
                    .collect();
                let replaced: Vec<&Tape> = match specs.len() {
                    0 => Vec::new(),
                    _ => self
                        .straight
                        .iter()
                        .flat_map(|st| st.minimal.iter())
                        .flat_map(|m| m.fused.kernel_tapes())
                        .collect(),
                };
                let tapes: Vec<&Tape> = self
                    .tapes()
                    // those that read no coordinate run once per setup
                    // (masses, local geometry, the fused table), on the
                    // register machine
                    .filter(|t| t.reads_state())
                    .filter(|t| !replaced.iter().any(|r| std::ptr::eq(*r, *t)))
                    .filter(|t| take(t.ops()))
                    .collect();
                let parts: Vec<_> = specs.iter().flat_map(Spec::parts).collect();
                let extras: Vec<&dyn super::tape::jit::Extra> = parts.iter().map(|p| p as _).collect();
                let (code, kernels, entries) = super::tape::jit::compile(&tapes, &extras)?;
                for (t, k) in tapes.iter().zip(kernels) {
                    t.set_kernel(k);
                }
                for (spec, entries) in specs.iter().zip(entries.chunks_exact(3)) {
                    // SAFETY: `entries` are the finalized functions of
                    // `spec`'s parts, in their order.
                    unsafe { spec.set_kernels(entries) };
                }
                Ok(code)
            }
            #[cfg(not(feature = "jit"))]
            Err("this build has no JIT (Cranelift): build ezy with `--features jit`".to_owned())
        });
        code.as_ref().map(|_| ()).map_err(Clone::clone)
    }

    /// Operations in all tapes (the size of the model's code).
    pub(super) fn ops(&self) -> usize {
        self.tapes().map(Tape::ops).sum()
    }
}
