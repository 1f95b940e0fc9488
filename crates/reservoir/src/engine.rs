//! The reservoir dynamics in one precision:
//! `x[k+1] = (1−λ)·x[k] + λ·f(ρ·(Ŵ·x[k]) + W_in·u[k] + W_fb·y[k] + b)`, `y[k] = W_out·x[k] + b_out`,
//! with `Ŵ` the recurrent weights at spectral radius 1 and `ρ` the radius.
//!
//! What several streams can share is split from what each has of its own:
//! [`Shared`] holds `Ŵ` (the only large matrix), [`Dynamics`] the radius, leak
//! rate, couplings and biases of one stream. Streams whose reservoirs have
//! the same `Ŵ` (same size, connectivity and seed) advance together, one
//! matrix product per step for all of them, whatever else differs.

use cpg_regression::Readout;
use pulp::{Simd, WithSimd};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::config::Activation;
use crate::kernel::{Aligned, SimdDot, matmul_cols, pack, padded};
use crate::reservoir::Reservoir;

/// `Ŵ` converted to the working precision and packed for the product
/// ([`crate::kernel::pack`]: panels of rows, padded to a height of `np`).
#[derive(Debug, Clone)]
pub(crate) struct Shared<R: SimdDot> {
    /// Neurons.
    pub n: usize,
    /// Padded height of states and columns (a multiple of [`crate::kernel::PAD`]).
    pub np: usize,
    /// Outputs.
    pub d: usize,
    /// Control inputs.
    pub u: usize,
    wt: Aligned<R>,
    /// The instruction set the hot loops are compiled for, detected at run
    /// time. Results do not depend on it (see [`crate::kernel`]).
    arch: pulp::Arch,
}

impl<R: SimdDot> Shared<R> {
    pub fn new(res: &Reservoir) -> Shared<R> {
        let n = res.n_neurons();
        Shared {
            n,
            np: padded(n),
            d: res.n_outputs(),
            u: res.n_inputs(),
            wt: pack(res.w_unit(), n, R::from_f64),
            arch: pulp::Arch::new(),
        }
    }

    /// `pre[c] = Ŵ·xs[c]` for the rows `rows` of every column (height `np`).
    #[inline(always)]
    pub fn product<S: Simd>(&self, simd: S, xs: &[R], pre: &mut [R], rows: (usize, usize)) {
        matmul_cols(simd, self.wt.as_slice(), (self.np, self.n), xs, pre, rows);
    }
}

/// One stream's own part of the dynamics, in the working precision.
#[derive(Debug, Clone)]
pub(crate) struct Dynamics<R: SimdDot> {
    rho: R,
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
}

fn transpose<R: SimdDot>(m: &[f64], rows: usize, cols: usize) -> Vec<R> {
    let mut t = Vec::with_capacity(rows * cols);
    for c in 0..cols {
        t.extend((0..rows).map(|r| R::from_f64(m[r * cols + c])));
    }
    t
}

impl<R: SimdDot> Dynamics<R> {
    pub fn new(res: &Reservoir) -> Dynamics<R> {
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
        Dynamics {
            rho: R::from_f64(c.spectral_radius),
            fb_t: transpose(res.w_feedback(), n, d),
            in_t: transpose(w_in, n, u),
            bias,
            leak: R::from_f64(c.leak_rate),
            keep: R::from_f64(1.0 - c.leak_rate),
            leak_f64: c.leak_rate,
            tempo: c.tempo_input,
            logistic: c.activation == Activation::Logistic,
        }
    }

    /// Completes an update of the `N` neurons once `pre` holds their
    /// `Ŵ·x`: scales by the radius, adds bias, feedback and inputs, applies
    /// `f`, integrates with the leak rate, adds `noise`.
    #[inline(always)]
    pub fn finish(&self, x: &mut [R], pre: &mut [R], y: &[R], u: &[R], noise: Option<&[R]>) {
        self.finish_rows(0, x, pre, y, u, noise)
    }

