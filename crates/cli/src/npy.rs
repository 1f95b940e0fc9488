//! `.npy` output (NumPy's array format, read by `numpy.load`), written by npyz.

use std::io::Write;

use npyz::WriterBuilder;

/// Writes `values` (row-major, C order) as a float64 array of `shape`.
pub fn write_npy(w: &mut dyn Write, shape: &[usize], values: impl IntoIterator<Item = f64>) -> anyhow::Result<()> {
    let shape: Vec<u64> = shape.iter().map(|&n| n as u64).collect();
    let mut out = npyz::WriteOptions::<f64>::new().default_dtype().shape(&shape).writer(w).begin_nd()?;
    out.extend(values)?;
    out.finish()?;
    Ok(())
}
