//! The inner loops: dot products with a fixed summation order.
//!
//! Every dot product accumulates in 16 lanes (element `i` goes to lane `i % 16`)
//! and reduces the lanes with one fixed tree. The matrix product computes each
//! element as one chain of fused multiply-adds over the terms in order (fused
//! multiply-adds round once, in hardware and in the standard library alike),
//! so a column's result never depends on how many columns are computed
//! together, on the rows or chunks given to each thread, or on the machine.

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
    /// The product of a packed matrix with several columns:
    /// `out[c·np + i] = Σ_{j<n} W[i][j] · xs[c·np + j]` for the rows `i` in
    /// `rows` (multiples of the vector width) of every column `c`. `wt` is
    /// `W` packed by [`pack`] (height `np`, a multiple of [`PAD`], the rows
    /// past the matrix's own being zero); `xs` and `out` hold columns of
    /// height `np`. Each element is a chain of fused multiply-adds over
    /// `j = 0, 1, …, n−1` in order, starting from +0, so its value does not
    /// depend on the instruction set, on the number of columns, on the rows
    /// computed with it, or on which block it falls in.
    fn gemm_simd<S: Simd>(
        simd: S,
        wt: &[Self],
        shape: (usize, usize),
        xs: &[Self],
        out: &mut [Self],
        rows: (usize, usize),
    );
}