    /// [`finish`](Self::finish) for the neurons `i0 .. i0 + x.len()` only:
    /// every neuron's update is its own, so rows finished apart give the
    /// same bits as rows finished together.
    #[inline(always)]
    pub fn finish_rows(&self, i0: usize, x: &mut [R], pre: &mut [R], y: &[R], u: &[R], noise: Option<&[R]>) {
        let n = self.bias.len();
        let i1 = i0 + x.len();
        debug_assert!(pre.len() == x.len() && i1 <= n);
        for (p, b) in pre.iter_mut().zip(&self.bias[i0..i1]) {
            *p = self.rho * *p;
            *p = *p + *b;
        }
        for (k, &yk) in y.iter().enumerate() {
            for (p, wv) in pre.iter_mut().zip(&self.fb_t[k * n + i0..k * n + i1]) {
                *p = *p + *wv * yk;
            }
        }
        for (k, &uk) in u.iter().enumerate() {
            for (p, wv) in pre.iter_mut().zip(&self.in_t[k * n + i0..k * n + i1]) {
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
}

/// One reservoir's dynamics: the shared `Ŵ` and its own scalars.
#[derive(Debug, Clone)]
pub(crate) struct Engine<R: SimdDot> {
    pub shared: Shared<R>,
    pub dynamics: Dynamics<R>,
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

    /// `y = W_out·x + b_out` for the first `N` values of `x`.
    #[inline(always)]
    pub fn apply<S: Simd>(&self, simd: S, x: &[R], y: &mut [R]) {
        let n = self.w.len() / self.b.len().max(1);
        let x = &x[..n];
        // Four outputs at a time: four independent chains of additions
        // instead of one that waits on its own latency. The state takes the
        // place of the shared row; products commute exactly, so each output
        // has the bits `dot_simd` gives it.
        let row = |k: usize| &self.w[k * n..(k + 1) * n];
        let whole = y.len() / 4 * 4;
        let (quads, rest) = y.split_at_mut(whole);
        for (k, yq) in (0..).step_by(4).zip(quads.chunks_exact_mut(4)) {
            let d = R::dot4_simd(simd, x, [row(k), row(k + 1), row(k + 2), row(k + 3)]);
            for ((yk, dk), bk) in yq.iter_mut().zip(d).zip(&self.b[k..k + 4]) {
                *yk = dk + *bk;
            }
        }
        for (k, yk) in (whole..).zip(rest) {
            *yk = R::dot_simd(simd, row(k), x) + self.b[k];
        }
    }
}

impl<R: SimdDot> Engine<R> {
    pub fn new(res: &Reservoir) -> Engine<R> {
        Engine { shared: Shared::new(res), dynamics: Dynamics::new(res) }
    }

    /// A state of the padded height, from `N` values.
    pub fn state(&self, x: &[f64]) -> Aligned<R> {
        let mut s = Aligned::zeros(self.shared.np);
        for (a, b) in s.as_mut_slice().iter_mut().zip(x) {
            *a = R::from_f64(*b);
        }
        s
    }

    /// The instruction-set handle the engine dispatches with.
    pub fn arch(&self) -> pulp::Arch {
        self.shared.arch
    }

    /// One update of one state vector (padded height) inside code compiled
    /// for `simd`. `pre` is scratch of the same height.
    #[inline(always)]
    pub fn update_simd<S: Simd>(&self, simd: S, x: &mut [R], y: &[R], u: &[R], pre: &mut [R], noise: Option<&[R]>) {
        let (n, np) = (self.shared.n, self.shared.np);
        self.shared.product(simd, x, pre, (0, np));
        self.dynamics.finish(&mut x[..n], &mut pre[..n], y, u, noise);
    }

    /// Teacher forcing: feeds `teacher[k]` (and `controls[k]`) for every row
    /// `k`, calling `record(k, x)` with the state after each update (the state
    /// whose readout should predict `teacher[k + 1]`). `x` has the padded height.
    pub fn teacher_force(&self, x: &mut [R], teacher: &[f64], controls: &[f64], record: impl FnMut(usize, &[R])) {
        let d = self.shared.d;
        let t = teacher.len() / d.max(1);
        self.drive(x, controls, t, |k, _, fed| fed.copy_from_slice(&teacher[k * d..(k + 1) * d]), record)
    }

    /// Drives the reservoir for `t` steps, the caller choosing what is fed
    /// back: before step `k`, `feed(k, x, fed)` sees the state (its first N
    /// values) and writes the `D` fed-back outputs; after it, `record(k, x)`
    /// sees the new state. Teacher forcing feeds the teacher; training on the
    /// network's own output feeds its readout. Allocates only before the first step.
    pub fn drive(
        &self,
        x: &mut [R],
        controls: &[f64],
        t: usize,
        feed: impl FnMut(usize, &[R], &mut [f64]),
        record: impl FnMut(usize, &[R]),
    ) {
        struct Op<'a, R: SimdDot, F, G>(&'a Engine<R>, &'a mut [R], &'a [f64], usize, F, G);
        impl<R: SimdDot, F: FnMut(usize, &[R], &mut [f64]), G: FnMut(usize, &[R])> WithSimd for Op<'_, R, F, G> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: Simd>(self, simd: S) {
                self.0.drive_simd(simd, self.1, self.2, self.3, self.4, self.5)
            }
        }
        self.shared.arch.dispatch(Op(self, x, controls, t, feed, record))
    }

