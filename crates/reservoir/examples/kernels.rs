//! Quick timing of the inner kernels (the real benchmarks are `cargo xtask bench`).
#![allow(clippy::unwrap_used)]
use cpg_reservoir::kernel::matmul;
use std::hint::black_box;
use std::time::Instant;

fn main() {
    for n in [300usize, 2000] {
        let w: Vec<f32> = (0..n * n).map(|k| ((k * 7919 % 1000) as f32 - 500.0) / 377.0).collect();
        let x: Vec<f32> = (0..n).map(|k| (k as f32).sin()).collect();
        let mut out = vec![0.0f32; n];
        let reps = if n == 300 { 20000 } else { 500 };
        let t = Instant::now();
        for _ in 0..reps {
            let s: [f32; 16] = black_box(&w).as_chunks::<16>().0.iter().fold([0.0; 16], |mut a, c| {
                for l in 0..16 {
                    a[l] += c[l];
                }
                a
            });
            black_box(s);
        }
        let floor = t.elapsed().as_secs_f64() / reps as f64;
        let t = Instant::now();
        for _ in 0..reps {
            matmul(&w, n, black_box(&x), &mut out);
            black_box(&out);
        }
        let mv = t.elapsed().as_secs_f64() / reps as f64;
        let k = 32;
        let xs: Vec<f32> = (0..n * k).map(|i| (i as f32).cos()).collect();
        let mut o2 = vec![0.0f32; n * k];
        let t = Instant::now();
        for _ in 0..reps / 10 {
            matmul(&w, n, black_box(&xs), &mut o2);
            black_box(&o2);
        }
        let mm = t.elapsed().as_secs_f64() / (reps / 10) as f64 / k as f64;
        println!(
            "n {n}: floor {:.2} µs, matvec {:.2} µs, batched per column {:.2} µs",
            floor * 1e6,
            mv * 1e6,
            mm * 1e6
        );
    }
}