// The one exception to the workspace's 120-line bound on functions: the
// SIMD kernels below are written once for `f32` and `f64` by this macro, and
// `gemm_simd` keeps its whole tile loop (panel packing offsets, the chains of
// fused multiply-adds, the row remainder) in one body so that the compiler
// keeps the accumulators in registers and the fixed summation order stays
// visible in one place; splitting it would add calls inside the hot loop.
macro_rules! simd_dot {
    ($t:ty, $v:ident, $n_lanes:ident, $as_simd:ident, $splat:ident, $add:ident, $mul:ident, $fma:ident) => {
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
            fn gemm_simd<S: Simd>(
                simd: S,
                wt: &[$t],
                (np, n): (usize, usize),
                xs: &[$t],
                out: &mut [$t],
                (r0, r1): (usize, usize),
            ) {
                let lanes = S::$n_lanes;
                assert!(n <= np && np % PAD == 0 && PAD % lanes == 0, "padded height {np} for {n} terms");
                assert!(r0 <= r1 && r1 <= np && r0 % lanes == 0 && r1 % lanes == 0, "rows {r0}..{r1} of {np}");
                assert_eq!(wt.len(), np * n);
                assert_eq!(xs.len(), out.len());
                assert!(np > 0 && xs.len() % np == 0);
                let k = xs.len() / np;

                /// Columns `c..c+Q`, the `B` row vectors from row `i` of the
                /// panel `pw` (height `h`, first row `p0`), terms `j0..j1`:
                /// Q·B accumulators in registers, each updated by one fused
                /// multiply-add per term. The running sums start at +0 when
                /// `j0 == 0` and otherwise continue from `out`, so tiling over
                /// `j` leaves every element's sequence of operations unchanged.
                #[inline(always)]
                fn block<S: Simd, const Q: usize, const B: usize>(
                    simd: S,
                    (pw, h, p0): (&[$t], usize, usize),
                    np: usize,
                    xs: &[$t],
                    out: &mut [$t],
                    (c, i): (usize, usize),
                    (j0, j1): (usize, usize),
                ) {
                    let lanes = S::$n_lanes;
                    let z = simd.$splat(0.0);
                    let mut acc = [[z; B]; Q];
                    let row = p0 + i;
                    if j0 > 0 {
                        for q in 0..Q {
                            let at = (c + q) * np + row;
                            let (sv, _) = S::$as_simd(&out[at..at + B * lanes]);
                            acc[q].copy_from_slice(&sv[..B]);
                        }
                    }
                    // Every slice is cut to the tile's length up front and its
                    // length asserted, so the loop's indices need no checks.
                    let len = j1 - j0;
                    let mut x: [&[$t]; Q] = [&[]; Q];
                    for (q, x) in x.iter_mut().enumerate() {
                        let at = (c + q) * np + j0;
                        *x = &xs[at..at + len];
                    }
                    for x in &x {
                        assert_eq!(x.len(), len);
                    }
                    for (jj, col) in (0..len).zip(pw[j0 * h..j1 * h].chunks_exact(h)) {
                        let (col, _) = S::$as_simd(&col[i..i + B * lanes]);
                        let col: &[S::$v; B] = col.try_into().unwrap_or_else(|_| unreachable!());
                        for q in 0..Q {
                            let xj = simd.$splat(x[q][jj]);
                            for b in 0..B {
                                acc[q][b] = simd.$fma(col[b], xj, acc[q][b]);
                            }
                        }
                    }
                    for q in 0..Q {
                        let at = (c + q) * np + row;
                        out[at..at + B * lanes].copy_from_slice(pulp::bytemuck::cast_slice::<S::$v, $t>(&acc[q]));
                    }
                }

                if n == 0 {
                    for c in 0..k {
                        out[c * np + r0..c * np + r1].fill(0.0);
                    }
                    return;
                }
                let wide = lanes * core::mem::size_of::<$t>() >= 64;
                // Terms per tile: a panel's tile stays in the first-level cache
                // while the columns pass over it (32 KB).
                let jt = (32 * 1024 / (PANEL * core::mem::size_of::<$t>())).max(16);
                let mut p0 = r0 / PANEL * PANEL;
                while p0 < r1 {
                    let h = PANEL.min(np - p0);
                    let pw = &wt[p0 * n..(p0 + h) * n];
                    let panel = (pw, h, p0);
                    let (a, b) = (r0.max(p0) - p0, r1.min(p0 + h) - p0);
                    if k == 2 || k == 3 {
                        // Two or three columns: one pass over the panel for
                        // all of them (a long run bound by streaming W costs
                        // little more with a twin beside it).
                        let mut i = a;
                        while i < b {
                            let bw = if wide && k == 2 && i + 8 * lanes <= b {
                                8
                            } else if i + 4 * lanes <= b {
                                4
                            } else if i + 2 * lanes <= b {
                                2
                            } else {
                                1
                            };
                            match (k, bw) {
                                (2, 8) => block::<S, 2, 8>(simd, panel, np, xs, out, (0, i), (0, n)),
                                (2, 4) => block::<S, 2, 4>(simd, panel, np, xs, out, (0, i), (0, n)),
                                (2, 2) => block::<S, 2, 2>(simd, panel, np, xs, out, (0, i), (0, n)),
                                (2, _) => block::<S, 2, 1>(simd, panel, np, xs, out, (0, i), (0, n)),
                                (_, 4) => block::<S, 3, 4>(simd, panel, np, xs, out, (0, i), (0, n)),
                                (_, 2) => block::<S, 3, 2>(simd, panel, np, xs, out, (0, i), (0, n)),
                                _ => block::<S, 3, 1>(simd, panel, np, xs, out, (0, i), (0, n)),
                            }
                            i += bw * lanes;
                        }
                    } else if k < 4 {
                        // One column: the panel streams through once, eight
                        // independent accumulators at most.
                        for c in 0..k {
                            let mut i = a;
                            while i + 8 * lanes <= b {
                                block::<S, 1, 8>(simd, panel, np, xs, out, (c, i), (0, n));
                                i += 8 * lanes;
                            }
                            while i + 4 * lanes <= b {
                                block::<S, 1, 4>(simd, panel, np, xs, out, (c, i), (0, n));
                                i += 4 * lanes;
                            }
                            while i < b {
                                block::<S, 1, 1>(simd, panel, np, xs, out, (c, i), (0, n));
                                i += lanes;
                            }
                        }
                    } else {
                        // Many columns: each tile of the panel is read from the
                        // outer caches once per product, by groups of columns
                        // whose accumulators fill the registers (see `groups`).
                        let mut i = a;
                        while i < b {
                            let bw = if wide && i + 4 * lanes <= b {
                                4
                            } else if i + 2 * lanes <= b {
                                2
                            } else {
                                1
                            };
                            let mut j0 = 0;
                            while j0 < n {
                                let j = (j0, (j0 + jt).min(n));
                                let mut c = 0;
                                for q in groups(k, wide) {
                                    let at = (c, i);
                                    match (q, bw) {
                                        (6, 2) => block::<S, 6, 2>(simd, panel, np, xs, out, at, j),
                                        (6, _) => block::<S, 6, 1>(simd, panel, np, xs, out, at, j),
                                        (5, 2) => block::<S, 5, 2>(simd, panel, np, xs, out, at, j),
                                        (5, _) => block::<S, 5, 1>(simd, panel, np, xs, out, at, j),
                                        (4, 4) => block::<S, 4, 4>(simd, panel, np, xs, out, at, j),
                                        (4, 2) => block::<S, 4, 2>(simd, panel, np, xs, out, at, j),
                                        (4, _) => block::<S, 4, 1>(simd, panel, np, xs, out, at, j),
                                        (3, 4) => block::<S, 3, 4>(simd, panel, np, xs, out, at, j),
                                        (3, 2) => block::<S, 3, 2>(simd, panel, np, xs, out, at, j),
                                        (3, _) => block::<S, 3, 1>(simd, panel, np, xs, out, at, j),
                                        (2, 4) => block::<S, 2, 4>(simd, panel, np, xs, out, at, j),
                                        (2, 2) => block::<S, 2, 2>(simd, panel, np, xs, out, at, j),
                                        (2, _) => block::<S, 2, 1>(simd, panel, np, xs, out, at, j),
                                        (_, 4) => block::<S, 1, 4>(simd, panel, np, xs, out, at, j),
                                        (_, 2) => block::<S, 1, 2>(simd, panel, np, xs, out, at, j),
                                        _ => block::<S, 1, 1>(simd, panel, np, xs, out, at, j),
                                    }
                                    c += q;
                                }
                                j0 = j.1;
                            }
                            i += bw * lanes;
                        }
                    }
                    p0 += h;
                }
            }
        }
    };
}

