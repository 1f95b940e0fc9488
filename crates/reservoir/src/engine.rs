//! The reservoir dynamics in one precision:
//! `x[k+1] = (1−λ)·x[k] + λ·f(W·x[k] + W_in·u[k] + W_fb·y[k] + b)`, `y[k] = W_out·x[k] + b_out`.

use cpg_regression::Readout;

use crate::config::Activation;
use pulp::{Simd, WithSimd};

use crate::kernel::{SimdDot, matmul_cols};
use crate::reservoir::Reservoir;

/// Weights converted to the working precision, laid out for the inner loops.
#[derive(Debug, Clone)]
pub(crate) struct Engine<R: SimdDot> {
    pub n: usize,
    pub d: usize,
    pub u: usize,
    /// Recurrent weights transposed (column-major W): column `j` is contiguous.
    wt: Vec<R>,
    /// Feedback weights transposed: `D × N`, one contiguous column per output.
    fb_t: Vec<R>,
    /// Input weights transposed: `U × N`.
    in_t: Vec<R>,
    /// Bias minus the input weights times the input centers.
    bias: Vec<R>,
    leak: R,
    keep: R,
    /// Leak rate as `f64`, for a tempo input.
    leak_f64: f64,
    /// The control input that multiplies the leak rate.
    tempo: Option<usize>,
    logistic: bool,
    /// The instruction set the hot loops are compiled for, detected at run
    /// time (AVX2 where present). Results do not depend on it: the loops do
    /// the same lane-wise multiplications and additions, never fused.
    arch: pulp::Arch,
}

/// A readout in the working precision: `D × N` weights and `D` biases.
#[derive(Debug, Clone)]
pub(crate) struct ReadoutR<R: SimdDot> {
    w: Vec<R>,
    b: Vec<R>,
}

impl<R: SimdDot> ReadoutR<R> {
    pub fn new(r: &Readout) -> ReadoutR<R> {
        ReadoutR {
            w: r.weights.iter().map(|&v| R::from_f64(v)).collect(),
            b: r.bias.iter().map(|&v| R::from_f64(v)).collect(),
        }
    }

    /// `y = W_out·x + b_out`.
    #[inline(always)]
    pub fn apply<S: Simd>(&self, simd: S, x: &[R], y: &mut [R]) {
        let n = x.len();
        for (k, yk) in y.iter_mut().enumerate() {
            *yk = R::dot_simd(simd, &self.w[k * n..(k + 1) * n], x) + self.b[k];
        }
    }

    /// [`apply`](Self::apply) in the best instruction set of this machine.
    pub fn apply_dispatch(&self, arch: pulp::Arch, x: &[R], y: &mut [R]) {
        struct Op<'a, R: SimdDot>(&'a ReadoutR<R>, &'a [R], &'a mut [R]);
        impl<R: SimdDot> WithSimd for Op<'_, R> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: Simd>(self, simd: S) {
                self.0.apply(simd, self.1, self.2)
            }
        }
        arch.dispatch(Op(self, x, y))
    }
}

fn transpose<R: SimdDot>(m: &[f64], rows: usize, cols: usize) -> Vec<R> {
    let mut t = Vec::with_capacity(rows * cols);
    for c in 0..cols {
        t.extend((0..rows).map(|r| R::from_f64(m[r * cols + c])));
    }
    t
}

impl<R: SimdDot> Engine<R> {
    pub fn new(res: &Reservoir) -> Engine<R> {
        let c = res.config();
        let (n, d, u) = (res.n_neurons(), res.n_outputs(), res.n_inputs());
        // An input with a center drives (u − center): fold −W_in·center into the bias.
        let w_in = res.w_input();
        let bias = res
            .bias()
            .iter()
            .enumerate()
            .map(|(i, &b)| {
                let shift: f64 = c.inputs.iter().enumerate().map(|(k, cp)| w_in[i * u + k] * cp.center).sum();
                R::from_f64(b - shift)
            })
            .collect();
        Engine {
            n,
            d,
            u,
            wt: transpose(res.w(), n, n),
            fb_t: transpose(res.w_feedback(), n, d),
            in_t: transpose(w_in, n, u),
            bias,
            leak: R::from_f64(c.leak_rate),
            keep: R::from_f64(1.0 - c.leak_rate),
            leak_f64: c.leak_rate,
            tempo: c.tempo_input,
            logistic: c.activation == Activation::Logistic,
            arch: pulp::Arch::new(),
        }
    }

