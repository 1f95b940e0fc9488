//! The inner loops: dot products with a fixed summation order.
//!
//! Every dot product accumulates in 16 lanes (element `i` goes to lane `i % 16`)
//! and reduces the lanes with one fixed tree. The batched kernel computes
//! several dot products against one shared row with exactly the same per-column
//! arithmetic, so a column's result never depends on how many columns are
//! computed together, on the chunking across threads, or on the machine.

use pulp::{Simd, WithSimd};

use crate::real::Real;

/// Accumulator lanes of every dot product.
pub const LANES: usize = 16;

#[inline(always)]
fn reduce<R: Real>(acc: [R; LANES]) -> R {
    let mut h = [R::ZERO; 8];
    for l in 0..8 {
        h[l] = acc[l] + acc[l + 8];
    }
    ((h[0] + h[4]) + (h[1] + h[5])) + ((h[2] + h[6]) + (h[3] + h[7]))
}

/// Dot products in explicit SIMD for one scalar type.
///
/// Implemented for `f32` and `f64` with [`pulp`]'s vector types, whose lane
/// count (1, 4, 8 or 16) divides [`LANES`], so that element `i` of each
/// 16-element chunk always lands in accumulator lane `i`, whatever the
/// instruction set; the tail and the final reduction are scalar and fixed.
pub trait SimdDot: Real + pulp::bytemuck::Pod {
    /// `Σ a[i]·b[i]`.
    fn dot_simd<S: Simd>(simd: S, a: &[Self], b: &[Self]) -> Self;
    /// Four dot products against one shared row.
    fn dot4_simd<S: Simd>(simd: S, row: &[Self], x: [&[Self]; 4]) -> [Self; 4];
    /// `out[c·n + i] = Σ_j wt[j·n + i] · xs[c·n + j]` for every column `c` of
    /// `xs`: the product of the column-major `n × n` matrix `wt` with each
    /// column. Each element sums over `j = 0, 1, …, n−1` in order, starting
    /// from 0, so its value does not depend on the instruction set, on the
    /// number of columns, or on which block it falls in.
    fn gemm_simd<S: Simd>(simd: S, wt: &[Self], n: usize, xs: &[Self], out: &mut [Self]);
}