simd_dot!(f32, f32s, F32_LANES, as_simd_f32s, splat_f32s, add_f32s, mul_f32s, mul_add_f32s);
simd_dot!(f64, f64s, F64_LANES, as_simd_f64s, splat_f64s, add_f64s, mul_f64s, mul_add_f64s);

/// How the many-column product splits `k` columns into groups that share
/// each load of `W`: as many accumulators as the registers hold (four
/// columns × four row vectors in the 32 registers of AVX-512; six × two in
/// the 16 of narrower sets), and no group so small that its few chains of
/// multiply-adds wait on their own latency: on a narrow set, thirty-two
/// columns are four groups of six and two of four, not five of six and two
/// single columns. The sizes sum to `k`.
fn groups(k: usize, wide: bool) -> impl Iterator<Item = usize> {
    let mut rem = k;
    core::iter::from_fn(move || {
        if rem == 0 {
            return None;
        }
        let q = if wide {
            rem.min(4)
        } else {
            match rem {
                13 => 5,
                12.. => 6,
                7 | 8 => 4,
                9 | 10 => 5,
                11 => 6,
                r => r,
            }
        };
        rem -= q;
        Some(q)
    })
}

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

/// Heights of the matrices and vectors of [`matmul`] are multiples of this:
/// every vector width (1, 2, 4, 8 or 16 lanes) divides it.
pub const PAD: usize = 16;

/// `n` rounded up to a multiple of [`PAD`].
pub fn padded(n: usize) -> usize {
    n.div_ceil(PAD) * PAD
}

