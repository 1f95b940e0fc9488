//! Linear algebra whose results do not depend on the machine.
//!
//! Every sum here runs over its terms in one fixed order, one fused
//! multiply-add per term. Vector instructions only process several *output*
//! elements at once, never split one element's sum, so the vector width
//! (scalar, AVX2, AVX-512) changes no bit; a fused multiply-add is exactly
//! rounded on every path (the scalar path calls `mul_add`). Nothing depends
//! on cache sizes or thread counts either. This is what makes a trained
//! model's file the same on every x86-64 machine, which faer's products and
//! eigendecomposition (blocked by the detected cache sizes, dispatched by the
//! detected instruction set) do not promise.
//!
//! - [`at_b`]: `AᵀB` for row-major `A` (`t × n`) and `B` (`t × m`).
//! - [`Tridiagonal`]: a symmetric matrix reduced to `Q T Qᵀ` by Householder
//!   reflections, with shifted solves `(A + λI)⁻¹ B` for any `λ`.

use pulp::{Simd, WithSimd};

/// Widths are padded to a multiple of this (every vector width divides it).
pub const PAD: usize = 16;

/// `n` rounded up to a multiple of [`PAD`].
pub fn padded(n: usize) -> usize {
    n.div_ceil(PAD) * PAD
}

#[inline(always)]
fn fma(a: f64, b: f64, c: f64) -> f64 {
    a.mul_add(b, c)
}

/// `y[i] = a·x[i] + y[i]` (fused) for every `i`.
#[inline(always)]
fn axpy<S: Simd>(simd: S, a: f64, x: &[f64], y: &mut [f64]) {
    let av = simd.splat_f64s(a);
    let (yv, yt) = S::as_mut_simd_f64s(y);
    let (xv, xt) = S::as_simd_f64s(&x[..x.len()]);
    for (yy, xx) in yv.iter_mut().zip(xv) {
        *yy = simd.mul_add_f64s(av, *xx, *yy);
    }
    for (yy, xx) in yt.iter_mut().zip(xt) {
        *yy = fma(a, *xx, *yy);
    }
}

/// `out[i·m + j] = Σ_k a[k·na + i0 + i] · b[k·m + j]` over `k = 0, 1, …, t−1`
/// in order, for rows `i` of `0..rows` and columns `j` of `j0..m` (`m` a
/// multiple of [`PAD`]).
struct AtB<'a> {
    a: &'a [f64],
    na: usize,
    b: &'a [f64],
    m: usize,
    t: usize,
    i0: usize,
    rows: usize,
    j0: usize,
    out: &'a mut [f64],
}

#[inline(always)]
fn tile<S: Simd, const R: usize, const W: usize>(simd: S, p: &mut AtB<'_>, i: usize, j: usize) {
    let l = S::F64_LANES;
    let z = simd.splat_f64s(0.0);
    let mut acc = [[z; W]; R];
    for k in 0..p.t {
        let (bv, _) = S::as_simd_f64s(&p.b[k * p.m + j..k * p.m + j + W * l]);
        let arow = &p.a[k * p.na + p.i0 + i..k * p.na + p.i0 + i + R];
        for r in 0..R {
            let ar = simd.splat_f64s(arow[r]);
            for w in 0..W {
                acc[r][w] = simd.mul_add_f64s(ar, bv[w], acc[r][w]);
            }
        }
    }
    for (r, row) in acc.iter().enumerate() {
        let at = (i + r) * p.m + j;
        p.out[at..at + W * l].copy_from_slice(pulp::bytemuck::cast_slice::<S::f64s, f64>(row));
    }
}