    #[inline(always)]
    fn drive_simd<S: Simd>(
        &self,
        simd: S,
        x: &mut [R],
        controls: &[f64],
        t: usize,
        mut feed: impl FnMut(usize, &[R], &mut [f64]),
        mut record: impl FnMut(usize, &[R]),
    ) {
        let Shared { n, np, d, u, .. } = self.shared;
        let mut fed = vec![0.0; d];
        let mut y = vec![R::ZERO; d];
        let mut uu = vec![R::ZERO; u];
        let mut pre_buf = Aligned::zeros(np);
        let pre = pre_buf.as_mut_slice();
        // A cancelled watch ends the pass early; the caller's `watch::check` then returns the error.
        let watch = crate::watch::current();
        for k in 0..t {
            if k.is_multiple_of(crate::watch::CHECK_EVERY_STEPS) && watch.as_ref().is_some_and(|w| w.cancelled()) {
                return;
            }
            feed(k, &x[..n], &mut fed);
            for (a, b) in y.iter_mut().zip(&fed) {
                *a = R::from_f64(*b);
            }
            for (a, b) in uu.iter_mut().zip(&controls[k * u..(k + 1) * u]) {
                *a = R::from_f64(*b);
            }
            self.update_simd(simd, x, &y, &uu, pre, None);
            record(k, &x[..n]);
        }
    }
}

/// Where a column's state noise comes from.
#[derive(Clone, Copy)]
pub(crate) enum NoiseSource<'a, R: SimdDot> {
    /// None.
    Off,
    /// Precomputed, `steps × N` (validation's common random numbers).
    Table(&'a [R]),
    /// Drawn as the [`Generator`](crate::Generator) draws it: `N` normals
    /// per step from the stream of `seed`, times `sigma`.
    Drawn { seed: u64, sigma: f64 },
}

/// Where a column's control values come from.
#[derive(Clone, Copy)]
pub(crate) enum ControlSource<'a> {
    /// `steps × U`, precomputed.
    Table(&'a [f64]),
    /// A function of the step.
    Fn(&'a (dyn crate::controls::Controls + 'a)),
}

/// One free run of a batch: its own dynamics, readout, start, noise,
/// controls and holds, sharing `Ŵ` with the rest.
#[derive(Clone, Copy)]
pub(crate) struct Column<'a, R: SimdDot> {
    pub dynamics: &'a Dynamics<R>,
    pub readout: &'a ReadoutR<R>,
    /// Start state, `N` values.
    pub x0: &'a [R],
    pub noise: NoiseSource<'a, R>,
    pub controls: ControlSource<'a>,
    pub holds: &'a [Hold],
}

