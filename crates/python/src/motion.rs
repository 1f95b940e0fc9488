//! `Motion` and `read_motion`: recorded or generated motion as numpy arrays.

use cpg_lab::format::Format;
use cpg_mocap::{BvhOptions, Skeleton};
use numpy::{IntoPyArray, PyArray2, PyArray3};
use pyo3::prelude::*;
use std::path::PathBuf;

use crate::convert::*;
use crate::errors::*;

/// A motion and (when read from a file) its skeleton.
#[pyclass(module = "cpg._cpg", name = "Motion", frozen)]
pub(crate) struct Motion {
    motion: cpg_mocap::Motion,
    skeleton: Option<Skeleton>,
    format: String,
}

#[pymethods]
impl Motion {
    /// A motion from arrays: `values` frames × channels (anything NumPy reads
    /// as numbers), `channels` their names (`bone.dof`: `lfemur.rx`), at
    /// `rate_hz`. It has no skeleton (no forward kinematics, no files).
    #[new]
    fn new(py: Python<'_>, values: &Bound<'_, PyAny>, channels: Vec<String>, rate_hz: f64) -> PyResult<Motion> {
        let rate_hz = rate_arg(rate_hz, "rate_hz")?;
        let (v, n, d) = matrix(py, values, "values")?;
        if channels.len() != d {
            return Err(err(format!("channels: {} names for {d} columns", channels.len())));
        }
        if let Some(i) = v.iter().position(|x| !(x.is_finite() && x.abs() <= MAX_VALUE)) {
            return Err(err(format!(
                "values: frame {}, channel {} is {}; expected finite values within ±{MAX_VALUE}",
                i / d.max(1),
                i % d.max(1),
                v[i]
            )));
        }
        let parsed = channels
            .iter()
            .map(|c| {
                cpg_mocap::Channel::parse(c)
                    .ok_or_else(|| err(format!("channels: {c:?} is not a channel name (bone.dof, e.g. lfemur.rx)")))
            })
            .collect::<PyResult<Vec<_>>>()?;
        if n == 0 {
            return Err(err("values: no frames"));
        }
        let motion = cpg_mocap::Motion::new(parsed, v, rate_hz).map_err(err)?;
        Ok(Motion { motion, skeleton: None, format: "arrays".into() })
    }

    /// Frames × channels, float64 (degrees for rotations, skeleton units for translations).
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        array2(py, self.motion.values().to_vec(), self.motion.n_frames(), self.motion.n_channels())
    }

    /// Channel names (`bone.dof`), one per column.
    #[getter]
    fn channels(&self) -> Vec<String> {
        self.motion.channel_names()
    }

    /// Frames per second.
    #[getter]
    fn rate_hz(&self) -> f64 {
        self.motion.sample_rate_hz()
    }

    /// Number of frames.
    #[getter]
    fn n_frames(&self) -> usize {
        self.motion.n_frames()
    }

    /// `amc` or `bvh` (with the length unit), or `arrays`.
    #[getter]
    fn format(&self) -> String {
        self.format.clone()
    }

    /// The skeleton as ASF text, if the motion has one.
    #[getter]
    fn skeleton_asf(&self) -> Option<String> {
        self.skeleton.as_ref().map(cpg_mocap::write_asf)
    }

    /// Millimetres per skeleton length unit (None without a skeleton).
    #[getter]
    fn mm_per_unit(&self) -> Option<f64> {
        self.skeleton.as_ref().map(Skeleton::mm_per_unit)
    }

    /// Forward kinematics: (points, names) with points frames × points × 3 in
    /// millimetres (y up): the root and every bone's end.
    fn forward_kinematics<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyArray3<f64>>, Vec<String>)> {
        let sk = self.skeleton.as_ref().ok_or_else(|| err("this motion has no skeleton (it was made from arrays)"))?;
        let p = py.detach(|| sk.forward_kinematics(&sk.complete(&self.motion)?)).map_err(err)?;
        let (n, k) = (p.n_frames(), p.names.len());
        let flat: Vec<f64> = p.points_mm.iter().flatten().copied().collect();
        let a = numpy::ndarray::Array3::from_shape_vec((n, k, 3), flat).map_err(err)?;
        Ok((a.into_pyarray(py), p.names))
    }

    /// The motion with only these channels (names, in this order).
    fn select(&self, channels: Vec<String>) -> PyResult<Motion> {
        let names: Vec<&str> = channels.iter().map(String::as_str).collect();
        Ok(Motion {
            motion: self.motion.select(&names).map_err(err)?,
            skeleton: self.skeleton.clone(),
            format: self.format.clone(),
        })
    }

    /// Writes the motion as BVH (lengths in centimetres) or AMC, by the
    /// extension, atomically: the file holds the old motion or the new one,
    /// never half of one; a missing directory is an error.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        let sk = self.skeleton.as_ref().ok_or_else(|| err("this motion has no skeleton to write it with"))?;
        let format = if cpg_mocap::is_bvh(&path) { Format::Bvh } else { Format::Amc };
        cpg_lab::format::write_motion(&path, format, sk, &self.motion).map_err(err)
    }

    fn __repr__(&self) -> String {
        format!(
            "Motion({} frames × {} channels at {} Hz, {})",
            self.motion.n_frames(),
            self.motion.n_channels(),
            self.motion.sample_rate_hz(),
            self.format
        )
    }
}

/// Reads a motion file: AMC (with `skeleton`, the ASF) or BVH.
#[pyfunction]
#[pyo3(signature = (path, skeleton=None, rate_hz=None, bvh_unit_mm=None))]
pub(crate) fn read_motion(
    py: Python<'_>,
    path: PathBuf,
    skeleton: Option<PathBuf>,
    rate_hz: Option<f64>,
    bvh_unit_mm: Option<f64>,
) -> PyResult<Motion> {
    let rate_hz = rate_hz.map(|r| rate_arg(r, "rate_hz")).transpose()?;
    // Off the GIL on a thread of its own, so that Ctrl-C is answered while a large file is parsed
    // (every parse is bounded: it finishes soon after, unseen).
    let r = interruptible(py, move |_| {
        cpg_mocap::read_recording(&path, skeleton.as_deref(), rate_hz, &BvhOptions { length_unit_mm: bvh_unit_mm })
    })?
    .map_err(err)?;
    let format = match r.format {
        cpg_mocap::Format::Amc => "amc".to_owned(),
        cpg_mocap::Format::Bvh { length_unit_mm, inferred } => {
            format!("bvh ({length_unit_mm} mm per unit{})", if inferred { ", inferred" } else { "" })
        }
    };
    Ok(Motion { motion: r.motion, skeleton: Some(r.skeleton), format })
}