impl WithSimd for AtB<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: Simd>(mut self, simd: S) {
        let l = S::F64_LANES;
        let mut i = 0;
        while i < self.rows {
            let r = (self.rows - i).min(4);
            let mut j = self.j0;
            while j < self.m {
                let w2 = j + 2 * l <= self.m;
                match (r, w2) {
                    (4, true) => tile::<S, 4, 2>(simd, &mut self, i, j),
                    (4, false) => tile::<S, 4, 1>(simd, &mut self, i, j),
                    (3, true) => tile::<S, 3, 2>(simd, &mut self, i, j),
                    (3, false) => tile::<S, 3, 1>(simd, &mut self, i, j),
                    (2, true) => tile::<S, 2, 2>(simd, &mut self, i, j),
                    (2, false) => tile::<S, 2, 1>(simd, &mut self, i, j),
                    (_, true) => tile::<S, 1, 2>(simd, &mut self, i, j),
                    (_, false) => tile::<S, 1, 1>(simd, &mut self, i, j),
                }
                j += if w2 { 2 * l } else { l };
            }
            i += r;
        }
    }
}

/// `AᵀB` (`n × m`, row-major, `m` padded) of row-major `a` (`t × na`, of
/// which the first `n` columns count) and `b` (`t × m`, `m` a multiple of
/// [`PAD`]). With `symmetric` (then `b` is `a` and `m == na`), only the
/// blocks on and above the diagonal are computed and the rest mirrored.
pub fn at_b(a: &[f64], na: usize, n: usize, b: &[f64], m: usize, t: usize, symmetric: bool) -> Vec<f64> {
    at_b_on(pulp::Arch::new(), a, na, n, b, m, t, symmetric)
}

/// [`at_b`] in the instruction set `arch` (the tests run every one).
#[allow(clippy::too_many_arguments)]
pub fn at_b_on(
    arch: pulp::Arch,
    a: &[f64],
    na: usize,
    n: usize,
    b: &[f64],
    m: usize,
    t: usize,
    symmetric: bool,
) -> Vec<f64> {
    assert!(m.is_multiple_of(PAD) && a.len() == t * na && b.len() == t * m && n <= na, "shapes of AᵀB");
    let mut out = vec![0.0; n * m];
    // Rows in bands of PAD: a band's columns start at its own first column
    // when symmetric (each element's sum is the same whichever band computes it).
    let mut i0 = 0;
    while i0 < n {
        let rows = PAD.min(n - i0);
        let j0 = if symmetric { i0 } else { 0 };
        let band = &mut out[i0 * m..(i0 + rows) * m];
        arch.dispatch(AtB { a, na, b, m, t, i0, rows, j0, out: band });
        i0 += rows;
    }
    if symmetric {
        for i in 0..n {
            for j in 0..i.min(m) {
                out[i * m + j] = out[j * m + i];
            }
        }
    }
    out
}

/// `Σ a[k]·b[k]` in order.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |s, (x, y)| fma(*x, *y, s))
}

/// A symmetric `n × n` matrix `A = Q T Qᵀ`: `T` tridiagonal (`diag`, `off`),
/// `Q = H₀H₁⋯H_{n−2}` with `H_k = I − τ_k v_k v_kᵀ` acting on the indices
/// after `k` (`v_k[0] = 1`).
#[derive(Debug, Clone)]
pub struct Tridiagonal {
    arch: pulp::Arch,
    n: usize,
    /// Row `k` holds `v_k` in its columns `k+1..n` (row-major `n × n`).
    reflectors: Vec<f64>,
    tau: Vec<f64>,
    diag: Vec<f64>,
    off: Vec<f64>,
}

/// `p[..] = Σ_j v[j] · rows[j]` for rows of `b` (`m × m` starting at `b0`, stride `n`).
struct Symv<'a> {
    b: &'a [f64],
    n: usize,
    k: usize,
    v: &'a [f64],
    p: &'a mut [f64],
}

impl WithSimd for Symv<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        let (n, k) = (self.n, self.k);
        self.p.fill(0.0);
        for (jj, vj) in self.v.iter().enumerate() {
            let j = k + 1 + jj;
            axpy(simd, *vj, &self.b[j * n + k + 1..(j + 1) * n], self.p);
        }
    }
}

/// `B[i][..] −= v[i]·w + w[i]·v` over the trailing rows and columns.
struct Rank2<'a> {
    b: &'a mut [f64],
    n: usize,
    k: usize,
    v: &'a [f64],
    w: &'a [f64],
}

