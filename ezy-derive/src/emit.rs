//! `quote!` the struct, its `Default` and its `Model` impl from the derived
//! expressions. Each generated function is straight-line code: the
//! expressions it needs, in arena order, as `let` bindings (so shared
//! subexpressions are computed once per call).

use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

use crate::ast::{ModelDef, doc_of, split_unit};
use crate::check::Resolved;
use crate::kinematics::Derived;
use crate::sym::{Id, Node, Sym};

fn lit_f64(v: f64) -> TokenStream {
    if v.is_finite() {
        let l = Literal::f64_suffixed(v);
        quote!(#l)
    } else {
        quote!(::core::f64::NAN)
    }
}

/// `a op b op c ...`
fn join(items: impl Iterator<Item = TokenStream>, op: TokenStream) -> TokenStream {
    let mut out = TokenStream::new();
    for (i, item) in items.enumerate() {
        if i > 0 {
            out.extend(op.clone());
        }
        out.extend(item);
    }
    out
}

/// Straight-line code computing `outputs`: `(let bindings, one expression per output)`.
fn lower(d: &Derived, def: &ModelDef, outputs: &[Id]) -> (TokenStream, Vec<TokenStream>) {
    let scalar = quote!(<S as ::ezy_core::__private::Scalar>);
    let reach = d.ar.reachable(outputs);
    let refer = |id: Id| -> TokenStream {
        match d.ar.node(id) {
            Node::Const(bits) => {
                let l = lit_f64(f64::from_bits(*bits));
                quote!(#scalar::from_f64(#l))
            }
            Node::Sym(Sym::Q(k)) => quote!(q[#k]),
            Node::Sym(Sym::Qd(k)) => quote!(qd[#k]),
            Node::Sym(Sym::Param(i)) => {
                let p = format_ident!("p_{}", def.params[*i].name);
                quote!(#p)
            }
            _ => {
                let t = format_ident!("t{}", id.index());
                quote!(#t)
            }
        }
    };
    let mut lets = TokenStream::new();
    for &id in &reach {
        let rhs = match d.ar.node(id) {
            Node::Sym(Sym::Param(i)) => {
                let p = format_ident!("p_{}", def.params[*i].name);
                let field = &def.params[*i].name;
                lets.extend(quote!(let #p: S = #scalar::from_f64(self.#field);));
                continue;
            }
            Node::Const(_) | Node::Sym(_) => continue,
            Node::Add(ts) => join(ts.iter().map(|&t| refer(t)), quote!(+)),
            Node::Mul(fs) => {
                if d.ar.as_const(fs[0]) == Some(-1.0) {
                    let p = join(fs[1..].iter().map(|&f| refer(f)), quote!(*));
                    quote!(-(#p))
                } else {
                    join(fs.iter().map(|&f| refer(f)), quote!(*))
                }
            }
            Node::Pow(b, n) => {
                let b = refer(*b);
                match *n {
                    2 => quote!(#b * #b),
                    3 => quote!(#b * #b * #b),
                    -1 => quote!(#scalar::recip(#b)),
                    -2 => quote!(#scalar::recip(#b * #b)),
                    n => quote!(#scalar::powi(#b, #n)),
                }
            }
            Node::Sin(a) => {
                let a = refer(*a);
                quote!(#scalar::sin(#a))
            }
            Node::Cos(a) => {
                let a = refer(*a);
                quote!(#scalar::cos(#a))
            }
            Node::Sqrt(a) => {
                let a = refer(*a);
                quote!(#scalar::sqrt(#a))
            }
        };
        let t = format_ident!("t{}", id.index());
        lets.extend(quote!(let #t: S = #rhs;));
    }
    (lets, outputs.iter().map(|&o| refer(o)).collect())
}

/// Assignments `out[k] = expr_k` with their bindings.
fn assign(d: &Derived, def: &ModelDef, groups: &[(&str, &[Id])]) -> TokenStream {
    let all: Vec<Id> = groups.iter().flat_map(|(_, ids)| ids.iter().copied()).collect();
    let (lets, exprs) = lower(d, def, &all);
    let mut body = lets;
    let mut start = 0;
    for (name, ids) in groups {
        let out = format_ident!("{}", name);
        let n = ids.len();
        body.extend(quote!(let #out = &mut #out[..#n];));
        for (k, e) in exprs[start..start + n].iter().enumerate() {
            body.extend(quote!(#out[#k] = #e;));
        }
        start += n;
    }
    body
}

/// The whole expansion.
pub fn emit(def: &ModelDef, res: &Resolved, d: &Derived) -> TokenStream {
    let name = &def.name;
    let vis = &def.vis;
    let attrs = &def.attrs;
    let nq = d.nq;
    let nh = d.phi.len();
    let pattern = d.pattern();
    let nnz_h = pattern.iter().filter(|(r, _)| *r < nh).count();

    // struct and Default
    let fields = def.params.iter().map(|p| {
        let pattrs = &p.attrs;
        let n = &p.name;
        quote!(#(#pattrs)* pub #n: f64,)
    });
    let defaults = def.params.iter().map(|p| {
        let n = &p.name;
        let v = lit_f64(p.value);
        quote!(#n: #v,)
    });

    // static info
    let private = quote!(::ezy_core::__private);
    let model_name = name.to_string();
    let model_doc = doc_of(&def.attrs).split(". ").next().unwrap_or("").trim_end_matches('.').to_string();
    let coords = def.bodies.iter().flat_map(|b| b.coords.iter().map(|c| c.to_string()));
    let params_info = def.params.iter().map(|p| {
        let (doc, unit) = split_unit(&doc_of(&p.attrs));
        let n = p.name.to_string();
        let v = lit_f64(p.value);
        quote!(#private::ParamInfo { name: #n, default: #v, unit: #unit, doc: #doc })
    });
    let param_of = |e: &syn::Expr| -> TokenStream {
        match e {
            syn::Expr::Path(p) if p.path.get_ident().is_some() => {
                let n = p.path.get_ident().expect("checked").to_string();
                quote!(::core::option::Option::Some(#n))
            }
            _ => quote!(::core::option::Option::None),
        }
    };
    let bodies_info = def.bodies.iter().enumerate().map(|(i, b)| {
        let n = b.name.to_string();
        let (x, y, phi) = (3 * i, 3 * i + 1, 3 * i + 2);
        let (mp, ip) = (param_of(&b.mass), param_of(&b.inertia));
        quote!(#private::BodyInfo { name: #n, coords: [#x, #y, #phi], mass_param: #mp, inertia_param: #ip })
    });
    let points_info = def.points.iter().zip(&res.point_body).map(|(p, &b)| {
        let n = p.name.to_string();
        quote!(#private::PointInfo { name: #n, body: #b })
    });
    let hinges_info = def.hinges.iter().zip(&res.hinge_points).enumerate().map(|(i, (h, &(a, b)))| {
        let n = h.name.to_string();
        let body_a = res.point_body[a];
        let body_b = match b {
            Some(b) => {
                let b = res.point_body[b];
                quote!(::core::option::Option::Some(#b))
            }
            None => quote!(::core::option::Option::None),
        };
        let row = 2 * i;
        quote!(#private::HingeInfo { name: #n, body_a: #body_a, body_b: #body_b, row: #row })
    });
    let n_hinge_rows = 2 * def.hinges.len();
    let sliders_info = def.sliders.iter().zip(&res.slider_points).enumerate().map(|(i, (sl, &(p, guide)))| {
        let n = sl.name.to_string();
        let body_b = res.point_body[p];
        let body_a = match guide {
            Some(g) => {
                let a = res.point_body[g];
                quote!(::core::option::Option::Some(#a))
            }
            None => quote!(::core::option::Option::None),
        };
        let row = n_hinge_rows + 2 * i;
        quote!(#private::SliderInfo { name: #n, body_a: #body_a, body_b: #body_b, row: #row })
    });
    let n_slider_rows = 2 * def.sliders.len();
    let drives_info = def.drives.iter().zip(&res.drive_hinge).enumerate().map(|(i, (d, &h))| {
        let n = d.name.to_string();
        let row = n_hinge_rows + n_slider_rows + i;
        quote!(#private::DriveInfo { name: #n, hinge: #h, row: #row })
    });
    let skates_info = def.skates.iter().zip(&res.skate_point).enumerate().map(|(i, (s, &p))| {
        let n = s.name.to_string();
        let row = nh + i;
        quote!(#private::SkateInfo { name: #n, point: #p, row: #row })
    });
    let cnames = &d.constraint_names;
    let pat = pattern.iter().map(|(r, c)| quote!((#r, #c)));

    // parameters by index
    let get_arms = def.params.iter().enumerate().map(|(i, p)| {
        let n = &p.name;
        quote!(#i => self.#n,)
    });
    let set_arms = def.params.iter().enumerate().map(|(i, p)| {
        let n = &p.name;
        quote!(#i => self.#n = value,)
    });

    // generated numerics
    let g_all: Vec<Id> = pattern.iter().map(|&(r, c)| d.g[r][c]).collect();
    let g_h: Vec<Id> = g_all[..nnz_h].to_vec();
    let points_flat: Vec<Id> = d.points.iter().flat_map(|p| p.iter().copied()).collect();
    let vel_flat: Vec<Id> = d.point_vel.iter().flat_map(|p| p.iter().copied()).collect();
    let mass_body = assign(d, def, &[("out", &d.mass)]);
    let phi_body = assign(d, def, &[("phi", &d.phi)]);
    let jac_body = assign(d, def, &[("values", &g_h)]);
    let g_body = assign(d, def, &[("values", &g_all)]);
    let terms_body = assign(d, def, &[("values", &g_all), ("gamma", &d.gamma)]);
    let phi_g_body = assign(d, def, &[("phi", &d.phi), ("values", &g_all)]);
    let points_body = assign(d, def, &[("out", &points_flat)]);
    let vel_body = assign(d, def, &[("out", &vel_flat)]);
    let n_local_points = 2 * d.points.len();
    let local_body = assign(d, def, &[("points", &d.local[..n_local_points]), ("blades", &d.local[n_local_points..])]);

    let kernels = sparse_kernels(&pattern, nq, d.g.len());
    let equations = equations(d, def, &pattern);

    quote! {
        #(#attrs)*
        #[derive(Debug, Clone, PartialEq)]
        #[allow(non_snake_case)]
        #vis struct #name {
            #(#fields)*
        }

        impl ::core::default::Default for #name {
            fn default() -> Self {
                Self { #(#defaults)* }
            }
        }

        #[allow(non_snake_case, unused_variables, clippy::all, clippy::pedantic)]
        impl #private::Model for #name {
            const INFO: #private::ModelInfo = #private::ModelInfo {
                name: #model_name,
                doc: #model_doc,
                coords: &[#(#coords),*],
                params: &[#(#params_info),*],
                bodies: &[#(#bodies_info),*],
                points: &[#(#points_info),*],
                hinges: &[#(#hinges_info),*],
                sliders: &[#(#sliders_info),*],
                drives: &[#(#drives_info),*],
                skates: &[#(#skates_info),*],
                constraints: &[#(#cnames),*],
                n_holonomic: #nh,
                pattern: &[#(#pat),*],
            };

            const EQUATIONS: #private::Equations = #equations;

            fn param(&self, index: usize) -> f64 {
                match index {
                    #(#get_arms)*
                    _ => panic!("parameter index {} out of range", index),
                }
            }

            fn set_param(&mut self, index: usize, value: f64) {
                match index {
                    #(#set_arms)*
                    _ => panic!("parameter index {} out of range", index),
                }
            }

            fn mass_diagonal(&self, out: &mut [f64]) {
                type S = f64;
                #mass_body
            }

            fn local_geometry(&self, points: &mut [f64], blades: &mut [f64]) {
                type S = f64;
                #local_body
            }

            #kernels

            #[inline]
            fn phi<S: #private::Scalar>(&self, q: &[S], phi: &mut [S]) {
                let q = &q[..#nq];
                #phi_body
            }

            #[inline]
            fn holonomic_jacobian<S: #private::Scalar>(&self, q: &[S], values: &mut [S]) {
                let q = &q[..#nq];
                #jac_body
            }

            #[inline]
            fn constraint_matrix<S: #private::Scalar>(&self, q: &[S], values: &mut [S]) {
                let q = &q[..#nq];
                #g_body
            }

            #[inline]
            fn phi_and_constraint_matrix<S: #private::Scalar>(&self, q: &[S], phi: &mut [S], values: &mut [S]) {
                let q = &q[..#nq];
                #phi_g_body
            }

            #[inline]
            fn constraint_terms<S: #private::Scalar>(&self, q: &[S], qd: &[S], values: &mut [S], gamma: &mut [S]) {
                let q = &q[..#nq];
                let qd = &qd[..#nq];
                #terms_body
            }

            #[inline]
            fn points<S: #private::Scalar>(&self, q: &[S], out: &mut [S]) {
                let q = &q[..#nq];
                #points_body
            }

            #[inline]
            fn point_velocities<S: #private::Scalar>(&self, q: &[S], qd: &[S], out: &mut [S]) {
                let q = &q[..#nq];
                let qd = &qd[..#nq];
                #vel_body
            }
        }
    }
}

/// The derived equations as text and LaTeX (`Model::EQUATIONS`), for
/// `ezy equations`: what the macro computed, in SPEC §1's notation.
fn equations(d: &Derived, def: &ModelDef, pattern: &[(usize, usize)]) -> TokenStream {
    use crate::sym::Id;
    use crate::sym::{Sym, latex_name, latex_rate};
    let private = quote!(::ezy_core::__private);
    let coords: Vec<String> = def.bodies.iter().flat_map(|b| b.coords.iter().map(|c| c.to_string())).collect();
    let params: Vec<String> = def.params.iter().map(|p| p.name.to_string()).collect();
    let text_name = |s: Sym| match s {
        Sym::Q(k) => coords[k].clone(),
        Sym::Qd(k) => format!("{}d", coords[k]),
        Sym::Param(i) => params[i].clone(),
    };
    let latex = |s: Sym| match s {
        Sym::Q(k) => latex_name(&coords[k]),
        Sym::Qd(k) => latex_rate(&coords[k]),
        Sym::Param(i) => latex_name(&params[i]),
    };
    let expr = |id: Id| {
        let t = d.ar.display(id, &text_name);
        let l = d.ar.latex(id, &latex);
        quote!(#private::EquationExpr { text: #t, latex: #l })
    };
    let coord_names = coords.iter().map(|c| {
        let l = latex_name(c);
        quote!(#private::EquationExpr { text: #c, latex: #l })
    });
    let mass = d.mass.iter().map(|&e| expr(e));
    let phi = d.phi.iter().map(|&e| expr(e));
    let velocity = d.velocity.iter().map(|&e| expr(e));
    let jacobian = pattern.iter().map(|&(r, c)| expr(d.g[r][c]));
    let gamma = d.gamma.iter().map(|&e| expr(e));
    let point_velocities = d.point_vel.iter().flat_map(|v| v.iter()).map(|&e| expr(e));
    quote!(#private::Equations {
        coords: &[#(#coord_names),*],
        mass: &[#(#mass),*],
        phi: &[#(#phi),*],
        velocity: &[#(#velocity),*],
        jacobian: &[#(#jacobian),*],
        gamma: &[#(#gamma),*],
        point_velocities: &[#(#point_velocities),*],
    })
}

/// Straight-line products with `G` at its compile-time sparsity pattern:
/// `normal_matrix` (`G W^-1 G^T`, lower triangle), `g_winv_mul` (`G W^-1 u`),
/// `sub_winv_gt_mul` (`v -= W^-1 G^T x`). No index arithmetic at run time.
fn sparse_kernels(pattern: &[(usize, usize)], nq: usize, nc: usize) -> TokenStream {
    let rows: Vec<Vec<(usize, usize)>> = (0..nc)
        .map(|r| pattern.iter().enumerate().filter(|(_, p)| p.0 == r).map(|(e, p)| (e, p.1)).collect())
        .collect();
    let zero = quote!(0.0f64);
    let mut normal = TokenStream::new();
    for i in 0..nc {
        for j in 0..=i {
            let mut terms = Vec::new();
            for &(e1, k) in &rows[i] {
                for &(e2, k2) in &rows[j] {
                    if k == k2 {
                        terms.push(quote!(values[#e1] * values[#e2] * winv[#k]));
                    }
                }
            }
            let idx = i * nc + j;
            let sum = if terms.is_empty() { zero.clone() } else { join(terms.into_iter(), quote!(+)) };
            normal.extend(quote!(a[#idx] = #sum;));
        }
    }
    let mut gmul = TokenStream::new();
    for (i, row) in rows.iter().enumerate() {
        let terms: Vec<TokenStream> = row.iter().map(|&(e, k)| quote!(values[#e] * (winv[#k] * u[#k]))).collect();
        let sum = if terms.is_empty() { zero.clone() } else { join(terms.into_iter(), quote!(+)) };
        gmul.extend(quote!(out[#i] = #sum;));
    }
    let mut gt = TokenStream::new();
    for k in 0..nq {
        let terms: Vec<TokenStream> = pattern
            .iter()
            .enumerate()
            .filter(|(_, p)| p.1 == k)
            .map(|(e, p)| {
                let r = p.0;
                quote!(values[#e] * x[#r])
            })
            .collect();
        if !terms.is_empty() {
            let sum = join(terms.into_iter(), quote!(+));
            gt.extend(quote!(v[#k] -= winv[#k] * (#sum);));
        }
    }
    let nnz = pattern.len();
    let nn = nc * nc;
    quote! {
        #[inline]
        fn normal_matrix(values: &[f64], winv: &[f64], a: &mut [f64]) {
            let values = &values[..#nnz];
            let winv = &winv[..#nq];
            let a = &mut a[..#nn];
            #normal
        }

        #[inline]
        fn g_winv_mul(values: &[f64], winv: &[f64], u: &[f64], out: &mut [f64]) {
            let values = &values[..#nnz];
            let winv = &winv[..#nq];
            let u = &u[..#nq];
            let out = &mut out[..#nc];
            #gmul
        }

        #[inline]
        fn sub_winv_gt_mul(values: &[f64], winv: &[f64], x: &[f64], v: &mut [f64]) {
            let values = &values[..#nnz];
            let winv = &winv[..#nq];
            let x = &x[..#nc];
            let v = &mut v[..#nq];
            #gt
        }
    }
}