/// [`matmul_cols`] over every row, in the best instruction set of this machine.
/// `wt` is a matrix packed by [`pack`]; `xs` and `out` are columns of
/// height `padded(n)`.
pub fn matmul<R: SimdDot>(wt: &[R], n: usize, xs: &[R], out: &mut [R]) {
    struct Op<'a, R>(&'a [R], usize, &'a [R], &'a mut [R]);
    impl<R: SimdDot> WithSimd for Op<'_, R> {
        type Output = ();
        #[inline(always)]
        fn with_simd<S: Simd>(self, simd: S) {
            let np = padded(self.1);
            matmul_cols(simd, self.0, (np, self.1), self.2, self.3, (0, np))
        }
    }
    pulp::Arch::new().dispatch(Op(wt, n, xs, out))
}

/// `out[c][i] = Σ_j W[i][j] · xs[c][j]` for every column `c` and the rows
/// `i` in `rows`, with `wt` the matrix packed by [`pack`]; see
/// [`SimdDot::gemm_simd`].
#[inline(always)]
pub fn matmul_cols<R: SimdDot, S: Simd>(
    simd: S,
    wt: &[R],
    shape: (usize, usize),
    xs: &[R],
    out: &mut [R],
    rows: (usize, usize),
) {
    R::gemm_simd(simd, wt, shape, xs, out, rows)
}

/// A buffer whose first element sits on a 64-byte boundary, so that vector
/// loads of 64 bytes never straddle two cache lines (the allocator only
/// promises 16).
#[derive(Debug, Clone)]
pub struct Aligned<R> {
    data: Vec<R>,
    off: usize,
    len: usize,
}

impl<R: Copy + Default> Aligned<R> {
    /// `len` copies of `R::default()`.
    pub fn zeros(len: usize) -> Aligned<R> {
        let size = core::mem::size_of::<R>().max(1);
        let extra = 64 / size;
        let data = vec![R::default(); len + extra];
        let addr = data.as_ptr() as usize;
        let off = ((64 - addr % 64) % 64) / size;
        Aligned { data, off: off.min(extra), len }
    }

    /// The elements.
    pub fn as_slice(&self) -> &[R] {
        &self.data[self.off..self.off + self.len]
    }

    /// The elements, mutably.
    pub fn as_mut_slice(&mut self) -> &mut [R] {
        &mut self.data[self.off..self.off + self.len]
    }
}

/// Rows per panel of a packed matrix.
pub const PANEL: usize = 128;