macro_rules! simd_dot {
    ($t:ty, $v:ident, $n_lanes:ident, $as_simd:ident, $splat:ident, $add:ident, $mul:ident) => {
        impl SimdDot for $t {
            #[inline(always)]
            fn dot_simd<S: Simd>(simd: S, a: &[$t], b: &[$t]) -> $t {
                assert_eq!(a.len(), b.len());
                let k = LANES / S::$n_lanes;
                let mut acc = [simd.$splat(0.0); LANES];
                let (ac, at) = a.as_chunks::<LANES>();
                let (bc, bt) = b.as_chunks::<LANES>();
                for (x, y) in ac.iter().zip(bc) {
                    let (xv, _) = S::$as_simd(x);
                    let (yv, _) = S::$as_simd(y);
                    for j in 0..k {
                        acc[j] = simd.$add(acc[j], simd.$mul(xv[j], yv[j]));
                    }
                }
                let mut lanes = [0.0 as $t; LANES];
                lanes.copy_from_slice(pulp::bytemuck::cast_slice::<S::$v, $t>(&acc[..k]));
                for (l, (x, y)) in at.iter().zip(bt).enumerate() {
                    lanes[l] += x * y;
                }
                reduce(lanes)
            }

            #[inline(always)]
            fn dot4_simd<S: Simd>(simd: S, row: &[$t], x: [&[$t]; 4]) -> [$t; 4] {
                for v in &x {
                    assert_eq!(v.len(), row.len());
                }
                let k = LANES / S::$n_lanes;
                let z = simd.$splat(0.0);
                let mut acc = [[z; LANES]; 4];
                let (rc, rt) = row.as_chunks::<LANES>();
                let cs = x.map(|v| v.as_chunks::<LANES>());
                for (i, r) in rc.iter().enumerate() {
                    let (rv, _) = S::$as_simd(r);
                    for (a, (c, _)) in acc.iter_mut().zip(&cs) {
                        let (xv, _) = S::$as_simd(&c[i]);
                        for j in 0..k {
                            a[j] = simd.$add(a[j], simd.$mul(rv[j], xv[j]));
                        }
                    }
                }
                let mut out = [0.0 as $t; 4];
                for ((o, a), (_, tail)) in out.iter_mut().zip(&acc).zip(&cs) {
                    let mut lanes = [0.0 as $t; LANES];
                    lanes.copy_from_slice(pulp::bytemuck::cast_slice::<S::$v, $t>(&a[..k]));
                    for (l, (w, v)) in rt.iter().zip(tail.iter()).enumerate() {
                        lanes[l] += w * v;
                    }
                    *o = reduce(lanes);
                }
                out
            }

            #[inline(always)]
            fn gemm_simd<S: Simd>(simd: S, wt: &[$t], n: usize, xs: &[$t], out: &mut [$t]) {
                assert_eq!(wt.len(), n * n);
                assert_eq!(xs.len(), out.len());
                assert!(n > 0 && xs.len() % n == 0);
                let n_cols = xs.len() / n;
                let lanes = S::$n_lanes;
                let n_vec = n / lanes;

                /// Columns `c..c+Q`, row vectors `v..v+B`, terms `j0..j1`: Q·B
                /// accumulators in registers. The running sums start at 0 when
                /// `j0 == 0` and otherwise continue from `out`, so tiling over `j`
                /// leaves every element's sequence of additions unchanged.
                #[inline(always)]
                fn block<S: Simd, const Q: usize, const B: usize>(
                    simd: S,
                    wt: &[$t],
                    n: usize,
                    xs: &[$t],
                    out: &mut [$t],
                    (c, v): (usize, usize),
                    (j0, j1): (usize, usize),
                ) {
                    let lanes = S::$n_lanes;
                    let z = simd.$splat(0.0);
                    let mut acc = [[z; B]; Q];
                    if j0 > 0 {
                        for q in 0..Q {
                            let src = &out[(c + q) * n + v * lanes..(c + q) * n + (v + B) * lanes];
                            let (sv, _) = S::$as_simd(src);
                            acc[q].copy_from_slice(&sv[..B]);
                        }
                    }
                    let x: [&[$t]; Q] = core::array::from_fn(|q| &xs[(c + q) * n..(c + q + 1) * n]);
                    for j in j0..j1 {
                        let base = j * n + v * lanes;
                        let (col, _) = S::$as_simd(&wt[base..base + B * lanes]);
                        let col: &[S::$v; B] = col.try_into().unwrap_or_else(|_| unreachable!());
                        for q in 0..Q {
                            let xj = simd.$splat(x[q][j]);
                            for b in 0..B {
                                acc[q][b] = simd.$add(acc[q][b], simd.$mul(col[b], xj));
                            }
                        }
                    }
                    for q in 0..Q {
                        let dst = &mut out[(c + q) * n + v * lanes..(c + q) * n + (v + B) * lanes];
                        dst.copy_from_slice(pulp::bytemuck::cast_slice::<S::$v, $t>(&acc[q]));
                    }
                }

                // Tiles of W columns small enough to stay in cache while every
                // row block passes over them (one tile when W itself fits).
                let tile = if n * n * core::mem::size_of::<$t>() <= 512 * 1024 { n } else { 64 };
                let mut j0 = 0;
                while j0 < n {
                    let j = (j0, (j0 + tile).min(n));
                    let mut c = 0;
                    while c + 4 <= n_cols {
                        let mut v = 0;
                        while v + 2 <= n_vec {
                            block::<S, 4, 2>(simd, wt, n, xs, out, (c, v), j);
                            v += 2;
                        }
                        while v < n_vec {
                            block::<S, 4, 1>(simd, wt, n, xs, out, (c, v), j);
                            v += 1;
                        }
                        c += 4;
                    }
                    while c < n_cols {
                        let mut v = 0;
                        while v + 8 <= n_vec {
                            block::<S, 1, 8>(simd, wt, n, xs, out, (c, v), j);
                            v += 8;
                        }
                        while v + 2 <= n_vec {
                            block::<S, 1, 2>(simd, wt, n, xs, out, (c, v), j);
                            v += 2;
                        }
                        while v < n_vec {
                            block::<S, 1, 1>(simd, wt, n, xs, out, (c, v), j);
                            v += 1;
                        }
                        c += 1;
                    }
                    j0 = j.1;
                }
                // Rows past the last full vector: the same sums, one element at a time.
                for c in 0..n_cols {
                    let x = &xs[c * n..(c + 1) * n];
                    for i in n_vec * lanes..n {
                        let mut s: $t = 0.0;
                        for j in 0..n {
                            s += wt[j * n + i] * x[j];
                        }
                        out[c * n + i] = s;
                    }
                }
            }
        }
    };
}