impl WithSimd for Rank2<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        let (n, k) = (self.n, self.k);
        for ii in 0..self.v.len() {
            let i = k + 1 + ii;
            let row = &mut self.b[i * n + k + 1..(i + 1) * n];
            axpy(simd, -self.w[ii], self.v, row);
            axpy(simd, -self.v[ii], self.w, row);
        }
    }
}

/// `Z[k+1..][..] −= τ·v[i]·(Σ_i v[i]·Z[i][..])` for a row-major `Z` (`n × m`).
struct Reflect<'a> {
    z: &'a mut [f64],
    m: usize,
    k: usize,
    v: &'a [f64],
    tau: f64,
    s: &'a mut [f64],
}

impl WithSimd for Reflect<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        let (m, k) = (self.m, self.k);
        self.s.fill(0.0);
        for (ii, vi) in self.v.iter().enumerate() {
            let i = k + 1 + ii;
            axpy(simd, *vi, &self.z[i * m..(i + 1) * m], self.s);
        }
        for (ii, vi) in self.v.iter().enumerate() {
            let i = k + 1 + ii;
            axpy(simd, -(self.tau * vi), self.s, &mut self.z[i * m..(i + 1) * m]);
        }
    }
}

impl Tridiagonal {
    /// Reduces the symmetric matrix `a` (row-major `n × n`, consumed).
    pub fn new(a: Vec<f64>, n: usize) -> Tridiagonal {
        Tridiagonal::new_on(pulp::Arch::new(), a, n)
    }

    /// [`Tridiagonal::new`] in the instruction set `arch`, which its solves use too.
    pub fn new_on(arch: pulp::Arch, mut a: Vec<f64>, n: usize) -> Tridiagonal {
        assert_eq!(a.len(), n * n, "a square matrix");
        let mut tau = vec![0.0; n.saturating_sub(1)];
        let mut diag = vec![0.0; n];
        let mut off = vec![0.0; n.saturating_sub(1)];
        let mut p = vec![0.0; n];
        let mut w = vec![0.0; n];
        for k in 0..n.saturating_sub(1) {
            let m = n - k - 1;
            diag[k] = a[k * n + k];
            let alpha = a[k * n + k + 1];
            let x = &a[k * n + k + 2..(k + 1) * n];
            let sigma = dot(x, x);
            if sigma == 0.0 {
                // Nothing below the subdiagonal: no reflection (H = I).
                off[k] = alpha;
                a[k * n + k + 1] = 1.0;
                continue;
            }
            let norm = fma(alpha, alpha, sigma).sqrt();
            let beta = if alpha <= 0.0 { norm } else { -norm };
            let v0 = alpha - beta;
            tau[k] = (beta - alpha) / beta;
            off[k] = beta;
            a[k * n + k + 1] = 1.0;
            for x in &mut a[k * n + k + 2..(k + 1) * n] {
                *x /= v0;
            }
            let v = a[k * n + k + 1..(k + 1) * n].to_vec();
            // p = τ·B·v, w = p − (τ/2)(pᵀv)·v, B −= v·wᵀ + w·vᵀ.
            arch.dispatch(Symv { b: &a, n, k, v: &v, p: &mut p[..m] });
            for x in &mut p[..m] {
                *x *= tau[k];
            }
            let half = 0.5 * tau[k] * dot(&p[..m], &v);
            for ((wi, pi), vi) in w[..m].iter_mut().zip(&p[..m]).zip(&v) {
                *wi = fma(-half, *vi, *pi);
            }
            arch.dispatch(Rank2 { b: &mut a, n, k, v: &v, w: &w[..m] });
        }
        if n > 0 {
            diag[n - 1] = a[(n - 1) * n + n - 1];
        }
        Tridiagonal { arch, n, reflectors: a, tau, diag, off }
    }

    /// Size.
    pub fn n(&self) -> usize {
        self.n
    }