/// Packs the row-major `n × n` matrix `w` for [`matmul`]: its rows, padded
/// with zeros to `padded(n)`, in panels of [`PANEL`] rows (the last one
/// shorter); within a panel, column `j`'s entries are contiguous. A product
/// reads each panel front to back.
pub fn pack<R: Copy + Default>(w: &[f64], n: usize, conv: impl Fn(f64) -> R) -> Aligned<R> {
    let np = padded(n);
    let mut packed = Aligned::zeros(np * n);
    let t = packed.as_mut_slice();
    let mut p0 = 0;
    while p0 < np {
        let h = PANEL.min(np - p0);
        for j in 0..n {
            for r in 0..h {
                let i = p0 + r;
                if i < n {
                    t[p0 * n + j * h + r] = conv(w[i * n + j]);
                }
            }
        }
        p0 += h;
    }
    packed
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The definition: a chain of fused multiply-adds over the terms in order.
    fn reference<R: Real>(w: &[f64], n: usize, x: &[R], conv: impl Fn(f64) -> R, fma: impl Fn(R, R, R) -> R) -> Vec<R> {
        (0..n)
            .map(|i| {
                let mut s = R::ZERO;
                for j in 0..n {
                    s = fma(conv(w[i * n + j]), x[j], s);
                }
                s
            })
            .collect()
    }

    fn columns(n: usize, k: usize) -> (Vec<f64>, Vec<Vec<f64>>) {
        let w: Vec<f64> = (0..n * n).map(|k| ((k * 7919 % 1000) as f64 - 500.0) / 377.0).collect();
        let xs =
            (0..k).map(|c| (0..n).map(|j| (((c * n + j) * 104_729 % 997) as f64 - 498.0) / 211.0).collect()).collect();
        (w, xs)
    }

    #[test]
    fn every_column_count_and_row_split_gives_the_definition_bit_for_bit() {
        for n in [1, 7, 8, 13, 16, 64, 150, 301] {
            let np = padded(n);
            let (w, xs64) = columns(n, 32);
            let wt = pack(&w, n, |v| v as f32);
            let wt = wt.as_slice();
            for k in [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 32] {
                let mut xs = vec![0.0f32; np * k];
                for c in 0..k {
                    for j in 0..n {
                        xs[c * np + j] = xs64[c][j] as f32;
                    }
                }
                let mut out = vec![f32::NAN; np * k];
                matmul(wt, n, &xs, &mut out);
                let mut scalar = vec![f32::NAN; np * k];
                matmul_cols(pulp::Scalar::new(), wt, (np, n), &xs, &mut scalar, (0, np));
                // Two halves of the rows, as two threads compute them.
                let mut halves = vec![f32::NAN; np * k];
                let mid = (np / 2).div_ceil(PAD) * PAD;
                for rows in [(0, mid), (mid, np)] {
                    struct Op<'a>(&'a [f32], (usize, usize), &'a [f32], &'a mut [f32], (usize, usize));
                    impl WithSimd for Op<'_> {
                        type Output = ();
                        fn with_simd<S: Simd>(self, simd: S) {
                            matmul_cols(simd, self.0, self.1, self.2, self.3, self.4)
                        }
                    }
                    pulp::Arch::new().dispatch(Op(wt, (np, n), &xs, &mut halves, rows));
                }
                for c in 0..k {
                    let def = reference(&w, n, &xs[c * np..c * np + n], |v| v as f32, f32::mul_add);
                    let mut one = vec![0.0; np];
                    matmul(wt, n, &xs[c * np..(c + 1) * np], &mut one);
                    for i in 0..n {
                        let want = def[i].to_bits();
                        assert_eq!(out[c * np + i].to_bits(), want, "n {n}, {k} columns, col {c}, row {i}");
                        assert_eq!(one[i].to_bits(), want, "single column, n {n}");
                        assert_eq!(scalar[c * np + i].to_bits(), want, "scalar path, n {n}");
                        assert_eq!(halves[c * np + i].to_bits(), want, "row halves, n {n}");
                    }
                    assert!(out[c * np + n..(c + 1) * np].iter().all(|v| *v == 0.0), "padding rows are zero");
                }
            }
        }
    }

    #[test]
    fn f64_product_over_several_term_tiles_is_the_definition() {
        // 300 terms: three tiles of the many-column path.
        let n = 300;
        let np = padded(n);
        let (w, xs64) = columns(n, 6);
        let wt = pack(&w, n, |v| v);
        let wt = wt.as_slice();
        let mut xs = vec![0.0f64; np * 6];
        for c in 0..6 {
            xs[c * np..c * np + n].copy_from_slice(&xs64[c]);
        }
        let mut out = vec![0.0; np * 6];
        matmul(wt, n, &xs, &mut out);
        for c in 0..6 {
            let def = reference(&w, n, &xs64[c], |v| v, f64::mul_add);
            for i in 0..n {
                assert_eq!(out[c * np + i].to_bits(), def[i].to_bits(), "col {c}, row {i}");
            }
        }
    }

    #[test]
    fn column_groups_cover_every_column_without_tiny_groups() {
        for wide in [false, true] {
            for k in 4..200 {
                let g: Vec<usize> = groups(k, wide).collect();
                assert_eq!(g.iter().sum::<usize>(), k, "k {k}: {g:?}");
                let most = if wide { 4 } else { 6 };
                assert!(g.iter().all(|&q| (1..=most).contains(&q)), "k {k}: {g:?}");
                if !wide {
                    // At most one group below four columns, and only for k = 7.
                    let small = g.iter().filter(|&&q| q < 4).count();
                    assert_eq!(small, usize::from(k == 7), "k {k}: {g:?}");
                }
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
