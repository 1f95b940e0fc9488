//! A deterministic, vectorisable `exp`.

/// `e^x` by range reduction and a degree-13 Taylor polynomial (relative
/// error below 2e-16 for `x` in [−708, 709]; 0 below −708): written so that
/// the compiler vectorises it, which the platform's `exp` is not. The same
/// bits on every machine (no call to the C library): the one deterministic
/// `exp` of the workspace, used by the centralized networks' RBF rows and
/// the reservoir's `tanh`.
#[inline(always)]
pub fn exp_det(x: f64) -> f64 {
    let x = x.clamp(-708.0, 709.0);
    // k = round(x / ln 2) with the 1.5·2^52 trick; the low bits of t hold k + 2^51.
    let t = x * std::f64::consts::LOG2_E + 6_755_399_441_055_744.0;
    let k = t - 6_755_399_441_055_744.0;
    let r = (x - k * 6.931_471_803_691_238e-1) - k * 1.908_214_929_270_587_7e-10;
    const C: [f64; 14] = [
        1.0,
        1.0,
        0.5,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
        1.0 / 40_320.0,
        1.0 / 362_880.0,
        1.0 / 3_628_800.0,
        1.0 / 39_916_800.0,
        1.0 / 479_001_600.0,
        1.0 / 6_227_020_800.0,
    ];
    let mut p = C[13];
    for c in C[..13].iter().rev() {
        p = p * r + c;
    }
    // 2^k in two factors, so that k down to −1022 − 52 stays representable.
    let bits = t.to_bits().wrapping_sub(0x4338_0000_0000_0000);
    let half = (bits as i64) >> 1;
    let a = f64::from_bits(((half + 1023) as u64) << 52);
    let b = f64::from_bits((((bits as i64 - half) + 1023) as u64) << 52);
    p * a * b
}