    fn reflect(&self, z: &mut [f64], m: usize, k: usize, s: &mut [f64]) {
        if self.tau[k] == 0.0 {
            return;
        }
        let n = self.n;
        let v = &self.reflectors[k * n + k + 1..(k + 1) * n];
        self.arch.dispatch(Reflect { z, m, k, v, tau: self.tau[k], s });
    }

    /// `Qᵀ Z` for a row-major `Z` (`n × m`), in place.
    pub fn apply_qt(&self, z: &mut [f64], m: usize) {
        let mut s = vec![0.0; m];
        for k in 0..self.n.saturating_sub(1) {
            self.reflect(z, m, k, &mut s);
        }
    }

    /// `Q Z` for a row-major `Z` (`n × m`), in place.
    pub fn apply_q(&self, z: &mut [f64], m: usize) {
        let mut s = vec![0.0; m];
        for k in (0..self.n.saturating_sub(1)).rev() {
            self.reflect(z, m, k, &mut s);
        }
    }

    /// `(T + λI)⁻¹ R` for a row-major `R` (`n × m`), in place, by
    /// elimination without pivoting (`T + λI` is positive definite for a
    /// positive semi-definite `A` and `λ > 0`); a pivot rounding made
    /// non-positive is replaced by the smallest positive one, so an
    /// ill-posed penalty gives a huge solution, never a NaN.
    pub fn solve_shifted(&self, lambda: f64, r: &mut [f64], m: usize) {
        let n = self.n;
        if n == 0 {
            return;
        }
        let mut c = vec![0.0; n];
        let pivot = |p: f64| if p > f64::MIN_POSITIVE { p } else { f64::MIN_POSITIVE };
        let mut d = pivot(self.diag[0] + lambda);
        for x in &mut r[..m] {
            *x /= d;
        }
        for i in 1..n {
            c[i - 1] = self.off[i - 1] / d;
            d = pivot(self.diag[i] + lambda - self.off[i - 1] * c[i - 1]);
            for j in 0..m {
                r[i * m + j] = (r[i * m + j] - self.off[i - 1] * r[(i - 1) * m + j]) / d;
            }
        }
        for i in (0..n - 1).rev() {
            for j in 0..m {
                r[i * m + j] -= c[i] * r[(i + 1) * m + j];
            }
        }
    }

    /// The largest eigenvalue, by bisection on Sturm counts (to the last bits).
    pub fn largest_eigenvalue(&self) -> f64 {
        let n = self.n;
        if n == 0 {
            return 0.0;
        }
        let bound = (0..n)
            .map(|i| {
                let l = if i > 0 { self.off[i - 1].abs() } else { 0.0 };
                let r = if i + 1 < n { self.off[i].abs() } else { 0.0 };
                self.diag[i].abs() + l + r
            })
            .fold(0.0, f64::max);
        // Eigenvalues below x: the negative pivots of T − xI.
        let below = |x: f64| {
            let mut count = 0;
            let mut q = self.diag[0] - x;
            for i in 0..n {
                if i > 0 {
                    let prev = if q == 0.0 { f64::MIN_POSITIVE } else { q };
                    q = self.diag[i] - x - self.off[i - 1] * self.off[i - 1] / prev;
                }
                if q < 0.0 {
                    count += 1;
                }
            }
            count
        };
        let (mut lo, mut hi) = (-bound, bound);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if below(mid) >= n { hi = mid } else { lo = mid }
        }
        hi
    }
}