impl<R: SimdDot> Column<'_, R> {
    /// The values fed back at step `s` (the outputs `y`, or a hold's values)
    /// into `fed`, and the control values of step `s` into `us` (`ctl` is
    /// scratch of the controls' width). Every runner calls this, so the paths
    /// give the same bits.
    #[inline(always)]
    fn inputs(&self, s: usize, y: &[R], fed: &mut [R], us: &mut [R], ctl: &mut [f64]) {
        match self.holds.iter().find(|h| (h.from..h.from + h.len).contains(&s)) {
            Some(h) => {
                for (a, b) in fed.iter_mut().zip(&h.values) {
                    *a = R::from_f64(*b);
                }
            }
            None => fed.copy_from_slice(y),
        }
        let u = us.len();
        match self.controls {
            ControlSource::Table(t) => {
                for (a, b) in us.iter_mut().zip(&t[s * u..(s + 1) * u]) {
                    *a = R::from_f64(*b);
                }
            }
            ControlSource::Fn(f) => {
                f.fill(s, ctl);
                for (a, b) in us.iter_mut().zip(ctl.iter()) {
                    *a = R::from_f64(*b);
                }
            }
        }
    }
}

/// Receives a column's outputs, step by step, before they are fed back.
pub(crate) trait Observer<R> {
    /// Output `y` of step `step`; `false` stops the column (it diverged or is done).
    fn see(&mut self, step: usize, y: &[R]) -> bool;
}

impl<R, F: FnMut(usize, &[R]) -> bool> Observer<R> for F {
    fn see(&mut self, step: usize, y: &[R]) -> bool {
        self(step, y)
    }
}

/// What a free-run loop steps in, allocated once before its first step:
/// every column's state (started at its `x0`) and products, padded to `np`
/// rows each, and its outputs, fed-back values and inputs; one control row.
struct StepBuffers<R> {
    xs: Aligned<R>,
    pre: Aligned<R>,
    ys: Vec<R>,
    fed: Vec<R>,
    us: Vec<R>,
    ctl: Vec<f64>,
}

