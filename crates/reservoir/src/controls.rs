//! Control values over time, as the engine and the batched runs read them
//! (below both, so that neither imports the other for it).

/// Control values over time.
pub trait Controls: Sync {
    /// Writes the control values of step `step` into `out` (one per control input).
    fn fill(&self, step: usize, out: &mut [f64]);
}

/// Constant controls.
impl Controls for [f64] {
    fn fill(&self, _step: usize, out: &mut [f64]) {
        out.copy_from_slice(self);
    }
}

impl Controls for Vec<f64> {
    fn fill(&self, _step: usize, out: &mut [f64]) {
        out.copy_from_slice(self);
    }
}