    /// Completes an update once `pre` holds `W·x`: adds bias, feedback and
    /// inputs, applies `f`, integrates with the leak rate, adds `noise`.
    #[inline(always)]
    fn finish(&self, x: &mut [R], pre: &mut [R], y: &[R], u: &[R], noise: Option<&[R]>) {
        for (p, b) in pre.iter_mut().zip(&self.bias) {
            *p = *p + *b;
        }
        for (k, &yk) in y.iter().enumerate() {
            for (p, wv) in pre.iter_mut().zip(&self.fb_t[k * self.n..(k + 1) * self.n]) {
                *p = *p + *wv * yk;
            }
        }
        for (k, &uk) in u.iter().enumerate() {
            for (p, wv) in pre.iter_mut().zip(&self.in_t[k * self.n..(k + 1) * self.n]) {
                *p = *p + *wv * uk;
            }
        }
        let (leak, keep) = match self.tempo {
            Some(k) => {
                let l = (self.leak_f64 * u[k].to_f64()).clamp(0.0, 1.0);
                (R::from_f64(l), R::from_f64(1.0 - l))
            }
            None => (self.leak, self.keep),
        };
        if self.logistic {
            let half = R::from_f64(0.5);
            for (xi, p) in x.iter_mut().zip(pre.iter()) {
                let f = half + half * (*p * half).tanh_det();
                *xi = keep * *xi + leak * f;
            }
        } else {
            for (xi, p) in x.iter_mut().zip(pre.iter()) {
                *xi = keep * *xi + leak * p.tanh_det();
            }
        }
        if let Some(noise) = noise {
            for (xi, e) in x.iter_mut().zip(noise) {
                *xi = *xi + *e;
            }
        }
    }