simd_dot!(f32, f32s, F32_LANES, as_simd_f32s, splat_f32s, add_f32s, mul_f32s);
simd_dot!(f64, f64s, F64_LANES, as_simd_f64s, splat_f64s, add_f64s, mul_f64s);

/// `Σ a[i]·b[i]` with the crate's fixed summation order, in the best
/// instruction set of this machine.
///
/// # Panics
/// When the lengths differ.
pub fn dot<R: SimdDot>(a: &[R], b: &[R]) -> R {
    struct Op<'a, R>(&'a [R], &'a [R]);
    impl<R: SimdDot> WithSimd for Op<'_, R> {
        type Output = R;
        #[inline(always)]
        fn with_simd<S: Simd>(self, simd: S) -> R {
            R::dot_simd(simd, self.0, self.1)
        }
    }
    pulp::Arch::new().dispatch(Op(a, b))
}

/// [`matmul_cols`] in the best instruction set of this machine.
pub fn matmul<R: SimdDot>(w: &[R], n: usize, xs: &[R], out: &mut [R]) {
    struct Op<'a, R>(&'a [R], usize, &'a [R], &'a mut [R]);
    impl<R: SimdDot> WithSimd for Op<'_, R> {
        type Output = ();
        #[inline(always)]
        fn with_simd<S: Simd>(self, simd: S) {
            matmul_cols(simd, self.0, self.1, self.2, self.3)
        }
    }
    pulp::Arch::new().dispatch(Op(w, n, xs, out))
}

/// `out[c][i] = Σ_j W[i][j] · xs[c][j]` for every column `c`, with `wt` the
/// column-major (transposed) `n × n` matrix; see [`SimdDot::gemm_simd`].
#[inline(always)]
pub fn matmul_cols<R: SimdDot, S: Simd>(simd: S, wt: &[R], n: usize, xs: &[R], out: &mut [R]) {
    R::gemm_simd(simd, wt, n, xs, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batched_columns_equal_single_dot_products_bit_for_bit() {
        for n in [1, 7, 8, 13, 64, 301, 390] {
            let w: Vec<f32> = (0..n * n).map(|k| ((k * 7919 % 1000) as f32 - 500.0) / 377.0).collect();
            for n_cols in [1, 3, 4, 5, 9] {
                let xs: Vec<f32> = (0..n * n_cols).map(|k| ((k * 104_729 % 997) as f32 - 498.0) / 211.0).collect();
                let mut out = vec![0.0; n * n_cols];
                matmul(&w, n, &xs, &mut out);
                let mut scalar = vec![0.0; n * n_cols];
                matmul_cols(pulp::Scalar::new(), &w, n, &xs, &mut scalar);
                for c in 0..n_cols {
                    let mut one = vec![0.0; n];
                    matmul(&w, n, &xs[c * n..(c + 1) * n], &mut one);
                    for i in 0..n {
                        // Sequential sum over j: the definition.
                        let mut s = 0.0f32;
                        for j in 0..n {
                            s += w[j * n + i] * xs[c * n + j];
                        }
                        assert_eq!(out[c * n + i].to_bits(), s.to_bits(), "n {n}, col {c}, row {i}");
                        assert_eq!(one[i].to_bits(), s.to_bits(), "single column, n {n}");
                        assert_eq!(scalar[c * n + i].to_bits(), s.to_bits(), "scalar path, n {n}");
                    }
                }
            }
        }
    }

    #[test]
    fn tiled_f64_product_is_the_sequential_sum() {
        // 260² f64 = 540 KB: above the tiling threshold.
        let n = 260;
        let w: Vec<f64> = (0..n * n).map(|k| ((k * 7919 % 1000) as f64 - 500.0) / 377.0).collect();
        let xs: Vec<f64> = (0..n * 5).map(|k| ((k * 104_729 % 997) as f64 - 498.0) / 211.0).collect();
        let mut out = vec![0.0; n * 5];
        matmul(&w, n, &xs, &mut out);
        for c in 0..5 {
            for i in 0..n {
                let mut s = 0.0f64;
                for j in 0..n {
                    s += w[j * n + i] * xs[c * n + j];
                }
                assert_eq!(out[c * n + i].to_bits(), s.to_bits(), "col {c}, row {i}");
            }
        }
    }

    #[test]
    fn dot_is_accurate() {
        let a: Vec<f64> = (0..1000).map(|k| (k as f64).sin()).collect();
        let b: Vec<f64> = (0..1000).map(|k| (k as f64 * 0.3).cos()).collect();
        let plain: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
        assert!((dot(&a, &b) - plain).abs() < 1e-12);
    }
}