impl<R: SimdDot> StepBuffers<R> {
    fn new(shared: &Shared<R>, columns: &[Column<'_, R>]) -> StepBuffers<R> {
        let Shared { n, np, d, u, .. } = *shared;
        let k = columns.len();
        let mut xs = Aligned::zeros(np * k);
        for (c, col) in columns.iter().enumerate() {
            xs.as_mut_slice()[c * np..c * np + n].copy_from_slice(&col.x0[..n]);
        }
        StepBuffers {
            xs,
            pre: Aligned::zeros(np * k),
            ys: vec![R::ZERO; d * k],
            fed: vec![R::ZERO; d * k],
            us: vec![R::ZERO; u * k],
            ctl: vec![0.0; u],
        }
    }
}

/// Advances `columns` together for `steps` steps, one product `Ŵ·[x_1 … x_K]`
/// per step; `observers[c]` sees column `c`'s outputs, and a column whose
/// observer returns `false` is advanced no further (the product shrinks).
/// A column's results do not depend on the other columns, their number or
/// their order. Everything is allocated before the first step.
pub(crate) fn run_columns<R: SimdDot, O: Observer<R>>(
    shared: &Shared<R>,
    columns: &[Column<'_, R>],
    observers: &mut [O],
    steps: usize,
) {
    struct Op<'a, 'b, R: SimdDot, O>(&'a Shared<R>, &'a [Column<'b, R>], &'a mut [O], usize);
    impl<R: SimdDot, O: Observer<R>> WithSimd for Op<'_, '_, R, O> {
        type Output = ();
        #[inline(always)]
        fn with_simd<S: Simd>(self, simd: S) {
            run_columns_simd(simd, self.0, self.1, self.2, self.3)
        }
    }
    assert_eq!(columns.len(), observers.len());
    shared.arch.dispatch(Op(shared, columns, observers, steps))
}

#[inline(always)]
fn run_columns_simd<S: Simd, R: SimdDot, O: Observer<R>>(
    simd: S,
    shared: &Shared<R>,
    columns: &[Column<'_, R>],
    observers: &mut [O],
    steps: usize,
) {
    let Shared { n, np, d, u, .. } = *shared;
    let k = columns.len();
    let mut bufs = StepBuffers::new(shared, columns);
    let StepBuffers { xs, pre, ys, fed, us, ctl } = &mut bufs;
    let (xs, pre) = (xs.as_mut_slice(), pre.as_mut_slice());
    let mut noise = vec![R::ZERO; n];
    let mut rngs: Vec<Option<(ChaCha8Rng, f64)>> = columns
        .iter()
        .map(|c| match c.noise {
            NoiseSource::Drawn { seed, sigma } => Some((crate::reservoir::rng(seed, 9_000), sigma)),
            _ => None,
        })
        .collect();
    // Slot i of the buffers holds column slot_of[i]; columns whose observer
    // has stopped leave the first `live` slots, so the product skips them.
    let mut slot_of: Vec<usize> = (0..k).collect();
    let mut stopped = vec![false; k];
    let mut live = k;
    let watch = crate::watch::current();
    let mut ran = 0;
    for s in 0..steps {
        if crate::watch::stop_at(&watch, s, live) {
            break;
        }
        ran = s + 1;
        let mut i = 0;
        while i < live {
            if !stopped[i] {
                i += 1;
                continue;
            }
            live -= 1;
            if i < live {
                xs.copy_within(live * np..(live + 1) * np, i * np);
                slot_of.swap(i, live);
                stopped.swap(i, live);
            }
        }
        if live == 0 {
            break;
        }
        for i in 0..live {
            let c = slot_of[i];
            let col = &columns[c];
            let y = &mut ys[i * d..(i + 1) * d];
            col.readout.apply(simd, &xs[i * np..i * np + n], y);
            stopped[i] = !observers[c].see(s, y);
            col.inputs(s, y, &mut fed[i * d..(i + 1) * d], &mut us[i * u..(i + 1) * u], ctl);
        }
        shared.product(simd, &xs[..live * np], &mut pre[..live * np], (0, np));
        for i in 0..live {
            let c = slot_of[i];
            let col = &columns[c];
            let z = match col.noise {
                NoiseSource::Off => None,
                NoiseSource::Table(t) => Some(&t[s * n..(s + 1) * n]),
                NoiseSource::Drawn { .. } => {
                    if let Some((g, sigma)) = rngs[c].as_mut() {
                        for e in noise.iter_mut() {
                            *e = R::from_f64(*sigma * g.sample::<f64, _>(StandardNormal));
                        }
                    }
                    Some(&noise[..])
                }
            };
            col.dynamics.finish(
                &mut xs[i * np..i * np + n],
                &mut pre[i * np..i * np + n],
                &fed[i * d..(i + 1) * d],
                &us[i * u..(i + 1) * u],
                z,
            );
        }
    }
    crate::watch::finish(&watch, ran, live);
}

/// A value alone on its cache lines, so that two cores writing neighbours do
/// not take the line from each other.
#[repr(align(128))]
struct Line<T>(T);

/// Spins on `flag` until it reaches `at`, yielding the core now and then so
/// that two threads sharing one core still make progress.
fn wait_for(flag: &std::sync::atomic::AtomicUsize, at: usize) {
    let mut spins = 0u32;
    while flag.load(std::sync::atomic::Ordering::Acquire) < at {
        spins = spins.wrapping_add(1);
        if spins.is_multiple_of(4096) {
            std::thread::yield_now();
        } else {
            std::hint::spin_loop();
        }
    }
}

/// One half of a split run: its rows of every step, on its own thread
/// (`observers` only on the calling thread's half).
struct SplitHalf<'a, 'b, R: SimdDot, O> {
    shared: &'a Shared<R>,
    columns: &'a [Column<'b, R>],
    observers: Option<&'a mut [O]>,
    steps: usize,
    t: usize,
    rows: [(usize, usize); 2],
    boxes: &'a [[Line<std::sync::Mutex<Vec<R>>>; 2]; 2],
    done: &'a [Line<std::sync::atomic::AtomicUsize>; 2],
    stop: &'a std::sync::atomic::AtomicBool,
    watch: &'a Option<std::sync::Arc<crate::watch::Watch>>,
}
impl<R: SimdDot, O: Observer<R>> WithSimd for SplitHalf<'_, '_, R, O> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        let SplitHalf { shared, columns, mut observers, steps, t, rows, boxes, done, stop, watch } = self;
        let Shared { n, np, d, u, .. } = *shared;
        let k = columns.len();
        let other = 1 - t;
        let (r0, r1) = rows[t];
        let (a, b) = (r0.min(n), r1.min(n));
        let (oa, ob) = (rows[other].0.min(n), rows[other].1.min(n));
        let mut bufs = StepBuffers::new(shared, columns);
        let StepBuffers { xs, pre, ys, fed, us, ctl } = &mut bufs;
        let (xs, pre) = (xs.as_mut_slice(), pre.as_mut_slice());
        let mut stopped = vec![false; k];
        let mut live = k;
        for s in 0..steps {
            // The calling thread's half (the one with observers) looks at the caller's flag.
            if observers.is_some() && crate::watch::stop_at(watch, s, live) {
                live = 0;
            }
            for (c, col) in columns.iter().enumerate() {
                let y = &mut ys[c * d..(c + 1) * d];
                col.readout.apply(simd, &xs[c * np..c * np + n], y);
                if let Some(obs) = observers.as_deref_mut()
                    && live > 0
                    && !stopped[c]
                    && !obs[c].see(s, y)
                {
                    stopped[c] = true;
                    live -= 1;
                }
                col.inputs(s, y, &mut fed[c * d..(c + 1) * d], &mut us[c * u..(c + 1) * u], ctl);
            }
            if live == 0 {
                if observers.is_some() {
                    crate::watch::finish(watch, s, k);
                }
                stop.store(true, std::sync::atomic::Ordering::Relaxed);
                done[t].0.store(s + 1, std::sync::atomic::Ordering::Release);
                return;
            }
            shared.product(simd, xs, pre, (r0, r1));
            for (c, col) in columns.iter().enumerate() {
                let at = c * np;
                col.dynamics.finish_rows(
                    a,
                    &mut xs[at + a..at + b],
                    &mut pre[at + a..at + b],
                    &fed[c * d..(c + 1) * d],
                    &us[c * u..(c + 1) * u],
                    None,
                );
            }
            let slot = (s + 1) % 2;
            if let Ok(mut m) = boxes[t][slot].0.lock() {
                for (c, dst) in m.chunks_exact_mut((b - a).max(1)).enumerate().take(k) {
                    dst.copy_from_slice(&xs[c * np + a..c * np + b]);
                }
            }
            done[t].0.store(s + 1, std::sync::atomic::Ordering::Release);
            wait_for(&done[other].0, s + 1);
            if stop.load(std::sync::atomic::Ordering::Relaxed) {
                return;
            }
            if let Ok(m) = boxes[other][slot].0.lock() {
                for (c, src) in m.chunks_exact((ob - oa).max(1)).enumerate().take(k) {
                    xs[c * np + oa..c * np + ob].copy_from_slice(src);
                }
            }
        }
    }
}

/// Noise-free free runs split over two threads, each computing half of the
/// rows of `Ŵ·X` for every column (so each core keeps its half of `Ŵ` in its
/// own cache) and finishing those neurons; after every step the two halves of
/// the states are exchanged. The outputs are bit-identical to [`run_columns`]:
/// every neuron's update is the same sequence of operations, only computed on
/// another core. `observers` see the outputs on the calling thread; a column
/// whose observer stopped is no longer shown, and the run ends when all have.
pub(crate) fn run_split<R: SimdDot, O: Observer<R>>(
    shared: &Shared<R>,
    columns: &[Column<'_, R>],
    observers: &mut [O],
    steps: usize,
) {
    use std::sync::Mutex;
    use std::sync::atomic::{AtomicBool, AtomicUsize};
    assert_eq!(columns.len(), observers.len());
    let Shared { n, np, .. } = *shared;
    let k = columns.len();
    if k == 0 {
        return;
    }
    let lanes_mult = crate::kernel::PAD;
    let mid = ((np / 2).div_ceil(lanes_mult) * lanes_mult).min(np);
    let rows = [(0, mid), (mid, np)];
    // Each half's published neurons (real ones only) of every column,
    // double-buffered by step parity.
    let real = |(a, b): (usize, usize)| (a.min(n), b.min(n));
    let boxes: [[Line<Mutex<Vec<R>>>; 2]; 2] = core::array::from_fn(|t| {
        let (a, b) = real(rows[t]);
        core::array::from_fn(|_| Line(Mutex::new(vec![R::ZERO; (b - a) * k])))
    });
    let done = [Line(AtomicUsize::new(0)), Line(AtomicUsize::new(0))];
    let stop = AtomicBool::new(false);
    let watch = crate::watch::current();
    let half = |t: usize, observers: Option<&mut [O]>| {
        shared.arch.dispatch(SplitHalf {
            shared,
            columns,
            observers,
            steps,
            t,
            rows,
            boxes: &boxes,
            done: &done,
            stop: &stop,
            watch: &watch,
        })
    };
    std::thread::scope(|scope| {
        scope.spawn(|| half(1, None));
        half(0, Some(observers));
    });
}

/// During steps `from .. from + len` of a free run, the fed-back outputs are
/// held at `values` (normalised units): the paper's perturbation.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Hold {
    /// First held step.
    pub from: usize,
    /// Number of held steps.
    pub len: usize,
    /// One value per output.
    pub values: Vec<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::dot;

    /// Outputs computed four at a time have the bits of one dot product each,
    /// whatever the output count's remainder and the state's tail.
    #[test]
    fn readout_four_at_a_time_gives_each_outputs_own_dot_product() {
        fn check<R: SimdDot>() {
            for (n, d) in [(1, 1), (17, 4), (33, 5), (300, 7), (301, 22)] {
                let weights: Vec<f64> = (0..n * d).map(|k| ((k * 7919 % 1000) as f64 - 500.0) / 377.0).collect();
                let bias: Vec<f64> = (0..d).map(|k| k as f64 * 0.37 - 1.0).collect();
                let readout = Readout { n_features: n, weights, bias };
                let r = ReadoutR::<R>::new(&readout);
                let x: Vec<R> = (0..n).map(|j| R::from_f64(((j * 104_729 % 997) as f64 - 498.0) / 211.0)).collect();
                struct Op<'a, R: SimdDot>(&'a ReadoutR<R>, &'a [R], &'a mut [R]);
                impl<R: SimdDot> WithSimd for Op<'_, R> {
                    type Output = ();
                    fn with_simd<S: Simd>(self, simd: S) {
                        self.0.apply(simd, self.1, self.2)
                    }
                }
                let mut y = vec![R::ZERO; d];
                pulp::Arch::new().dispatch(Op(&r, &x, &mut y));
                for (k, yk) in y.iter().enumerate() {
                    let want = dot(&r.w[k * n..(k + 1) * n], &x) + r.b[k];
                    assert_eq!(yk.to_f64().to_bits(), want.to_f64().to_bits(), "n {n}, d {d}, output {k}");
                }
            }
        }
        check::<f32>();
        check::<f64>();
    }
}
