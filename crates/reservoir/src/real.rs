//! The two precisions the dynamics run in, with a deterministic `tanh`.
//!
//! `tanh` is computed here, not by the platform's libm, so that a given
//! model, seed and input give bit-identical results on every machine. It is
//! `sign(x)·(1 − 2/(e^{2|x|} + 1))` with `e^y = 2^k·p(r)`, `y = k·ln 2 + r`,
//! `|r| ≤ ln 2 / 2`, and `p` the Taylor polynomial of `e^r` (degree 7 in
//! `f32`, 13 in `f64`). The absolute error is below 2e-7 in `f32` and 1e-15 in
//! `f64` (tested against the standard library). The code is branch-free so
//! that the compiler vectorises it.

use std::fmt::Debug;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A floating-point type the reservoir can run in.
pub trait Real:
    Copy
    + Send
    + Sync
    + Debug
    + PartialOrd
    + Default
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + 'static
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Converts from `f64` (rounding to nearest).
    fn from_f64(v: f64) -> Self;
    /// Converts to `f64` (exact).
    fn to_f64(self) -> f64;
    /// Deterministic hyperbolic tangent (see the module docs).
    fn tanh_det(self) -> Self;
    /// Whether the value is neither NaN nor infinite.
    fn finite(self) -> bool;
}

impl Real for f32 {
    const ZERO: f32 = 0.0;
    const ONE: f32 = 1.0;
    #[inline(always)]
    fn from_f64(v: f64) -> f32 {
        v as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn tanh_det(self) -> f32 {
        // tanh(10) rounds to 1 in f32; clamping keeps 2^k in range.
        let a = self.abs();
        // Not `min`: a NaN must stay NaN so that divergence is detected.
        let a = if a > 10.0 { 10.0 } else { a };
        let y = 2.0 * a;
        // k = round(y / ln 2) with the 1.5·2^23 trick (round to nearest even,
        // vectorisable): the low bits of `t` then hold k itself.
        let t = y * std::f32::consts::LOG2_E + 12_582_912.0;
        let k = t - 12_582_912.0;
        let r = (y - k * 0.693_359_4) + k * 2.121_944_4e-4;
        let p = 1.0
            + r * (1.0
                + r * (0.5
                    + r * (1.0 / 6.0 + r * (1.0 / 24.0 + r * (1.0 / 120.0 + r * (1.0 / 720.0 + r * (1.0 / 5040.0)))))));
        // 2^k from the bits of t (0x4B40_0000 + k for 0 <= k < 2^22): integer
        // operations that vectorise, where a float-to-integer cast does not.
        let scale = f32::from_bits(t.to_bits().wrapping_sub(0x4B40_0000 - 127) << 23);
        let e = p * scale;
        (1.0 - 2.0 / (e + 1.0)).copysign(self)
    }
    #[inline(always)]
    fn finite(self) -> bool {
        self.is_finite()
    }
}

impl Real for f64 {
    const ZERO: f64 = 0.0;
    const ONE: f64 = 1.0;
    #[inline(always)]
    fn from_f64(v: f64) -> f64 {
        v
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn tanh_det(self) -> f64 {
        // tanh(19.1) = 1 − 5e-17 rounds to 1 in f64.
        let a = self.abs();
        let a = if a > 19.1 { 19.1 } else { a };
        let e = cpg_regression::exp_det(2.0 * a);
        (1.0 - 2.0 / (e + 1.0)).copysign(self)
    }
    #[inline(always)]
    fn finite(self) -> bool {
        self.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tanh_matches_the_standard_library() {
        let mut worst32: f64 = 0.0;
        let mut worst64: f64 = 0.0;
        for i in -200_000..=200_000 {
            let x = i as f64 * 1e-4; // −20 … 20
            worst32 = worst32.max(((x as f32).tanh_det() as f64 - (x as f32 as f64).tanh()).abs());
            worst64 = worst64.max((x.tanh_det() - x.tanh()).abs());
        }
        assert!(worst32 < 2e-7, "f32 error {worst32}");
        assert!(worst64 < 1e-15, "f64 error {worst64}");
        assert_eq!(f32::tanh_det(0.0), 0.0);
        assert_eq!(f64::tanh_det(-50.0), -1.0);
        assert_eq!(f32::tanh_det(1e30), 1.0);
        assert!(f64::tanh_det(f64::NAN).is_nan());
        assert!(f32::tanh_det(f32::NAN).is_nan());
        // 2^k from the bits of the rounding constant equals 2^k from a cast.
        for k in 0..=55i64 {
            let t = k as f64 + 6_755_399_441_055_744.0;
            assert_eq!(
                f64::from_bits(t.to_bits().wrapping_sub(0x4338_0000_0000_0000 - 1023) << 52),
                2f64.powi(k as i32)
            );
            if k <= 29 {
                let t = k as f32 + 12_582_912.0;
                assert_eq!(f32::from_bits(t.to_bits().wrapping_sub(0x4B40_0000 - 127) << 23), 2f32.powi(k as i32));
            }
        }
    }
}