    /// One update of one state vector. `pre` is scratch of length N.
    pub fn update(&self, x: &mut [R], y: &[R], u: &[R], pre: &mut [R], noise: Option<&[R]>) {
        struct Op<'a, R: SimdDot>(&'a Engine<R>, &'a mut [R], &'a [R], &'a [R], &'a mut [R], Option<&'a [R]>);
        impl<R: SimdDot> WithSimd for Op<'_, R> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: Simd>(self, simd: S) {
                self.0.update_simd(simd, self.1, self.2, self.3, self.4, self.5)
            }
        }
        self.arch.dispatch(Op(self, x, y, u, pre, noise))
    }

    /// The instruction-set handle the engine dispatches with.
    pub fn arch(&self) -> pulp::Arch {
        self.arch
    }

    #[inline(always)]
    fn update_simd<S: Simd>(&self, simd: S, x: &mut [R], y: &[R], u: &[R], pre: &mut [R], noise: Option<&[R]>) {
        R::gemm_simd(simd, &self.wt, self.n, x, pre);
        self.finish(x, pre, y, u, noise);
    }

    /// Teacher forcing: feeds `teacher[k]` (and `controls[k]`) for every row
    /// `k`, calling `record(k, x)` with the state after each update (the state
    /// whose readout should predict `teacher[k + 1]`).
    pub fn teacher_force(&self, x: &mut [R], teacher: &[f64], controls: &[f64], record: impl FnMut(usize, &[R])) {
        struct Op<'a, R: SimdDot, F>(&'a Engine<R>, &'a mut [R], &'a [f64], &'a [f64], F);
        impl<R: SimdDot, F: FnMut(usize, &[R])> WithSimd for Op<'_, R, F> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: Simd>(self, simd: S) {
                self.0.teacher_force_simd(simd, self.1, self.2, self.3, self.4)
            }
        }
        self.arch.dispatch(Op(self, x, teacher, controls, record))
    }

    #[inline(always)]
    fn teacher_force_simd<S: Simd>(
        &self,
        simd: S,
        x: &mut [R],
        teacher: &[f64],
        controls: &[f64],
        mut record: impl FnMut(usize, &[R]),
    ) {
        let t = teacher.len() / self.d;
        let mut y = vec![R::ZERO; self.d];
        let mut u = vec![R::ZERO; self.u];
        let mut pre = vec![R::ZERO; self.n];
        for k in 0..t {
            for (a, b) in y.iter_mut().zip(&teacher[k * self.d..(k + 1) * self.d]) {
                *a = R::from_f64(*b);
            }
            for (a, b) in u.iter_mut().zip(&controls[k * self.u..(k + 1) * self.u]) {
                *a = R::from_f64(*b);
            }
            self.update_simd(simd, x, &y, &u, &mut pre, None);
            record(k, x);
        }
    }

    /// Free runs of several columns at once (see [`Batch`]). Each step is one
    /// batched product `W·[x_1 … x_K]`. While a hold is active its values
    /// replace the fed-back outputs of every column. `sink(step, column, y)`
    /// receives each column's output before it is fed back; it returns
    /// `false` to stop reporting that column.
    pub fn free_run_batch(&self, batch: &Batch<'_, R>, sink: &mut dyn FnMut(usize, usize, &[R]) -> bool) {
        struct Op<'a, 'b, R: SimdDot>(&'a Engine<R>, &'a Batch<'a, R>, &'b mut dyn FnMut(usize, usize, &[R]) -> bool);
        impl<R: SimdDot> WithSimd for Op<'_, '_, R> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: Simd>(self, simd: S) {
                self.0.free_run_batch_simd(simd, self.1, self.2)
            }
        }
        self.arch.dispatch(Op(self, batch, sink))
    }

    #[inline(always)]
    fn free_run_batch_simd<S: Simd>(
        &self,
        simd: S,
        batch: &Batch<'_, R>,
        sink: &mut dyn FnMut(usize, usize, &[R]) -> bool,
    ) {
        let Batch { steps, x0, readouts, noises, controls, holds } = *batch;
        let (n, d) = (self.n, self.d);
        let k_cols = readouts.len();
        let mut xs: Vec<R> = x0.iter().copied().cycle().take(n * k_cols).collect();
        let mut pre = vec![R::ZERO; n * k_cols];
        let mut ys = vec![R::ZERO; d * k_cols];
        let mut u = vec![R::ZERO; self.u];
        let mut live = vec![true; k_cols];
        let mut held: Vec<R> = vec![R::ZERO; d];
        for s in 0..steps {
            if !live.iter().any(|l| *l) {
                break;
            }
            for c in 0..k_cols {
                let y = &mut ys[c * d..(c + 1) * d];
                readouts[c].apply(simd, &xs[c * n..(c + 1) * n], y);
                if live[c] {
                    live[c] = sink(s, c, y);
                }
            }
            let hold = holds.iter().find(|h| (h.from..h.from + h.len).contains(&s));
            if let Some(h) = hold {
                for (a, b) in held.iter_mut().zip(&h.values) {
                    *a = R::from_f64(*b);
                }
            }
            for (a, b) in u.iter_mut().zip(&controls[s * self.u..(s + 1) * self.u]) {
                *a = R::from_f64(*b);
            }
            matmul_cols(simd, &self.wt, n, &xs, &mut pre);
            for c in 0..k_cols {
                let noise = noises[c].map(|z| &z[s * n..(s + 1) * n]);
                let fed = if hold.is_some() { &held[..] } else { &ys[c * d..(c + 1) * d] };
                self.finish(&mut xs[c * n..(c + 1) * n], &mut pre[c * n..(c + 1) * n], fed, &u, noise);
            }
        }
    }
}

/// The free runs advanced together by [`Engine::free_run_batch`]: columns
/// with their own readout and noise, from one start state, under the same
/// controls and holds. `controls` and every noise sequence cover `steps` steps.
#[derive(Clone, Copy)]
pub(crate) struct Batch<'a, R: SimdDot> {
    /// Steps to run.
    pub steps: usize,
    /// The common start state (length N).
    pub x0: &'a [R],
    /// One readout per column.
    pub readouts: &'a [&'a ReadoutR<R>],
    /// One noise sequence (`steps × N`) or none per column.
    pub noises: &'a [Option<&'a [R]>],
    /// `steps × U` control values.
    pub controls: &'a [f64],
    /// Held outputs.
    pub holds: &'a [Hold],
}

/// During steps `from .. from + len` of a validation free run, the fed-back
/// outputs are held at `values` (normalised units): the paper's perturbation.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Hold {
    /// First held step.
    pub from: usize,
    /// Number of held steps.
    pub len: usize,
    /// One value per output.
    pub values: Vec<f64>,
}