/// Every instruction set this machine runs: scalar, then the vector sets.
pub fn every_arch() -> Vec<pulp::Arch> {
    #[allow(unused_mut)]
    let mut v = vec![pulp::Arch::Scalar];
    #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
    {
        if let Some(s) = pulp::x86::V3::try_new() {
            v.push(pulp::Arch::V3(s));
        }
        if let Some(s) = pulp::x86::V4::try_new() {
            v.push(pulp::Arch::V4(s));
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sym(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let t = 3 * n;
        let x: Vec<f64> = (0..t * n).map(|_| next()).collect();
        let mut g = vec![0.0; n * n];
        for k in 0..t {
            for i in 0..n {
                for j in 0..n {
                    g[i * n + j] += x[k * n + i] * x[k * n + j];
                }
            }
        }
        g
    }

    #[test]
    fn at_b_is_the_product_and_the_same_bits_on_every_path() {
        let (t, n) = (37, 21);
        let na = padded(n);
        let a: Vec<f64> =
            (0..t * na).map(|i| if i % na < n { ((i * 7919) % 101) as f64 / 17.0 - 3.0 } else { 0.0 }).collect();
        let g = at_b(&a, na, n, &a, na, t, true);
        let full = at_b(&a, na, n, &a, na, t, false);
        for i in 0..n {
            for j in 0..n {
                let want: f64 = (0..t).fold(0.0, |s, k| a[k * na + i].mul_add(a[k * na + j], s));
                assert_eq!(g[i * na + j].to_bits(), want.to_bits(), "({i}, {j})");
                assert_eq!(full[i * na + j].to_bits(), want.to_bits());
            }
        }
    }

    #[test]
    fn every_instruction_set_gives_the_same_bits() {
        let n = 45;
        let g = sym(n, 11);
        let m = 5;
        let b: Vec<f64> = (0..n * m).map(|i| (i as f64 * 0.91).cos()).collect();
        let (t, na) = (60, padded(n));
        let a: Vec<f64> =
            (0..t * na).map(|i| if i % na < n { ((i * 31) % 97) as f64 / 13.0 - 3.5 } else { 0.0 }).collect();
        let mut seen: Vec<(Vec<u64>, Vec<u64>)> = Vec::new();
        for arch in every_arch() {
            let ab: Vec<u64> = at_b_on(arch, &a, na, n, &a, na, t, true).iter().map(|x| x.to_bits()).collect();
            let tri = Tridiagonal::new_on(arch, g.clone(), n);
            let mut z = b.clone();
            tri.apply_qt(&mut z, m);
            tri.solve_shifted(1e-3, &mut z, m);
            tri.apply_q(&mut z, m);
            seen.push((ab, z.iter().map(|x| x.to_bits()).collect()));
        }
        #[cfg(target_arch = "x86_64")]
        assert!(seen.len() >= 2, "only the scalar path could be tried");
        for s in &seen[1..] {
            assert!(*s == seen[0], "an instruction set changed the bits");
        }
    }

    #[test]
    fn a_shifted_solve_inverts_the_matrix() {
        let n = 30;
        let g = sym(n, 3);
        let tri = Tridiagonal::new(g.clone(), n);
        let m = 3;
        let b: Vec<f64> = (0..n * m).map(|i| (i as f64 * 0.37).sin()).collect();
        let lambda = 0.5;
        let mut z = b.clone();
        tri.apply_qt(&mut z, m);
        tri.solve_shifted(lambda, &mut z, m);
        tri.apply_q(&mut z, m);
        for i in 0..n {
            for j in 0..m {
                let lhs: f64 = (0..n).map(|k| g[i * n + k] * z[k * m + j]).sum::<f64>() + lambda * z[i * m + j];
                assert!((lhs - b[i * m + j]).abs() < 1e-10, "({i}, {j}): {lhs} against {}", b[i * m + j]);
            }
        }
        // The largest eigenvalue: the Rayleigh quotient of no vector exceeds it, power iteration reaches it.
        let top = tri.largest_eigenvalue();
        let mut v = vec![1.0; n];
        for _ in 0..2000 {
            let w: Vec<f64> = (0..n).map(|i| (0..n).map(|k| g[i * n + k] * v[k]).sum()).collect();
            let norm = w.iter().map(|x| x * x).sum::<f64>().sqrt();
            v = w.iter().map(|x| x / norm).collect();
        }
        let rq: f64 = (0..n).map(|i| v[i] * (0..n).map(|k| g[i * n + k] * v[k]).sum::<f64>()).sum();
        assert!((top - rq).abs() < 1e-9 * top, "{top} against {rq}");
    }
}
