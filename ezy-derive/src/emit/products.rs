//! The products with `G` of a model without families, straight-line at
//! its compile-time sparsity pattern, which the runtime's KKT solves call
//! in place of its generic sparse loops.

use proc_macro2::TokenStream;
use quote::quote;

use super::join;

/// Straight-line products with `G` at its compile-time sparsity pattern:
/// `normal_matrix` (`G W^-1 G^T`, lower triangle), `g_winv_mul` (`G W^-1 u`),
/// `sub_winv_gt_mul` (`v -= W^-1 G^T x`). No index arithmetic at run time.
pub(super) fn sparse_kernels(pattern: &[(usize, usize)], nq: usize, nc: usize) -> TokenStream {
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
        fn normal_matrix(&self, _pattern: &[(usize, usize)], _nc: usize, values: &[f64], winv: &[f64], a: &mut [f64]) {
            let values = &values[..#nnz];
            let winv = &winv[..#nq];
            let a = &mut a[..#nn];
            #normal
        }

        #[inline]
        fn g_winv_mul(&self, _pattern: &[(usize, usize)], values: &[f64], winv: &[f64], u: &[f64], out: &mut [f64]) {
            let values = &values[..#nnz];
            let winv = &winv[..#nq];
            let u = &u[..#nq];
            let out = &mut out[..#nc];
            #gmul
        }

        #[inline]
        fn sub_winv_gt_mul(&self, _pattern: &[(usize, usize)], values: &[f64], winv: &[f64], x: &[f64], v: &mut [f64]) {
            let values = &values[..#nnz];
            let winv = &winv[..#nq];
            let x = &x[..#nc];
            let v = &mut v[..#nq];
            #gt
        }
    }
}
